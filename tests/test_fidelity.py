"""Texture-space fidelity (issue 10): the beam light integrated over each texel's footprint, ..."""
from __future__ import annotations

import math

import analytic_judge as A
import numpy as np
import pytest
from helpers import first_gathered_step, small_settings

from skinviewer.ground.settings import with_values
from skinviewer.scene.scenes import build_scene

# ---------------------------------------------------------------------------------------------
# item 5: the laser beam keeps its power at every map size


def _beam_power_ratio(renderer, scene, tech, n, offset=(0.0, 0.0), radius=0.02):
    key = "deon.irradiance_size" if tech == "deon" else "gosselin.light_map_size"
    res = "deon_irradiance" if tech == "deon" else "gosselin_light_map"
    s = small_settings(scene, tech, 32, **{key: n, "deon.energy_conservation": False,
                                           "lights.0.position": [offset[0], offset[1], 0.0],
                                           "lights.0.beam_radius": radius})
    renderer.render(s)
    E = renderer.graph(tech).read(res)[..., :3].astype(np.float64)
    m = build_scene(scene).mesh
    _, _, area = A.plane_coords(m.positions, m.uvs, m.mm_per_unit, n)
    L = s.lights[0]
    return E.sum((0, 1)) * area / (math.pi * radius ** 2 * L.intensity)


@pytest.mark.parametrize("n", [256, 512, 1024])
@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.013, -0.007)])
def test_laser_power_at_every_map_size(renderer, n, offset):
    # the 0.02 mm beam at the slab's centre hits a texel corner: point-sampled it lit nothing at
    # 256^2 and 512^2 and carried 1.9x its power at 1024^2
    for tech in ("deon", "gosselin"):
        ratio = _beam_power_ratio(renderer, "laser", tech, n, offset)
        assert np.allclose(ratio, 1.0, atol=0.01), (tech, n, offset, ratio)


def test_beam_power_on_stretched_texels_and_wide_beams(renderer):
    # 4:1 texel footprints (stretch-plane), and a beam wider than many texels
    assert np.allclose(_beam_power_ratio(renderer, "stretch-plane", "deon", 256, (0.011, 0.03)), 1.0, atol=0.01)
    assert np.allclose(_beam_power_ratio(renderer, "laser", "deon", 256, (0.3, -0.2), radius=1.3), 1.0, atol=0.01)


# ---------------------------------------------------------------------------------------------
# items 3-4: transmission (translucent shadow map) without terminator lines, thin parts glow


def _uv_sphere_obj(path, radius=40.0, nlon=128, nlat=64):
    """A lat-long sphere (seam at -x, the side away from a light at +x) written as OBJ."""
    import trimesh
    lon = np.pi + np.linspace(0.0, 2.0 * np.pi, nlon + 1)
    lat = np.linspace(-np.pi / 2, np.pi / 2, nlat + 1)
    LO, LA = np.meshgrid(lon, lat)
    P = np.stack([np.cos(LA) * np.cos(LO), np.sin(LA), np.cos(LA) * np.sin(LO)], -1).reshape(-1, 3) * radius
    UV = np.stack([0.02 + 0.96 * (LO - np.pi) / (2 * np.pi), 0.02 + 0.96 * (LA + np.pi / 2) / np.pi], -1).reshape(-1, 2)
    idx = []
    for j in range(nlat):
        for i in range(nlon):
            a = j * (nlon + 1) + i
            idx += [(a, a + nlon + 1, a + nlon + 2), (a, a + nlon + 2, a + 1)]
    trimesh.Trimesh(P, np.array(idx), process=False, visual=trimesh.visual.TextureVisuals(uv=UV)).export(str(path))
    return str(path)


def test_no_red_line_along_the_terminator(renderer, tmp_path):
    """A 40 mm sphere lit from +x, seen from +z: the image's middle row runs along the equator (a
    great circle) across the terminator at its centre. The red channel must fall monotonically from
    the lit side into the shadow: the TSM term used the depth below the lit point (-> 0 at grazing
    light) and put a red line just past the terminator."""
    mesh = _uv_sphere_obj(tmp_path / "sphere.obj")
    s = small_settings("head", "deon", 192, **{
        "scene.mesh": mesh, "scene.mm_per_unit": 1.0, "camera.yaw": 0.0, "camera.pitch": 0.0,
        "camera.distance": 200.0, "camera.target": [0.0, 0.0, 0.0], "deon.irradiance_size": 512,
        "deon.tsm_size": 512, "specular.rho_s": 0.0,
        "lights": [{"kind": "directional", "direction": [1.0, 0.0, 0.0], "intensity": 2.0, "cast_shadow": True}]})
    renderer.render(s)
    lit = renderer.read(s, "lit")[..., :3].astype(np.float64)
    row = lit[lit.shape[0] // 2, :, 0]
    n = row.size
    # the sphere spans about the middle 60 % of the row; from its lit limb (right) to its dark limb
    inside = np.nonzero(lit[lit.shape[0] // 2, :, :].sum(-1) > 0)[0]
    seg = row[n // 2 - int(0.25 * n): n // 2 + int(0.25 * n)][::-1]  # lit -> dark
    assert seg[0] > 0.05, (seg[0], inside)
    rises = np.diff(seg)
    assert np.all(rises <= 1e-4 * seg[0]), np.round(seg * 1000).astype(int)


def test_backlit_ear_transmits_the_thin_slab_profile(renderer):
    """backlit-ear (a flap 1.5 mm thick at the top, 6 mm at the bottom) lit from behind: at the
    front points 2, 3 and 4 mm thick the final image is C^(1-mix) sum_i w_i exp(-m^2/2v_i) blur_i(uv_A),
    m the path through the flap along the light, A where that ray enters the back (seed 000 eq. 33).
    (helpers.backlit_ear_deviation; benchmarks/claims.py prints the same figures for the README.)"""
    from helpers import backlit_ear_deviation
    for d, dev in backlit_ear_deviation(renderer).items():
        # red: measured +3.4 / +3.2 / +1.7 % at 2 / 3 / 4 mm (llvmpipe, 160^2 image, 512^2 maps; the TSM's
        # texel footprint and the blurs' rim renormalisation); the band is 1.4x the largest, below a
        # lost transmission (-100 %) or the albedo split C^(1-mix) taken twice (-17 %)
        assert -0.01 < dev[0] < 0.06, (d, dev)


def test_gutter_table_zones_each_texel_to_its_nearest_island():
    """B: the zone (nearest island), negative on a zone's border; A: texels to the nearest border."""
    from skinviewer.passes.texture_space import gutter_table
    c = np.zeros((12, 24), bool)
    c[2:10, 2:7] = True
    c[2:10, 14:20] = True
    t = gutter_table(c)
    zone = np.abs(t[..., 2])
    assert set(np.unique(zone)) == {1.0, 2.0} and (zone[:, :10] == zone[5, 3]).all() and (zone[:, 11:] == zone[5, 15]).all()
    assert (t[..., 2][:, 10:12] < 0).all() and (t[..., 2][:, :10] > 0).all()  # the border between the zones
    assert t[5, 3, 3] == 7 and t[5, 9, 3] == 1  # distance (texels) to the border
    assert (t[c][:, :2] == np.argwhere(c)[:, ::-1]).all()  # RG: an island texel is its own source


@pytest.mark.parametrize("tech", ["deon", "gosselin"])
def test_no_light_crosses_a_uv_gutter(renderer, tech):
    """backlit-ear's front and back are two UV islands 0.04 apart; the red blur reaches farther
    (3 sigma = 32 texels at 256^2, the gutter is 10). Without transmission the front, lit by nothing,
    stays black: no tap of the back's lit irradiance lands on it across the gutter. Gosselin in mm
    with one iteration reaches as far (15 % of the back's light on the front before)."""
    extra = {"deon.tsm": False} if tech == "deon" else {"gosselin.radius_mode": "mm", "gosselin.iterations": 1}
    s = small_settings("backlit-ear", tech, 64, **extra)
    renderer.render(s)
    g = renderer.graph(tech)
    res = "deon_diffuse" if tech == "deon" else "gosselin_blurred"
    D = g.read(res)[..., 0].astype(np.float64)
    n = D.shape[0]
    front = D[:, : int(0.49 * n)]
    assert front.max() <= 1e-6 * D.max(), front.max() / D.max()
    off = with_values(s, {"scene.seam_aware": False})  # the gutters as before: the blur reads across them
    renderer.render(off)
    leak = renderer.graph(tech).read(res)[..., 0][:, : int(0.49 * n)].max()
    assert leak > 1e-3 * D.max()


def test_islands_a_texel_apart_keep_their_own_light(renderer, tmp_path):
    """Two 40 mm plates 10 mm apart in 3D, their UV islands 1.3 texels apart at 256^2; a beam lights
    the left one up to the edge beside the gap. The right plate stays black (no tap reads across the
    gutter), and the left one's texels beside it (on its zone's border) keep their light."""
    import trimesh

    from skinviewer.scene.scenes import _merge, grid
    upm, n = 0.0093, 256
    w = 40.0 * upm
    parts = []
    for x0, u0 in ((-25.0, 0.02), (25.0, 0.02 + w + 1.3 / n)):
        p, nrm, uv, idx = grid(20, 20, 40.0, 40.0, uv_rect=(u0, 0.5 - w / 2, u0 + w, 0.5 + w / 2))
        p[:, 0] += x0
        parts.append((p, nrm, uv, idx))
    P, _, UV, F = _merge(parts)
    path = tmp_path / "plates.obj"
    trimesh.Trimesh(P, F, process=False, visual=trimesh.visual.TextureVisuals(uv=UV)).export(str(path))
    D = _diffused(renderer, str(path), True, n, beam=(-20.0, 15.5))[..., 0]
    j = n // 2
    a_edge = int((0.02 + w) * n) - 1  # the left island's last texel column
    b = D[:, a_edge + 3:int((0.02 + 2 * w) * n)]
    assert b.max() <= 1e-6 * D.max(), b.max() / D.max()
    assert D[j, a_edge] > 0.3 * D[j, a_edge - 8] > 0, (D[j, a_edge - 8:a_edge + 3])


def test_an_open_border_diffuses_like_a_half_plane(renderer, tmp_path):
    """A uniformly lit open plate: at a texel delta mm inside its border the diffused light is
    sum_i w_i Phi(delta / sigma_i) of the interior's (the integral over the surface that is there, as
    the ground truth computes it), within 0.035; the edge texel used to be repeated into the gutter,
    giving the interior's light (1.0) right up to the border."""
    from scipy.stats import norm
    n, upm = 256, 0.0093
    path, _, _ = _plane_obj(tmp_path / "plate.obj", False, uv_per_mm=upm)
    D = _diffused(renderer, path, True, n, beam=(0.0, 500.0))
    prof = [(0.5, [0.4, 0.6, 0.8]), (3.0, [0.6, 0.4, 0.2])]  # _diffused's profile
    u0 = (0.5 - 40.0 * upm) * n  # the border, texels
    i0, j = math.ceil(u0 - 0.5), n // 2
    for k in range(6):
        delta = (i0 + k + 0.5 - u0) / (n * upm)
        expect = sum(np.asarray(w) * norm.cdf(delta / math.sqrt(v)) for v, w in prof)
        got = D[j, i0 + k] / D[j, n // 2]
        assert np.abs(got - expect).max() < 0.035, (k, delta, got, expect)


def test_backlit_flap_transmits_alike_at_both_sides(renderer):
    """The flap is symmetric in x and the light has no x component: its left and right edges (the
    front island's u = 0.02 and 0.48) transmit the same. The TSM's 'already carried by the blur'
    term (lib/tsm_transmit.glsl) used to measure the front-back distance in UV across islands,
    which is small at one edge only: a dark band there, hidden by the gutter leak."""
    s = small_settings("backlit-ear", "deon", 64)
    renderer.render(s)
    D = renderer.graph("deon").read("deon_diffuse")[..., 0].astype(np.float64)
    n = D.shape[0]
    for v in (0.3, 0.5, 0.7):
        row = D[int(v * n)]
        # texels as far inside either edge (the light falls towards an open border)
        left, right = row[math.ceil(0.02 * n - 0.5) + 2], row[math.floor(0.48 * n - 0.5) - 2]
        assert abs(right / left - 1) < 0.05, (v, left, right)


def test_no_transmission_through_the_head(renderer):
    """Light from behind the default head, seen from the front: the face (~150 mm of head behind
    it) gets no transmitted light; the thin ears do. Before: red contours along every terminator."""
    from skinviewer.ground.settings import with_values
    n = 160
    s = small_settings("head", "deon", n, **{"camera.yaw": 0.0, "camera.pitch": 5.0, "deon.irradiance_size": 512,
                                             "deon.tsm_size": 512, "shadow.map_size": 1024,
                                             "lights": [{"kind": "directional", "direction": [0.0, 0.15, -1.0],
                                                         "intensity": 3.0, "cast_shadow": True}]})
    renderer.render(s)
    on = renderer.read(s, "lit")[..., 0].astype(np.float64).copy()
    renderer.render(with_values(s, {"deon.tsm": False}))
    off = renderer.read(s, "lit")[..., 0].astype(np.float64)
    t = on - off
    face = t[int(0.3 * n):int(0.8 * n), int(0.38 * n):int(0.62 * n)]  # between the ears
    assert face.max() < 1e-3, (face.max(), np.argwhere(face >= 1e-3)[:10])
    assert t.max() > 0.05  # the ears glow


def _roof_obj(path):
    """A ground plane (z = 0, 40 mm) and, over x > 0, a roof: two sheets at z = 1 and 1.5 mm."""
    import trimesh

    from skinviewer.scene.scenes import _merge, grid
    top = grid(40, 80, 20.0, 40.0, uv_rect=(0.02, 0.65, 0.48, 0.98), z=1.5)
    bottom = grid(40, 80, 20.0, 40.0, uv_rect=(0.52, 0.65, 0.98, 0.98), z=1.0, flip=True)
    top[0][:, 0] += 10.0
    bottom[0][:, 0] += 10.0
    P, _, UV, F = _merge([grid(80, 80, 40.0, 40.0, uv_rect=(0.02, 0.02, 0.98, 0.6)), top, bottom])
    trimesh.Trimesh(P, F, process=False, visual=trimesh.visual.TextureVisuals(uv=UV)).export(str(path))
    return str(path)


def test_a_grazing_shadow_does_not_creep_under_its_occluder(renderer, tmp_path):
    """Light 80 degrees from the ground's normal over the roof's edge: the roof's top sheet shades
    the ground out to x = -1.5 tan 80 = -8.5 mm. The shadow lookup's normal offset slides sideways
    at grazing light, past the occluder's silhouette in the map (the light that lit the scan's
    concha); with the receiver-plane depth bias the offset is smaller: half light within 2 mm of
    the edge on a 128^2 map (before: 4.1 mm inside the shadow)."""
    a = math.radians(80.0)
    s = small_settings("laser", "deon", 32, **{
        "scene.mesh": _roof_obj(tmp_path / "roof.obj"), "scene.mm_per_unit": 1.0, "deon.irradiance_size": 1024,
        "shadow.map_size": 128, "deon.tsm": False, "deon.energy_conservation": False,
        "camera.target": None, "camera.distance": None,
        "lights": [{"kind": "directional", "direction": [math.sin(a), 0.0, math.cos(a)], "intensity": 1.0,
                    "cast_shadow": True}]})
    renderer.render(s)
    E = renderer.graph("deon").read("deon_irradiance")[..., 0].astype(np.float64)
    n = E.shape[0]
    row = E[int(0.31 * n)]  # y = 0 on the ground
    x = ((np.arange(n) + 0.5) / n - 0.02) / 0.96 * 40.0 - 20.0
    f = row / row[(x > -19) & (x < -16)].mean()
    k = np.nonzero((x > -16) & (f < 0.5))[0][0]  # the first texel under half light
    half = np.interp(0.5, [f[k], f[k - 1]], [x[k], x[k - 1]])
    assert abs(half + 1.5 * math.tan(a)) < 2.0, half


def test_a_sphere_does_not_shadow_itself_at_grazing_light(renderer, tmp_path):
    """Phong on a sphere lit from the side: wherever N.L > 0.05 the shadowed image equals the
    unshadowed one within 3 % (no acne, no false darkening towards the terminator)."""
    mesh = _uv_sphere_obj(tmp_path / "sphere.obj")
    light = {"kind": "directional", "direction": [1.0, 0.3, 0.2], "intensity": 1.0, "cast_shadow": True}
    s = small_settings("head", "phong", 160, **{
        "scene.mesh": mesh, "scene.mm_per_unit": 1.0, "camera.yaw": 0.0, "camera.pitch": 0.0,
        "camera.distance": 200.0, "camera.target": [0.0, 0.0, 0.0], "specular.rho_s": 0.0, "lights": [light], "shadow.map_size": 256})
    renderer.render(s)
    a = renderer.read(s, "lit")[..., 0].astype(np.float64).copy()
    renderer.render(with_values(s, {"lights": [{**light, "cast_shadow": False}]}))
    b = renderer.read(s, "lit")[..., 0].astype(np.float64)
    lit = b > 0.05 * b.max()
    assert np.all(a[lit] >= 0.97 * b[lit]), (np.count_nonzero(a[lit] < 0.97 * b[lit]), (a[lit] / b[lit]).min())


def _fold_obj(path, half_band: float = 1.5, thickness: float = 2.0):
    """A sheet ``thickness`` mm thick (faces z = +-thickness/2, 40 mm square) and, 1.5 mm behind it, a
    strip 2 mm thick and 2 * half_band wide along y: lit from -z the strip shades a band of the
    sheet's back face, as an ear's fold shades the sheet behind it (half_band 0: no strip). UV
    islands per face, open borders."""
    import trimesh

    from skinviewer.scene.scenes import _merge, grid
    w, h = 2 * half_band, 0.5 * thickness
    parts = [grid(40, 40, 40.0, 40.0, uv_rect=(0.02, 0.02, 0.48, 0.48), z=h),
             grid(40, 40, 40.0, 40.0, uv_rect=(0.52, 0.02, 0.98, 0.48), z=-h, flip=True)]
    if w > 0:
        parts += [grid(6, 40, w, 40.0, uv_rect=(0.02, 0.52, 0.02 + 0.46 * w / 40, 0.98), z=-h - 1.5),
                  grid(6, 40, w, 40.0, uv_rect=(0.52, 0.52, 0.52 + 0.46 * w / 40, 0.98), z=-h - 3.5, flip=True)]
    P, _, UV, F = _merge(parts)
    trimesh.Trimesh(P, F, process=False, visual=trimesh.visual.TextureVisuals(uv=UV)).export(str(path))
    return str(path)


@pytest.mark.parametrize("gather", [16, 0])
def test_a_fold_transmits_the_light_lit_beside_its_ray(renderer, tmp_path, gather):
    """Issue 10 item 4: the sheet's front behind the shaded band receives, through its 2 mm, the
    back face lit beyond the band (3D distances: sum_i w_i exp(-2^2/2v_i) erfc(b/sqrt(2v_i)) E) and the
    strip's far face through 5.5 mm. Eq. 33 on the ray alone sees only the strip and leaves the
    band dark; the light-space gather (deon.tsm_gather) finds the lit back face beside the ray."""
    from scipy.special import erfc
    b = 1.5
    s = small_settings("laser", "deon", 32, **{
        "scene.mesh": _fold_obj(tmp_path / "fold.obj", b), "scene.mm_per_unit": 1.0, "deon.irradiance_size": 512,
        "deon.tsm_size": 512, "shadow.map_size": 1024, "deon.energy_conservation": False, "deon.tsm_gather": gather,
        "camera.target": None, "camera.distance": None,
        "lights": [{"kind": "directional", "direction": [0.0, 0.0, -1.0], "intensity": 1.0, "cast_shadow": True}]})
    renderer.render(s)
    g = renderer.graph("deon")
    D = g.read("deon_diffuse")[..., 0].astype(np.float64)
    E = g.read("deon_irradiance")[..., 0].astype(np.float64)
    n = D.shape[0]
    e_back = E[int(0.25 * n), int((0.52 + 0.46 * 0.2) * n)]  # the back face, lit, 12 mm from the band
    v = np.array([x.variance for x in s.deon.gaussians])
    w = np.array([x.weights[0] for x in s.deon.gaussians])
    k = np.sqrt(2 * v)
    expect = e_back * (w * (np.exp(-4 / (2 * v)) * erfc(b / k) + np.exp(-5.5 ** 2 / (2 * v)) * (1 - erfc(b / k)))).sum()
    got = D[int(0.25 * n), int(0.25 * n)]  # the front face behind the band's centre
    if gather:
        assert abs(got / expect - 1) < 0.15, (got, expect)
    else:
        assert got < 0.5 * expect, (got, expect)  # the failure the gather mends


def test_a_membrane_thinner_than_the_tsm_gate_transmits(renderer, tmp_path):
    """A 0.3 mm sheet lit from behind: along the ray its back face is within the TSM's depth tolerance
    (two texels, at least 0.25 mm), which eq. 33 treats as C itself, lit. C faces away from the light,
    so it is not lit: the gathered Gaussians transmit sum_i w_i exp(-0.3^2 / 2v_i) E (before: ~10 %)."""
    prof = [{"variance": 1.0, "weights": [0.5, 0.5, 0.5]}, {"variance": 4.0, "weights": [0.5, 0.5, 0.5]}]
    s = small_settings("laser", "deon", 32, **{
        "scene.mesh": _fold_obj(tmp_path / "membrane.obj", 0.0, 0.3), "scene.mm_per_unit": 1.0,
        "deon.irradiance_size": 512, "deon.tsm_size": 512, "deon.energy_conservation": False,
        "deon.gaussians": prof, "camera.target": None, "camera.distance": None,
        "lights": [{"kind": "directional", "direction": [0.0, 0.0, -1.0], "intensity": 1.0, "cast_shadow": True}]})
    renderer.render(s)
    g = renderer.graph("deon")
    T = g.read("deon_transmitted")[..., 0].astype(np.float64)
    E = g.read("deon_irradiance")[..., 0].astype(np.float64)
    e_back = E[int(0.25 * E.shape[0]), int(0.75 * E.shape[0])]
    expect = e_back * sum(0.5 * math.exp(-0.09 / (2 * p["variance"])) for p in prof)
    got = T[int(0.25 * T.shape[0]), int(0.25 * T.shape[0])]
    assert abs(got / expect - 1) < 0.05, (got, expect)


# ---------------------------------------------------------------------------------------------
# item 1: seam-aware blurs


def _plane_obj(path, cut: bool, size=80.0, uv_per_mm=0.0093):
    """An 80 mm plane (normal +z), uncut (one UV island) or cut along x = 0 into two islands 0.22
    apart in u (the same texel density either way)."""
    import trimesh

    from skinviewer.scene.scenes import _merge, grid
    w = size * uv_per_mm
    if cut:
        parts = []
        for x0, u0 in ((-size / 4, 0.02), (size / 4, 0.98 - w / 2)):
            p, nrm, uv, idx = grid(20, 40, size / 2, size, uv_rect=(u0, 0.5 - w / 2, u0 + w / 2, 0.5 + w / 2))
            p[:, 0] += x0
            parts.append((p, nrm, uv, idx))
        P, _, UV, F = _merge(parts)
    else:
        P, _, UV, F = grid(40, 40, size, size, uv_rect=(0.5 - w / 2, 0.5 - w / 2, 0.5 + w / 2, 0.5 + w / 2))
    trimesh.Trimesh(P, F, process=False, visual=trimesh.visual.TextureVisuals(uv=UV)).export(str(path))
    return str(path), UV, P


def _diffused(renderer, mesh, seam_aware=True, n=256, beam=(2.5, 2.0), **extra):
    from skinviewer.passes.deon import mean_texel_mm
    from skinviewer.physics.diffusion import blur_plan_texels, texture_of
    prof = [{"variance": 0.5, "weights": [0.4, 0.6, 0.8]}, {"variance": 3.0, "weights": [0.6, 0.4, 0.2]}]
    s = small_settings("laser", "deon", 32, **{
        "scene.mesh": mesh, "scene.mm_per_unit": 1.0, "scene.seam_aware": seam_aware, "deon.irradiance_size": n,
        "deon.tsm": False, "deon.energy_conservation": False, "deon.gaussians": prof,
        "deon.reuse_irradiance_below_texels": 0.0, "camera.target": None, "camera.distance": None,
        "deon.half_res_above_texels": 0.0,  # every blur at n^2: the sum below reads them texel by texel
        "lights": [{"kind": "beam", "direction": [0.0, 0.0, 1.0], "position": [beam[0], 0.0, 0.0], "beam_radius": beam[1],
                    "intensity": 1.0, "cast_shadow": False}], **extra})
    renderer.render(s)
    g = renderer.graph("deon")
    plan = blur_plan_texels([x["variance"] for x in prof], 0.0, mean_texel_mm(renderer.scene.gpu, n))
    return sum(np.asarray(x["weights"]) * g.read(texture_of(p))[..., :3].astype(np.float64) for x, p in zip(prof, plan))


def test_diffusion_across_a_uv_cut_equals_the_uncut_plane(renderer, tmp_path):
    """A beam beside the cut (2.5 mm right of it, 2 mm radius): the blurred irradiance on both islands equals the uncut plane's at
    the same surface points (within 2 % of the peak); with gutters that repeat the island's edge
    texel (scene.seam_aware off) it does not."""
    from scipy.ndimage import map_coordinates
    n, upm = 256, 0.0093
    cut, _, _ = _plane_obj(tmp_path / "cut.obj", True, uv_per_mm=upm)
    whole, _, _ = _plane_obj(tmp_path / "whole.obj", False, uv_per_mm=upm)
    ref = _diffused(renderer, whole, n=n)
    w = 80.0 * upm

    def compare(D):
        errs = []
        for u0, x0 in ((0.02, -40.0), (0.98 - w / 2, 0.0)):
            i0, i1 = int(np.ceil(u0 * n)), int((u0 + w / 2) * n) - 1
            j0, j1 = int(np.ceil((0.5 - w / 2) * n)), int((0.5 + w / 2) * n) - 1
            jj, ii = np.mgrid[j0:j1 + 1, i0:i1 + 1]
            x = x0 + ((ii + 0.5) / n - u0) / upm           # mm on the plane
            ui = ((0.5 - w / 2) + (x + 40.0) * upm) * n - 0.5  # the uncut map's texel coordinate there
            for c in range(3):
                r = map_coordinates(ref[..., c], [jj.astype(float), ui], order=1)
                errs.append(np.abs(D[j0:j1 + 1, i0:i1 + 1, c] - r).max() / ref[..., c].max())
        return max(errs)

    err_on = compare(_diffused(renderer, cut, True, n))
    err_off = compare(_diffused(renderer, cut, False, n))
    print(f"uv cut: max error seam-aware {err_on:.4f}, edge-texel gutters {err_off:.4f}")
    assert err_on < 0.02 and err_off > 0.05, (err_on, err_off)


# ---------------------------------------------------------------------------------------------
# item 2: stretch with shear


def _sheared_plane_obj(path, shear_deg: float, upm=0.0096):
    """A 60 mm plane, u = 0.5 + upm (x + y tan(shear)), v = 0.5 + upm y: texels sheared by
    ``shear_deg`` on the surface (the same texel area either way)."""
    import trimesh

    from skinviewer.scene.scenes import grid
    P, _, UV, F = grid(40, 40, 60.0, 60.0)
    t = np.tan(np.radians(shear_deg))
    UV = np.stack([0.5 + upm * (P[:, 0] + P[:, 1] * t), 0.5 + upm * P[:, 1]], 1)
    trimesh.Trimesh(P, F, process=False, visual=trimesh.visual.TextureVisuals(uv=UV)).export(str(path))
    return str(path)


@pytest.mark.parametrize("gather", [2.0, 0.0], ids=["gather", "separable"])
def test_sheared_uvs_diffuse_like_unsheared(renderer, tmp_path, gather):
    """Seed 000 eq. 27 keeps per-axis lengths only: on UVs skewed by 30 deg the blur came out
    anisotropic. With the full Jacobian (the default) the profile matches the unsheared plane's within
    2 % of the peak at the same surface points; per-axis lengths miss by more than 5 % when every
    step is separable. (The narrow step that deon.surface_gather_below_texels sums over the surface
    does not use the stretch at all.)"""
    from scipy.ndimage import map_coordinates
    n, upm = 256, 0.0096
    g = {"deon.surface_gather_below_texels": gather}
    # the same taps on both: a plane with no shear at all takes whole-texel taps (deon_blur NARROW_TAPS),
    # which a sheared second pass cannot; 0.02 deg of shear keeps the bilinear ones and changes nothing else
    ref = _diffused(renderer, _sheared_plane_obj(tmp_path / "plane.obj", 0.02), n=n, beam=(0.0, 1.0), **g)
    D = _diffused(renderer, _sheared_plane_obj(tmp_path / "sheared.obj", 30.0), n=n, beam=(0.0, 1.0), **g)
    t = np.tan(np.radians(30.0))
    jj, ii = np.mgrid[0:n, 0:n]
    y = ((jj + 0.5) / n - 0.5) / upm
    x = ((ii + 0.5) / n - 0.5) / upm - y * t
    keep = (np.hypot(x, y) < 12.0)
    err = 0.0
    for c in range(3):
        r = map_coordinates(ref[..., c], [(0.5 + upm * y) * n - 0.5, (0.5 + upm * x) * n - 0.5], order=1)
        err = max(err, np.abs(D[..., c] - r)[keep].max() / ref[..., c].max())
    D0 = _diffused(renderer, _sheared_plane_obj(tmp_path / "sheared.obj", 30.0), n=n, beam=(0.0, 1.0),
                   **{"deon.stretch_shear": False}, **g)  # eq. 27's per-axis lengths
    err0 = 0.0
    for c in range(3):
        r = map_coordinates(ref[..., c], [(0.5 + upm * y) * n - 0.5, (0.5 + upm * x) * n - 0.5], order=1)
        err0 = max(err0, np.abs(D0[..., c] - r)[keep].max() / ref[..., c].max())
    print(f"sheared plane: max error {err:.4f} of the peak (per-axis stretch: {err0:.4f})")
    assert err < 0.02, err
    assert err0 > 0.05 or gather, err0


def _eig2(S: np.ndarray) -> np.ndarray:
    """Eigenvalues of the symmetric 2x2 matrices (S_uu, S_uv, S_vv), ascending."""
    return np.linalg.eigvalsh(np.stack([np.stack([S[:, 0], S[:, 1]], -1), np.stack([S[:, 1], S[:, 2]], -1)], -2))


def test_vertex_uv_covariance_is_the_inverse_metric_and_ignores_uv_slivers():
    """physics/diffusion.vertex_uv_covariance: on a plane with a linear (sheared) map it is
    (J^T J)^-1 exactly at every vertex; and where a vertex is collapsed in UV onto its neighbour
    (two triangles degenerate to slivers whose own covariance is ~0 across: the per-triangle stretch
    would stop the blur there), its vertices keep a covariance within 2x of the plane's."""
    from skinviewer.physics.diffusion import triangle_uv_covariance, vertex_uv_covariance
    from skinviewer.scene.scenes import grid
    P, _, _, F = grid(8, 8, 60.0, 60.0)
    t, upm = np.tan(np.radians(30.0)), 0.0096
    UV = np.stack([0.5 + upm * (P[:, 0] + P[:, 1] * t), 0.5 + upm * P[:, 1]], 1)
    J = np.array([[1.0, 0.0], [t, 1.0]]).T * upm  # UV per mm: d(u, v) / d(x, y)
    S_true = J @ J.T                               # UV covariance of a unit surface Gaussian
    S = vertex_uv_covariance(P, UV, F, 1.0)
    assert np.allclose(S, [S_true[0, 0], S_true[0, 1], S_true[1, 1]], rtol=1e-4)
    k = 4 * 9 + 4  # the centre vertex, collapsed in UV towards its +x neighbour
    UV2 = UV.copy()
    UV2[k] = UV[k + 1] + (UV[k] - UV[k + 1]) * 1e-3
    around = (F == k).any(1)
    St, ok, _ = triangle_uv_covariance(P, UV2, F, 1.0)
    ev_true = np.linalg.eigvalsh(S_true)
    assert (_eig2(St[around])[:, 0] < 1e-5 * ev_true[0]).sum() == 2  # the two slivers
    S2 = vertex_uv_covariance(P, UV2, F, 1.0)
    ring = np.unique(F[around].ravel())
    ev = _eig2(S2[ring])
    assert (ev > 0.5 * ev_true).all() and (ev < 2.0 * ev_true).all(), ev / ev_true
    far = np.setdiff1d(np.arange(len(P)), np.unique(F[(np.isin(F, ring)).any(1)].ravel()))
    assert np.allclose(S2[far], S[far], rtol=1e-6)


def test_stretch_map_of_a_sheared_plane_is_its_jacobian(renderer, tmp_path):
    """deon_stretch.frag in both modes, against numpy (physics/diffusion.stretch_from_uv_covariance of
    vertex_uv_covariance) and the analytic map of UVs skewed 30 deg: s_u = upm, s_v = upm cos 30,
    shear c = -sin 30."""
    from skinviewer.physics.diffusion import stretch_from_uv_covariance, vertex_uv_covariance
    from skinviewer.scene.mesh import load_mesh
    upm, n = 0.0096, 256
    path = _sheared_plane_obj(tmp_path / "sheared.obj", 30.0, upm)
    m = load_mesh(path)
    want = stretch_from_uv_covariance(vertex_uv_covariance(m.positions, m.uvs, m.indices, 1.0))
    assert np.allclose(want, [upm, upm * np.cos(np.radians(30.0)), -0.5], rtol=1e-4)
    for mode in ("vertex", "triangle"):
        s = small_settings("laser", "deon", 32, **{"scene.mesh": path, "scene.mm_per_unit": 1.0,
                                                   "deon.irradiance_size": n, "scene.stretch_metric": mode,
                                                   "camera.target": None, "camera.distance": None})
        renderer.render(s)
        g = renderer.graph("deon")
        st, gut = g.read("deon_stretch"), g.read(f"gutter_{n}")
        yy, xx = np.mgrid[0:n, 0:n]
        cov = (gut[..., 0] == xx) & (gut[..., 1] == yy)
        assert cov.sum() > 1000
        assert np.allclose(st[cov][:, :3], want[0], rtol=2e-3, atol=1e-6), (mode, st[cov][:, :3].min(0), st[cov][:, :3].max(0))


def _stretch_jumps(renderer, mode: str, n: int = 256) -> np.ndarray:
    """|log| ratio of the u stretch between horizontally adjacent island texels (2 texels inside)."""
    from scipy import ndimage
    s = small_settings("head", "deon", 32, **{"deon.irradiance_size": n, "scene.stretch_metric": mode,
                                              "deon.subpixel_kernel_px": 0.0})
    renderer.render(s)
    g = renderer.graph("deon")
    st, gut = g.read("deon_stretch"), g.read(f"gutter_{n}")
    yy, xx = np.mgrid[0:n, 0:n]
    inner = ndimage.binary_erosion((gut[..., 0] == xx) & (gut[..., 1] == yy), iterations=2)
    a = np.log(st[..., 0])
    return np.abs(a[:, 1:] - a[:, :-1])[inner[:, 1:] & inner[:, :-1]]


def test_vertex_metric_stretch_is_smooth_where_the_triangles_are_not(renderer):
    """scene.stretch_metric = vertex (default): the stretch map interpolates the per-vertex metric, so
    neighbouring texels differ little even where the triangles' own stretch jumps (issue 10 items 1-2).
    Measured on the default head at 256^2: p99 neighbour ratio 2.13 (triangle) -> 1.34, largest 9.1 -> 2.9."""
    tri = np.exp(_stretch_jumps(renderer, "triangle"))
    ver = np.exp(_stretch_jumps(renderer, "vertex"))
    assert np.percentile(tri, 99) > 1.8 and tri.max() > 6.0  # the per-triangle map does jump
    assert np.percentile(ver, 99) < 1.5 and ver.max() < 4.0


@pytest.mark.parametrize("gather", [2.0, 0.0], ids=["gather", "separable"])
def test_laser_error_falls_with_map_size(renderer, gather):
    """Issue 10 item 5: the d'Eon laser error (l1 radial, seed 002 §14.4.1) falls from 256^2 to 512^2 and
    stays at its floor above. Separable: a blur of 1-8 texels takes whole-texel taps (deon_blur.frag
    NARROW_TAPS) instead of bilinear taps whose own smoothing added variance (512^2 was worse than
    256^2); 256^2 is still 1-4 %. With the narrow steps summed over the surface (the default) 256^2 is
    already at the floor (0.2 %)."""
    from skinviewer.passes.deon import DIFFUSE
    from skinviewer.physics.diffusion import IRRADIANCE
    from skinviewer.scene.scenes import build_scene
    m = build_scene("laser").mesh
    errs = {}
    for n in (256, 512, 1024):
        s = small_settings("laser", "deon", 32, **{"deon.irradiance_size": n, "deon.energy_conservation": False,
                                                   "deon.surface_gather_below_texels": gather})
        renderer.render(s)
        g = renderer.graph("deon")
        D, E = (g.read(x)[..., :3].astype(np.float64) for x in (DIFFUSE, IRRADIANCE))
        X, Y, area = A.plane_coords(m.positions, m.uvs, m.mm_per_unit, n)
        gs = s.deon.gaussians
        errs[n] = A.laser_errors(D, E, X, Y, area, [x.variance for x in gs], [x.weights for x in gs])["l1"]
    if gather:
        assert np.all(errs[256] < 0.005) and np.all(errs[512] <= errs[256]), errs
    else:
        assert np.all(errs[512] < 0.5 * errs[256]), errs
    assert np.all(errs[1024] <= errs[512] + 0.002) and np.all(errs[1024] < 0.01), errs


def test_tissue_only_reference_does_not_couple_across_air():
    """scene.texels.surface_diffusion_reference with normals: two plates facing each other 1 mm apart
    (lips touching) exchange light through 3D distance, but not through tissue; a flat plate alone is
    unchanged by the option."""
    from skinviewer.scene.texels import surface_diffusion_reference
    n = 16
    g = (np.arange(n) - n / 2 + 0.5) * 0.5  # mm
    X, Y = np.meshgrid(g, g)
    pos = np.zeros((n, 2 * n, 3))
    pos[:, :n] = np.stack([X, Y, np.zeros_like(X)], -1)          # lower plate, normal +z
    pos[:, n:] = np.stack([X, Y, np.ones_like(X)], -1)           # upper plate above it, normal -z
    nrm = np.zeros_like(pos)
    nrm[:, :n, 2], nrm[:, n:, 2] = 1.0, -1.0
    E = np.zeros((n, 2 * n, 3))
    E[:, :n] = 1.0  # only the lower plate is lit
    area = np.full((n, 2 * n), 0.25)
    cov = np.ones((n, 2 * n), bool)
    v, w = [1.0], [(1.0, 1.0, 1.0)]
    through_air = surface_diffusion_reference(E, pos, area, cov, v, w)
    tissue = surface_diffusion_reference(E, pos, area, cov, v, w, normals=nrm)
    assert through_air[:, n:, 0].max() > 0.1  # the 3D-distance reference lights the upper plate
    assert tissue[:, n:, 0].max() == 0.0 and np.allclose(tissue[:, :n], 1.0)
    flat = surface_diffusion_reference(E[:, :n], pos[:, :n], area[:, :n], cov[:, :n], v, w)
    assert np.array_equal(flat, surface_diffusion_reference(E[:, :n], pos[:, :n], area[:, :n], cov[:, :n], v, w,
                                                            normals=nrm[:, :n]))


def _hairpin(fold_mm: float = 1.0, plate_mm: float = 24.0, width_mm: float = 8.0, step: float = 1.0):
    """A strip folded back on itself (a lip or an eyelid margin seen in section): a top plate at
    z = +fold, a half cylinder of radius ``fold`` and a bottom plate at z = -fold, one UV island.
    Returns (positions mm, uvs, indices, arc length s per vertex)."""
    arc = np.pi * fold_mm
    total = 2 * plate_mm + arc
    s = np.unique(np.r_[np.arange(0.0, total, step), np.arange(plate_mm, plate_mm + arc, step / 4), total])
    y = np.arange(0.0, width_mm + 1e-9, step)
    S, Y = np.meshgrid(s, y, indexing="ij")
    th = np.clip((S - plate_mm) / fold_mm, 0.0, np.pi)
    X = np.where(S < plate_mm, plate_mm - S, np.where(S > plate_mm + arc, S - plate_mm - arc, -fold_mm * np.sin(th)))
    Z = np.where(S < plate_mm, fold_mm, np.where(S > plate_mm + arc, -fold_mm, fold_mm * np.cos(th)))
    P = np.stack([X, Y, Z], -1).reshape(-1, 3)
    UV = np.stack([0.05 + 0.9 * S / total, 0.3 + 0.4 * Y / width_mm], -1).reshape(-1, 2)
    ns, ny = len(s), len(y)
    q = (np.arange(ns - 1)[:, None] * ny + np.arange(ny - 1)[None, :]).ravel()
    F = np.concatenate([np.stack([q, q + ny, q + 1], 1), np.stack([q + 1, q + ny, q + ny + 1], 1)])
    return P, UV, F, S.ravel()


def test_surface_path_reference_couples_along_the_surface_only():
    """scene.texels.SurfacePaths: on a strip folded back on itself 2 mm thick, the 3D-distance
    reference lights the bottom plate under a spot on the top plate (2 mm away in 3D, ~35 mm along the
    surface) and dilutes the spot with it; the surface-path reference does neither, yet carries light
    round the fold itself."""
    from skinviewer.scene.texels import SurfacePaths, surface_diffusion_reference, texel_surface
    P, UV, F, _ = _hairpin()
    n = 128
    tri, pos, area = texel_surface(P, UV, F, n)
    cov = tri >= 0
    E = np.zeros((n, n, 3))
    spot = cov & (np.hypot(pos[..., 0] - 16.0, pos[..., 1] - 4.0) < 2.0) & (pos[..., 2] > 0.9)  # top plate
    E[spot] = 1.0
    fold_lit = cov & (pos[..., 0] < 0.5) & (pos[..., 2] > 0.5)  # the top plate's end and the fold's top
    E[fold_lit] = 1.0
    v, w = [4.0], [(1.0, 1.0, 1.0)]
    sp = SurfacePaths(P, F, tri, pos, 1.0, reach_mm=3.5 * 2.0)
    d3 = surface_diffusion_reference(E, pos, area, cov, v, w)
    ds = surface_diffusion_reference(E, pos, area, cov, v, w, surface_paths=sp)
    below = cov & (np.hypot(pos[..., 0] - 16.0, pos[..., 1] - 4.0) < 1.0) & (pos[..., 2] < -0.9)
    assert below.sum() > 4
    assert d3[below, 0].min() > 0.1            # through the 2 mm gap
    assert ds[below, 0].max() < 1e-6           # not along the surface
    around = cov & (pos[..., 0] < 0.5) & (pos[..., 2] < -0.5) & (pos[..., 2] > -0.99)  # the fold's lower half
    assert around.sum() > 4 and ds[around, 0].mean() > 0.5 * d3[around, 0].mean() > 0.01  # round the fold
    top = cov & (np.hypot(pos[..., 0] - 16.0, pos[..., 1] - 4.0) < 1.0) & (pos[..., 2] > 0.9)
    assert (ds[top, 0] > 1.5 * d3[top, 0]).all()  # the 3D reference dilutes the spot with the dark plate below


# ---------------------------------------------------------------------------------------------
# item 1: narrow blur steps as a direct sum over the surface (deon.surface_gather_below_texels)


def _seam_filled(E, seam):
    """shaders/seam_fill.frag in numpy (light): across a seam the bilinear value there, past a border
    the edge's value times the share in A."""
    from scipy.ndimage import map_coordinates
    out = np.array(E, np.float64)
    across = (seam[..., 2] > 0.5) & (seam[..., 2] < 1.5)
    ys, xs = np.nonzero(across)
    for c in range(4):
        out[ys, xs, c] = map_coordinates(E[..., c], [seam[ys, xs, 1], seam[ys, xs, 0]], order=1, mode="nearest")
    past = seam[..., 2] > 1.5
    out[past, :3] *= seam[past, 3:4]
    return out


def test_surface_gather_shader_agrees_with_its_numpy_twin(renderer):
    """deon_gather_blocks.frag + deon_surface_gather.frag against physics/surface_gather.py on the
    default head at 256^2 (seams, folds, lips and ears; the first blur, straight from the
    irradiance): the island texels agree within 1e-3 of the largest, the weights being kept as half floats
    (issue 27; measured 3.8e-4; 2e-6 when the sum computed them itself)."""
    from skinviewer.passes.deon import GATHER_SURFACE, STRETCH
    from skinviewer.passes.texture_space import gutter_resource, seam_resource
    from skinviewer.physics.diffusion import IRRADIANCE, blur_resource
    from skinviewer.physics.surface_gather import gather_blocks_for, surface_gather
    n = 256
    s = small_settings("head", "deon", 32, **{"deon.irradiance_size": n, "deon.tsm": False, "deon.subpixel_kernel_px": 0.0})
    g, texel, step = first_gathered_step(renderer, s, n)
    gut = g.read(gutter_resource(n)).astype(np.float64)
    E = _seam_filled(g.read(IRRADIANCE).astype(np.float64), g.read(seam_resource(n)).astype(np.float64))
    got = g.read(blur_resource(step.index)).astype(np.float64)
    blocks = gather_blocks_for(np.sqrt(step.increment) / texel)  # the reach follows sigma (issue 27)
    assert blocks < 5
    args = (g.read(GATHER_SURFACE), np.abs(gut[..., 2]), g.read(STRETCH), step.increment, blocks)
    want = surface_gather(E, *args)
    island = (gut[..., 0] == np.arange(n)[None, :]) & (gut[..., 1] == np.arange(n)[:, None])
    assert island.sum() > 0.3 * n * n
    err = np.abs(got - want)[island].max(0) / np.maximum(np.abs(want[island]).max(0), 1e-12)
    # the weights kept in half floats (issue 27, deon_gather_weights.frag): measured 3.8e-4 of the largest
    assert np.all(err < 1e-3), err  # the split's own twins: tests/test_surface_gather_split.py


def _density_jump_obj(path, ratio: float = 4.0):
    """A 60 mm plane whose UVs are `ratio` x denser per mm left of x = 0 than right of it (continuous
    UVs, no seam): texels of 0.33 mm beside texels of 1.3 mm at 256^2, as where a scan's atlas changes
    scale between neighbouring triangles."""
    import trimesh

    from skinviewer.scene.scenes import grid
    P, _, _, F = grid(60, 60, 60.0, 60.0)
    a = 0.45 / (30.0 * ratio + 30.0)  # UV per mm right of the jump
    u = np.where(P[:, 0] < 0, 0.5 + ratio * a * P[:, 0], 0.5 + a * P[:, 0])
    UV = np.stack([u, 0.5 + 0.0075 * P[:, 1]], 1)
    trimesh.Trimesh(P, F, process=False, visual=trimesh.visual.TextureVisuals(uv=UV)).export(str(path))
    return str(path)


@pytest.mark.parametrize("gather", [2.0, 0.0], ids=["gather", "separable"])
def test_a_jump_in_texel_size_diffuses_like_the_surface(renderer, tmp_path, gather):
    """Issue 10 item 1's worst texels sit where the atlas's texel size jumps. A beam beside a 4x jump:
    against the 3D-distance sum over the same texels (scene/texels.surface_diffusion_reference), the
    narrow step summed over the surface (the default) is within 6 % of the peak; separable taps,
    placed by one texel's stretch, miss by over 10 % (measured 4.6 and 14 %)."""
    from skinviewer.physics.diffusion import IRRADIANCE
    from skinviewer.scene.texels import surface_diffusion_reference, texel_surface
    n = 256
    D = _diffused(renderer, _density_jump_obj(tmp_path / "jump.obj"), True, n, beam=(4.0, 3.0),
                  **{"deon.surface_gather_below_texels": gather})
    m = renderer.scene.gpu.mesh
    tri, pos, area = texel_surface(m.positions, m.uvs, m.indices, n, 1.0)
    E = renderer.graph("deon").read(IRRADIANCE)[..., :3].astype(np.float64)
    ref = surface_diffusion_reference(E, pos, area, tri >= 0, [0.5, 3.0], [[0.4, 0.6, 0.8], [0.6, 0.4, 0.2]])
    err = (np.abs(D - ref)[tri >= 0].max(0) / ref[tri >= 0].max(0)).max()
    print(f"texel-size jump: max error {err:.4f} of the peak")
    assert err < 0.06 if gather else err > 0.10, err


def _default_table():
    """The default d'Eon Gaussians as arrays: variances (mm^2) and RGB weights."""
    from skinviewer.ground.settings import Settings
    g = Settings().deon.gaussians
    return np.array([x.variance for x in g]), np.array([x.weights for x in g])


def _step(X: np.ndarray, cov: np.ndarray, offset: float) -> np.ndarray:
    """U = 1 where x + 0.37 y > offset on the covered texels (point-sampled at X, as a technique)."""
    E = np.zeros(X.shape[:2] + (3,))
    E[(X[..., 0] + 0.37 * X[..., 1] > offset) & cov] = 1.0
    return E


def test_the_supersampled_judge_is_converged_on_its_own_terms():
    """scene.texels.supersampled_diffusion_reference (the seam bench's judge): a shadow step across a
    plane's 40^2 map (1 mm texels, not along the grid). One level finer (JUDGE_LEVEL + 2) changes the
    figure it gives a texel-centre sum (the old judge's discretisation, as a technique's) by < 10 % of
    itself, while that figure itself is far from 0: the texel-centre sum is not a judge."""
    from skinviewer.physics import metrics
    from skinviewer.scene.scenes import grid
    from skinviewer.scene.texels import (
        JUDGE_LEVEL,
        supersampled_diffusion_reference,
        surface_diffusion_reference,
        texel_surface,
    )
    v, w = _default_table()
    pos, _, uv, idx = grid(8, 8, 40.0, 40.0)
    n = 40
    tri, P, area = texel_surface(pos, uv, idx, n, 1.0)
    cov = tri >= 0
    E = _step(P, cov, 0.3)
    lit = cov & (E.max(-1) > 0)
    centres = surface_diffusion_reference(E, P, area, cov, v, w)
    figs = [metrics.p99_rel(centres, supersampled_diffusion_reference(E, cov, pos, uv, idx, n, 1.0, v, w, level=L), lit)
            for L in (JUDGE_LEVEL, JUDGE_LEVEL + 2)]
    assert np.all(np.abs(figs[1] - figs[0]) < 0.1 * figs[0]), figs
    assert figs[0].max() > 0.05, figs


def _slanted_shadow_plane(n: int, offset: float = 0.3):
    """A plane of n mm with n^2 1 mm texels, lit (U = 1) where x + 0.37 y > offset: the texel surface,
    and parts / visible callables that test the shadow at the point itself (as Surface's rays do)."""
    from skinviewer.scene.scenes import grid
    from skinviewer.scene.texels import texel_surface
    pos, _, uv, idx = grid(8, 8, float(n), float(n))
    P = np.asarray(pos, np.float64)
    F = np.asarray(idx, np.int64).reshape(-1, 3)

    def visible(t, b):
        p = np.einsum("nk,nkd->nd", b, P[F[t]])
        return (p[:, 0] + 0.37 * p[:, 1] > offset)[None]

    def parts(t, b):
        return np.ones((1, len(t), 3)), visible(t, b)
    tri, X, area = texel_surface(pos, uv, idx, n, 1.0)
    return (pos, uv, idx), (tri, X, area), parts, visible


def test_the_ray_cast_judge_is_converged_on_its_own_terms_and_casts_rays_only_near_the_shadow():
    """scene.texels.RayCastIrradiance (issue 30 item 4: E = unshadowed x visibility at each judge
    sample, nothing from the technique's map): on a plane with a slanted shadow step (64^2 map, 1 mm
    texels), one level finer (RAY_LEVEL + 1) changes the p99 it gives a texel-centre sum by < 10 % of
    itself while that p99 is far from 0, and it casts under half the rays a dense sampling would
    (the fine visibility only in the band where the nodes disagree)."""
    from skinviewer.physics import metrics
    from skinviewer.scene.texels import (
        RAY_LEVEL,
        RayCastIrradiance,
        supersampled_diffusion_reference,
        surface_diffusion_reference,
    )
    v, w = _default_table()
    n = 64
    (pos, uv, idx), (tri, X, area), parts, visible = _slanted_shadow_plane(n)
    cov = tri >= 0
    E = _step(X, cov, 0.3)  # point-sampled at texel centres, as a technique
    lit = cov & (E.max(-1) > 0)
    centres = surface_diffusion_reference(E, X, area, cov, v, w)
    figs, rays = [], []
    for L in (RAY_LEVEL, RAY_LEVEL + 1):
        irr = RayCastIrradiance(uv, idx, n, cov, parts, visible, 1.0, math.sqrt(v.min()), level=L)
        figs.append(metrics.p99_rel(centres, supersampled_diffusion_reference(
            None, cov, pos, uv, idx, n, 1.0, v, w, irradiance=irr), lit))
        rays.append(irr.rays / (cov.sum() * irr.kv ** 2))
    assert np.all(np.abs(figs[1] - figs[0]) < 0.1 * figs[0]), figs
    assert figs[0].min() > 0.02, figs
    assert max(rays) < 0.5, rays


def test_the_ray_cast_judge_shares_no_shadow_with_the_technique():
    """A technique whose shadow edge is 2 mm off: the map judge blurs the technique's own map and
    scores it about as well as a right one (RMS ~1-2 %); the ray-cast judge sees the edge where the
    surface has it and scores it > 5x worse. Its E comes from the surface, not from the map."""
    from skinviewer.physics import metrics
    from skinviewer.scene.texels import RayCastIrradiance, supersampled_diffusion_reference, surface_diffusion_reference
    v, w = _default_table()
    n = 48
    (pos, uv, idx), (tri, X, area), parts, visible = _slanted_shadow_plane(n)
    cov = tri >= 0
    E = _step(X, cov, 2.3)  # the edge 2 mm off
    lit = cov & (X[..., 0] + 0.37 * X[..., 1] > 0.3)  # where the surface is lit
    technique = surface_diffusion_reference(E, X, area, cov, v, w)
    own = supersampled_diffusion_reference(E, cov, pos, uv, idx, n, 1.0, v, w)
    ray = supersampled_diffusion_reference(None, cov, pos, uv, idx, n, 1.0, v, w,
                                           irradiance=RayCastIrradiance(uv, idx, n, cov, parts, visible, 1.0,
                                                                        math.sqrt(v.min())))
    e_own, e_ray = metrics.rel_rms(technique, own, lit), metrics.rel_rms(technique, ray, lit)
    assert np.all(e_ray > 5 * e_own), (e_own, e_ray)
