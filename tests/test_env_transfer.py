"""SH transfer vectors of the environment light (issue 32; Sloan, Kautz & Snyder 2002): the basis
against scipy's spherical harmonics, the Embree bake against quadrature on an open plane and at the
foot of a wall, AO and bent normal recovered from the vector, and the vertex stage's GLSL twin."""
from __future__ import annotations

import math

import moderngl
import numpy as np
import pytest

from skinviewer.ground.paths import shaders_dir
from skinviewer.physics import environment as env
from tests.helpers import flat_grid


def _grid(n=12, size=20.0):
    return flat_grid(n, size / 2.0)  # a flat grid size wide (tests/helpers.py)


def _hemisphere_quadrature(visible, n_theta=400, n_phi=800):
    """Directions of the upper (+z) hemisphere on a midpoint grid with their solid angles, kept where
    ``visible(d)``: an integration that shares nothing with the bake's stratified rays."""
    th = (np.arange(n_theta) + 0.5) / n_theta * (math.pi / 2)
    ph = (np.arange(n_phi) + 0.5) / n_phi * 2 * math.pi
    T, F = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(T) * np.cos(F), np.sin(T) * np.sin(F), np.cos(T)], -1).reshape(-1, 3)
    w = (np.sin(T) * (math.pi / 2 / n_theta) * (2 * math.pi / n_phi)).reshape(-1)
    keep = visible(d)
    return d[keep], w[keep]


def test_sh25_is_scipys_real_spherical_harmonics():
    try:
        from scipy.special import sph_harm_y  # scipy >= 1.15
    except ImportError:  # older scipy (pyproject allows 1.10): sph_harm(m, l, azimuth, polar)
        from scipy.special import sph_harm

        def sph_harm_y(l, m, polar, azimuth):
            return sph_harm(m, l, azimuth, polar)
    d = np.random.default_rng(3).normal(size=(500, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ours = env.sh_basis25(d)
    np.testing.assert_allclose(ours[:, :9], env.sh_basis(d))  # R&H's nine come first, unchanged
    th, ph = np.arccos(d[:, 2]), np.arctan2(d[:, 1], d[:, 0])
    k = 0
    for l in range(5):
        for m in range(-l, l + 1):
            y = sph_harm_y(l, abs(m), th, ph)
            ref = y.real if m == 0 else math.sqrt(2) * (y.imag if m < 0 else y.real)
            sign = np.sign(ref @ ours[:, k])  # the Condon-Shortley phase differs between conventions; 6-digit constants
            np.testing.assert_allclose(sign * ours[:, k], ref, atol=1e-5, err_msg=f"Y_{l},{m}")
            k += 1


def test_unoccluded_transfer_reproduces_the_sh_irradiance():
    P, N, F = _grid()
    T = env.bake_transfer(P, N, F, rays=1024).astype(np.float64)
    np.testing.assert_allclose(T, env.transfer_unoccluded(N), atol=0.01)  # stratified MC of the clamped cosine
    img = env.builtin_environment("studio")
    L = env.sh_project25(img)
    E = env.sh_irradiance_coefficients(env.sh_project(img))
    want = env.sh_irradiance(E, N)
    np.testing.assert_allclose(env.transfer_irradiance(T, L, 2), want, rtol=0.01)
    # order 4 is closer to the exact (texel-summed) irradiance than R&H's order 2
    exact = env.irradiance_exact(img, N[:1])[0]
    assert abs(env.transfer_irradiance(T, L, 4)[0] - exact).max() < 0.5 * abs(want[0] - exact).max()


def test_plane_at_the_foot_of_a_box_loses_the_blocked_half():
    import trimesh
    P, N, F = _grid(n=5, size=2.0)
    box = trimesh.creation.box(extents=(2000.0, 4000.0, 2000.0))
    bp = np.asarray(box.vertices) + np.array([1000.0 + 1.2, 0.0, 1000.0 - 1.0])  # the wall face at x = 1.2
    Pm = np.r_[P, bp]
    Fm = np.r_[F, np.asarray(box.faces) + len(P)]
    T = env.bake_transfer(Pm, np.r_[N, np.tile([1.0, 0, 0], (len(bp), 1))], Fm, rays=4096)[:len(P)].astype(np.float64)
    for i in (6, 12, 18):  # plane vertices at x = -0.5, 0, 0.5: what they see of the box, by quadrature
        d, w = _hemisphere_quadrature(lambda d: d[:, 0] <= 0)  # the wall takes every direction towards +x
        want = (env.sh_basis25(d) * (d[:, 2] * w)[:, None]).sum(0)
        np.testing.assert_allclose(T[i], want, atol=0.02)
    assert env.transfer_ao(T[12:13])[0] == pytest.approx(0.5, abs=0.01)
    bent = env.transfer_bent_normal(T[12:13], N[12:13])[0]  # int V cos w dw = (-2/3, 0, pi/3)
    np.testing.assert_allclose(bent, np.array([-2 / 3, 0.0, math.pi / 3]) / math.hypot(2 / 3, math.pi / 3), atol=0.01)
    # the studio's key soft box is on the camera's left (-x): a wall at +x leaves it, a wall at -x takes it
    img = env.builtin_environment("studio")
    L, E = env.sh_project25(img), env.sh_irradiance_coefficients(env.sh_project(img))
    d, w = _hemisphere_quadrature(lambda d: d[:, 0] < 0)
    exact = (env.sample_equirect(img, d) * (d[:, 2] * w)[:, None]).sum(0)
    got = env.transfer_irradiance(T[12:13], L)[0]
    ao_sh = env.env_diffuse_transfer(E, L, N[12:13], N[12:13], T[12:13], order=0)[0]
    assert abs(got - exact).max() < 0.1 * exact.max()
    assert abs(got - exact).max() < abs(ao_sh - exact).max()


def test_ao_and_bent_normal_come_out_of_the_transfer_vector():
    """The same rays (seed, chunk) give bake_visibility's AO exactly; the bent normal agrees with a
    4 096-ray bake_visibility (the transfer bake integrates the unoccluded part exactly)."""
    import trimesh
    P, N, F = _grid(n=8, size=10.0)
    box = trimesh.creation.box(extents=(4.0, 4.0, 4.0))
    Pm = np.r_[P, np.asarray(box.vertices) + np.array([3.0, 0.0, 2.5])]
    Fm = np.r_[F, np.asarray(box.faces) + len(P)]
    Nm = np.r_[N, np.tile([0.0, 0.0, 1.0], (8, 1))]
    vis = env.bake_visibility(Pm, Nm, Fm, rays=64, chunk=2048)
    T = env.bake_transfer(Pm, Nm, Fm, rays=64, chunk=2048)
    assert vis[:len(P), 3].min() < 0.8  # some vertices see the box
    np.testing.assert_allclose(env.transfer_ao(T), vis[:, 3], atol=1e-5)
    fine = env.bake_visibility(Pm, Nm, Fm, rays=4096)[:len(P)]
    T = env.bake_transfer(Pm, Nm, Fm, rays=1024)[:len(P)]
    seen = fine[:, 3] > 0.3  # under the box the bent normal is the direction of a few stray rays
    assert seen.sum() > 50
    np.testing.assert_allclose(env.transfer_bent_normal(T, N)[seen], fine[seen, :3], atol=0.02)


def test_an_unoccluded_vertex_has_the_exact_transfer():
    """The bake's control variate: nothing blocks, no Monte Carlo error at any ray count."""
    P, N, F = _grid()
    np.testing.assert_allclose(env.bake_transfer(P, N, F, rays=16), env.transfer_unoccluded(N), atol=1e-6)


VERT = """#version 330 core
#define ENV_LIGHT 1
#define ENV_RAYS 64
#define ENV_TRANSFER {order}
{mesh_vs}
out vec4 v_out;
uniform int u_count;
void main() {{
    ENV_VIS_OUT();
    v_out = v_env_vis;
    gl_PointSize = 1.0;
    gl_Position = vec4((float(gl_VertexID) + 0.5) / float(u_count) * 2.0 - 1.0, 0.0, 0.0, 1.0);
}}
"""
FRAG = """#version 330 core
in vec4 v_out;
out vec4 o;
void main() { o = v_out; }
"""


@pytest.mark.parametrize("order", [4, 2, 0])
def test_vertex_stage_transfer_agrees_with_numpy(gl_ctx, order):
    lib = shaders_dir() / "lib"
    mesh_vs = (lib / "mesh_vs.glsl").read_text().replace('#include "env_sh.glsl"', (lib / "env_sh.glsl").read_text())
    prog = gl_ctx.program(vertex_shader=VERT.format(order=order, mesh_vs=mesh_vs), fragment_shader=FRAG)
    rng = np.random.default_rng(11)
    n = 64
    Nv = rng.normal(size=(n, 3))
    Nv /= np.linalg.norm(Nv, axis=1, keepdims=True)
    T = env.transfer_unoccluded(Nv) * rng.uniform(0.2, 1.0, size=(n, 25))  # partly occluded vectors
    img = env.builtin_environment("window")
    L = env.sh_project25(img, 30.0)
    L[env.TRANSFER_BAND > order] = 0.0
    E = env.sh_irradiance_coefficients(env.sh_project(img, 30.0))
    if "u_env_L" in prog:  # not in the AO x SH variant
        prog["u_env_L"].write(L[:prog["u_env_L"].array_length].astype(np.float32).tobytes())  # cut to what is kept
    if "u_env_sh" in prog:
        prog["u_env_sh"].write(E.astype(np.float32).tobytes())
    prog["u_count"].value = n
    tbuf = np.zeros((n, 28), np.float32)
    tbuf[:, :25] = T
    vb_t, vb_n = gl_ctx.buffer(tbuf.tobytes()), gl_ctx.buffer(Nv.astype(np.float32).tobytes())
    names = [f"in_env_t{k}" for k in range(7)]
    fmt = " ".join("4f" if a in prog else "16x" for a in names)
    content = [(vb_t, fmt, *[a for a in names if a in prog])]
    if "in_normal" in prog:
        content.append((vb_n, "3f", "in_normal"))
    vao = gl_ctx.vertex_array(prog, content)
    out = gl_ctx.texture((n, 1), 4, dtype="f4")
    fbo = gl_ctx.framebuffer([out])
    fbo.use()
    fbo.viewport = (0, 0, n, 1)
    fbo.clear()
    vao.render(moderngl.POINTS, vertices=n)
    got = np.frombuffer(out.read(), np.float32).reshape(n, 4).astype(np.float64)
    for o in (vao, fbo, out, vb_t, vb_n, prog):
        o.release()
    want = env.env_diffuse_transfer(E, L, Nv, Nv, T, order=order)
    np.testing.assert_allclose(got[:, :3], want, rtol=2e-4, atol=2e-5 * want.max())
    np.testing.assert_allclose(got[:, 3], env.transfer_ao(T), atol=1e-5)


# -- the environment in the background (render.background_environment) ------------------------------

def _view_dirs(s, renderer, size):
    from skinviewer.scene.camera import framed_view
    view = framed_view(s.camera, renderer.scene.gpu, (size, size))
    inv = np.linalg.inv(view.view_proj)
    j, i = np.mgrid[0:size, 0:size]  # j: GL rows, bottom first
    ndc = np.stack([(i + 0.5) / size * 2 - 1, (j + 0.5) / size * 2 - 1], -1).reshape(-1, 2)
    far = np.c_[ndc, np.ones(len(ndc)), np.ones(len(ndc))] @ inv.T
    d = far[:, :3] / far[:, 3:] - view.eye
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _sphere_hits(s, renderer, size, radius=50.0):
    """Per pixel of the rendered view of a sphere of ``radius`` at the origin: (view direction, the
    normal where the ray meets the sphere, pixels well inside its disc (N.V > 0.3))."""
    from skinviewer.scene.camera import framed_view
    d = _view_dirs(s, renderer, size)
    view = framed_view(s.camera, renderer.scene.gpu, (size, size))
    b = d @ view.eye
    disc = b * b - (view.eye @ view.eye - radius ** 2)
    t = -b - np.sqrt(np.maximum(disc, 0))
    n = (view.eye + t[:, None] * d) / radius
    return d, n, (disc > 0) & ((n * -d).sum(1) > 0.3)


def test_background_shows_the_environment_through_each_pixel(renderer):
    from skinviewer.ground.settings import with_values
    from skinviewer.passes.output import tone_map
    from tests.helpers import small_settings
    n = 64
    base = small_settings(technique="phong", size=n)
    d = base.model_dump()
    d["lights"] = [{"kind": "environment", "environment": "studio", "intensity": 1.5, "yaw": 70.0,
                    "cast_shadow": False}]
    base = base.model_validate({**d, "camera": {**d["camera"], "yaw": 160.0}})
    images = {}
    for mode in ("off", "sharp", "blurred"):
        s = with_values(base, {"render.background_environment": mode})
        renderer.render(s)
        g = renderer.graph("phong")
        images[mode] = g.read("image")[..., :3].astype(np.float64).reshape(-1, 3)
        alpha = g.read("lit")[..., 3].reshape(-1)
    bg = alpha == 0
    assert bg.sum() > 0.3 * n * n
    np.testing.assert_allclose(images["off"][bg], np.broadcast_to(base.render.background, (bg.sum(), 3)),
                               atol=1 / 255)  # the background colour (sRGB)
    img = env.builtin_environment("studio")
    dirs = _view_dirs(base, renderer, n)[bg]

    def shown(L):
        c = tone_map(1.5 * L * base.render.exposure)
        return np.where(c <= 0.0031308, c * 12.92, 1.055 * c ** (1 / 2.4) - 0.055)
    err = np.abs(images["sharp"][bg] - shown(env.sample_equirect(img, dirs, 70.0)))
    assert np.median(err) < 2 / 255 and np.percentile(err, 99) < 0.05  # the texture is 1024 x 512 bilinear
    assert np.ptp(images["sharp"][bg].sum(1)) > 0.2  # the room's wall and floor
    h = env.SPEC_SIZE[1]
    level = env.prefilter_specular(img)[h:2 * h]  # blurred: the m = 0.15 level
    err = np.abs(images["blurred"][bg] - shown(env.sample_equirect(level, dirs, 70.0)))
    assert np.median(err) < 2 / 255 and np.percentile(err, 99) < 0.05
    assert np.abs(images["blurred"][bg] - images["sharp"][bg]).mean() > 0.02  # the soft box's glow spreads


# -- Phong's environment specular --------------------------------------------------------------------

@pytest.mark.parametrize("n", [8.0, 32.0, 128.0])
def test_phong_lobe_albedo_is_the_integral_of_the_lobe(n):
    t = (np.arange(200000) + 0.5) / 200000 * (math.pi / 2)  # N.L = cos t at V = N, H halfway
    lobe = np.sqrt((1 + np.cos(t)) / 2) ** n * np.cos(t) * np.sin(t)
    assert env.phong_env_albedo(n) == pytest.approx(2 * math.pi * lobe.sum() * (math.pi / 2 / 200000), rel=1e-6)


def test_phong_sphere_adds_the_pre_filtered_environment_specular(renderer, tmp_path):
    """Phong (ambient 0) on a convex sphere: C x E_SH(n) + phong.specular x the lobe's albedo x the
    radiance pre-filtered at R — the GLSL against physics/environment.env_phong_specular per pixel."""
    from skinviewer.engine.reference import DEFAULT_SKIN_SRGB
    from skinviewer.ground.settings import with_values
    from skinviewer.physics.color import srgb_to_linear
    from skinviewer.scene.environment import environment_image
    from tests.helpers import small_settings
    from tests.test_environment import _env_lights, _sphere_obj
    mesh = _sphere_obj(tmp_path / "sphere.obj")
    size = 96
    s = with_values(small_settings(technique="phong", size=size), {
        "scene.mesh": str(mesh), "scene.mm_per_unit": 1.0, "phong.ambient": 0.0, "phong.specular": 0.6,
        "phong.shininess": 24.0, "camera.yaw": 30.0, "camera.pitch": 20.0})
    s = s.model_validate({**s.model_dump(), **_env_lights(environment="studio", occlusion=False, yaw=40.0,
                                                           intensity=1.0)})
    renderer.render(s)
    lit = renderer.graph("phong").read("lit")[..., :3].astype(np.float64).reshape(-1, 3)
    d, n, inner = _sphere_hits(s, renderer, size)
    img = environment_image("studio")
    E_lm = env.sh_irradiance_coefficients(env.sh_project(img, 40.0))
    diffuse = srgb_to_linear(np.array(DEFAULT_SKIN_SRGB)) * env.sh_irradiance(E_lm, n[inner])
    spec = env.env_phong_specular(env.prefilter_specular(img), n[inner], -d[inner], 24.0, 0.6, yaw_deg=40.0)
    got = lit[inner]
    assert inner.sum() > 2000 and spec.max() > 0.5 * diffuse.max()  # the soft box's highlight is in view
    assert np.median(np.abs(got - diffuse - spec) / (diffuse + spec).max()) < 0.01
    assert np.percentile(np.abs(got - diffuse - spec), 99) / (diffuse + spec).max() < 0.05  # facets
    assert np.percentile(np.abs(got - diffuse), 95) / (diffuse + spec).max() > 0.05  # the specular is there


# -- pre-integrated skin's environment term (Penner) --------------------------------------------------

def _band_limited_environment(w=128, h=64):
    """An environment whose radiance is a polynomial of degree 2 in the direction: SH order 2 holds it exactly."""
    d = env.equirect_directions(w, h)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    base = 1.0 + 0.6 * y + 0.4 * x - 0.3 * z + 0.5 * x * y + 0.4 * (z * z - 0.3)
    return np.stack([base, 0.8 * base + 0.2 * x, 0.6 * base - 0.1 * y], -1) * 0.5


def test_penner_band_factors_scatter_the_environment_as_the_ring_table_does():
    """int L(w) D(N.w, k) dw by summing texels, with D read from the ring table's row, against the SH
    irradiance with each band scaled by env_band_factors (Funk-Hecke)."""
    from skinviewer.ground.settings import Settings
    from skinviewer.passes.penner import profile
    from skinviewer.physics import penner
    s = Settings()
    n = 64
    ring = penner.ring_lut(list(profile(s.deon.gaussians)), n, 2.0)
    w = penner.env_band_factors(ring)
    np.testing.assert_allclose(w[0], 1.0, atol=2e-4)  # curvature ~0: the clamped cosine
    assert w[-1, 2, 0] < 0.85 < w[-1, 2, 2]  # tight curvature blurs red's second band most
    img = _band_limited_environment()
    hh, ww = img.shape[:2]
    dirs = env.equirect_directions(ww, hh).reshape(-1, 3)
    rad = img.reshape(-1, 3) * env.equirect_solid_angles(ww, hh).reshape(-1, 1)
    E_lm = env.sh_irradiance_coefficients(env.sh_project(img))
    N = np.random.default_rng(5).normal(size=(40, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    mu = (np.arange(n) + 0.5) / n * 2 - 1
    for row in (0, 20, n - 1):
        cosines = N @ dirs.T
        D = np.stack([np.interp(cosines, mu, ring[row, :, c]) for c in range(3)], -1)  # (40, texels, 3)
        want = np.einsum("ntc,tc->nc", D, rad)
        got = env.sh_irradiance_scattered(E_lm, N, w[row])
        np.testing.assert_allclose(got, want, rtol=0.02, atol=0.01 * want.max())


def test_penner_sphere_scatters_the_environment_as_numpy_does(renderer, tmp_path):
    from skinviewer.engine.reference import DEFAULT_SKIN_SRGB
    from skinviewer.ground.files import save_exr
    from skinviewer.ground.settings import with_values
    from skinviewer.passes.penner import profile
    from skinviewer.physics import penner
    from skinviewer.physics.color import srgb_to_linear
    from tests.helpers import small_settings
    from tests.test_environment import _sphere_obj
    path = tmp_path / "band.exr"
    save_exr(path, _band_limited_environment().astype(np.float32))
    mesh = _sphere_obj(tmp_path / "sphere.obj")
    size = 96
    s = with_values(small_settings(technique="penner", size=size), {
        "scene.mesh": str(mesh), "scene.mm_per_unit": 0.04, "deon.energy_conservation": False,
        "specular.rho_s": 0.0, "camera.yaw": 30.0, "camera.pitch": 20.0})
    s = s.model_validate({**s.model_dump(), "lights": [{"kind": "environment", "environment": str(path),
                                                        "occlusion": False, "intensity": 1.0, "cast_shadow": False}]})
    renderer.render(s)
    lit = renderer.graph("penner").read("lit")[..., :3].astype(np.float64).reshape(-1, 3)
    d, n, inner = _sphere_hits(s, renderer, size)
    k = (1.0 / (50.0 * 0.04)) * s.penner.curvature_scale / s.penner.max_curvature  # 0.5 mm^-1, normalised
    ring = penner.ring_lut(list(profile(s.deon.gaussians)), s.penner.lut_size, s.penner.max_curvature)
    bands = penner.env_band_factors(ring)
    rows = (np.arange(len(bands)) + 0.5) / len(bands)
    w = np.stack([[np.interp(k, rows, bands[:, l, c]) for c in range(3)] for l in range(3)])
    E_lm = env.sh_irradiance_coefficients(env.sh_project(_band_limited_environment()))
    want = srgb_to_linear(np.array(DEFAULT_SKIN_SRGB)) * env.sh_irradiance_scattered(E_lm, n[inner], w)
    flat = srgb_to_linear(np.array(DEFAULT_SKIN_SRGB)) * env.sh_irradiance(E_lm, n[inner])
    got = lit[inner]
    assert inner.sum() > 2000
    err, effect = np.abs(got - want)[:, 0] / want.max(), np.abs(flat - want)[:, 0] / want.max()
    assert np.median(effect) > 0.003  # red's scattering at this curvature (0.5 mm^-1)
    assert np.median(err) < 0.2 * np.median(effect) and np.percentile(err, 99) < 0.01


def test_texel_path_follows_the_environment_as_the_unwrapped_path_does(renderer):
    """d'Eon's irradiance from the texel surface map (whose v map holds the vertex's shadowed environment
    irradiance) equals the unwrapped raster's after the environment turns: the texel surface pass re-runs."""
    from skinviewer.ground.settings import with_values
    from tests.helpers import small_settings
    base = small_settings(technique="deon", size=48)
    d = base.model_dump()
    d["lights"] = [{"kind": "environment", "environment": "studio", "intensity": 1.0, "ao_rays": 16,
                    "cast_shadow": False}]
    base = base.model_validate(d)
    renderer.render(base)
    out = {}
    for texel in (True, False):
        s = with_values(base, {"lights.0.yaw": 120.0, "render.texel_surface": texel})
        renderer.render(s)
        out[texel] = renderer.graph("deon").read("deon_irradiance")[..., :3].astype(np.float64)
    covered = (out[True].sum(2) > 0) & (out[False].sum(2) > 0)
    assert covered.mean() > 0.2
    diff = np.abs(out[True] - out[False])[covered]
    assert np.median(diff) < 1e-3 * out[False][covered].max()
    renderer.render(with_values(base, {"lights.0.yaw": 0.0}))
    turned = renderer.graph("deon").read("deon_irradiance")[..., :3].astype(np.float64)
    assert np.median(np.abs(turned - out[True])[covered]) > 0.01 * out[False][covered].max()
