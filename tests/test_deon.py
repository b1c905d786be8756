"""d'Eon & Luebke 2007 technique (issue 4): profile maths, laser profile, stretch, TSM, rho_dt on
the GPU, caching rules and hard cases (every intermediate texture finite)."""
from __future__ import annotations

import numpy as np
import pytest
from analytic_judge import plane_coords
from helpers import assert_all_finite, small_settings

from skinviewer.ground.settings import (
    DeonSettings,
    Gaussian,
    profile_warnings,
    with_values,
)
from skinviewer.passes.deon import mean_texel_mm
from skinviewer.physics import diffusion
from skinviewer.physics.diffusion import (
    KERNEL7,
    blur_plan,
    blur_plan_texels,
    gaussian,
    texture_of,
    tsm_factor,
)

# ---------------------------------------------------------------------------------------------
# numpy maths


def test_kernel7_unit_variance_and_plan():
    k = np.arange(-3, 4)
    assert abs(KERNEL7.sum() - 1) < 1e-12
    assert abs(np.sum(KERNEL7 * k * k) - 1) < 1e-9  # the blur adds exactly its increment
    # GPU Gems' printed curve is 8 % too wide in variance
    assert np.sum(diffusion.GPU_GEMS_KERNEL7 * k * k) > 1.05
    p = blur_plan([0.0064, 0.0484, 0.187], reuse_below=0.01)
    assert p[0].reused and texture_of(p[0]) == "deon_irradiance"
    assert p[1].source == "deon_irradiance" and abs(p[1].increment - 0.0484) < 1e-12
    p = blur_plan([0.0064, 0.0484, 0.187], reuse_below=0.0)
    assert [s.source for s in p] == ["deon_irradiance", "blur_0", "blur_1"]
    assert abs(p[2].increment - (0.187 - 0.0484)) < 1e-12
    # non-ascending: increment clamped to 0, the later step measures from what the texture has
    p = blur_plan([0.5, 0.2, 1.0, 0.0], reuse_below=0.0)
    assert [round(s.increment, 9) for s in p] == [0.5, 0.0, 0.5, 0.0]
    assert [s.variance for s in p] == [0.5, 0.5, 1.0, 1.0]


def test_profile_warnings_never_crash():
    d = DeonSettings(gaussians=[Gaussian(variance=1.0, weights=(0, 0, 0)), Gaussian(variance=0.0, weights=(2, 0, 0))])
    w = profile_warnings(d)
    assert any("ascending" in x for x in w) and any("energy" in x for x in w)
    assert profile_warnings(DeonSettings()) == []  # the default table sums to 1 per channel
    # a G table summing to 1.1 (or 0.9) is named, per channel, with the direction of the error
    for scale, verb in ((1.1, "gains"), (0.9, "loses")):
        gs = [Gaussian(variance=g.variance, weights=(g.weights[0], g.weights[1] * scale, g.weights[2]))
              for g in DeonSettings().gaussians]
        w = profile_warnings(DeonSettings(gaussians=gs))
        assert len(w) == 1 and "channel G" in w[0] and verb in w[0], w


def test_tsm_identity():
    r = np.linspace(0, 5, 101)[:, None]
    d = np.array([0.0, 0.3, 1.0, 2.5])[None, :]
    for v in (0.0064, 0.187, 1.99, 7.41):
        lhs = gaussian(v, np.sqrt(r * r + d * d))
        rhs = gaussian(v, r) * tsm_factor(d, v, "exact")
        assert np.allclose(lhs, rhs, rtol=1e-12, atol=1e-300)
        printed = gaussian(v, r) * tsm_factor(d, v, "printed")
        dd = d[0, 1:]
        assert np.all(np.abs(printed[0, 1:] - lhs[0, 1:]) > 1e-3 * lhs[0, 1:] + 0) or np.all(lhs[0, 1:] < 1e-300)
        assert np.all(np.isfinite(tsm_factor(dd, 0.0))) and tsm_factor(0.0, 0.0) == 1.0


# ---------------------------------------------------------------------------------------------
# GPU helpers


def _deon(scene, **kw):
    return small_settings(scene, "deon", 64, **kw)


def _plane_coords(renderer, n):
    """Texel centres -> mesh millimetres for a planar built-in scene (linear UV map)."""
    gpu = renderer.scene.gpu
    return plane_coords(gpu.mesh.positions, gpu.mesh.uvs, gpu.mm_per_unit, n)


def _diffuse_and_reference(renderer, s):
    """Sum_i w_i blur_i and the exact profile convolved with the irradiance texels actually lit,
    both normalised by the beam's total power; texel coordinates in mm."""
    renderer.render(s)
    g = renderer.graph("deon")
    n = s.deon.irradiance_size
    E = g.read("deon_irradiance")[..., :3].astype(np.float64)
    plan = blur_plan_texels([x.variance for x in s.deon.gaussians], s.deon.reuse_irradiance_below_texels,
                            mean_texel_mm(renderer.scene.gpu, n))
    D = sum(np.asarray(x.weights) * g.read(texture_of(p))[..., :3] for x, p in zip(s.deon.gaussians, plan))
    X, Y, area = _plane_coords(renderer, n)
    lit = E[..., 0] > 0
    assert 1 <= lit.sum() < 200
    pw = E[lit] * area
    ref = np.zeros_like(D, dtype=np.float64)
    for x0, y0, p in zip(X[lit], Y[lit], pw):
        rr = np.hypot(X - x0, Y - y0)
        for x in s.deon.gaussians:
            ref += p * np.asarray(x.weights) * gaussian(x.variance, rr)[..., None]
    tot = pw.sum(0)
    cx, cy = (pw[:, 0] @ X[lit]) / tot[0], (pw[:, 0] @ Y[lit]) / tot[0]
    return D / tot, ref / tot, X - cx, Y - cy, area


def _radial_error(D, ref, R, rmax=10.0, bins=200):
    edges = np.linspace(0, rmax, bins + 1)
    idx = np.digitize(R.ravel(), edges) - 1
    ok = (idx >= 0) & (idx < bins)
    cnt = np.bincount(idx[ok], None, bins)
    has = cnt > 0
    rc = 0.5 * (edges[1:] + edges[:-1])
    errs = []
    for ch in range(3):
        m = np.bincount(idx[ok], D[..., ch].ravel()[ok], bins)[has] / cnt[has]
        f = np.bincount(idx[ok], ref[..., ch].ravel()[ok], bins)[has] / cnt[has]
        errs.append(float(np.sum(rc[has] * np.abs(m - f)) / np.sum(rc[has] * f)))
    return errs


# ---------------------------------------------------------------------------------------------
# laser: mm scaling and the hierarchical blur


def test_laser_profile_matches_sum_of_gaussians(renderer):
    # 1024^2 on the 24 mm slab: 0.023 mm texels, the smallest Gaussian (sigma 0.08 mm) is 3.4 texels
    s = _deon("laser", **{"deon.irradiance_size": 1024})  # shipped settings: every Gaussian is resolved
    D, ref, dx, dy, area = _diffuse_and_reference(renderer, s)
    errs = _radial_error(D, ref, np.hypot(dx, dy))
    # measured: R 0.0064, G 0.0109, B 0.0151 (single 7-tap blurs without sub-steps: 0.018/0.033/0.044)
    assert errs[0] < 0.012 and errs[1] < 0.02 and errs[2] < 0.03, errs
    # the blurs conserve the beam's power (weights sum to ~1 per channel in the default profile)
    wsum = np.sum([x.weights for x in s.deon.gaussians], axis=0)
    assert np.allclose(D.sum((0, 1)) * area, wsum, rtol=0.01)


def test_reuse_of_the_irradiance_follows_the_texel_size(renderer):
    """blur_1 reuses the irradiance only where its sigma (0.08 mm) is under half a texel: on the
    laser's fine texels it must be blurred, on the head's 1 mm texels the blur would be a no-op."""
    rep = renderer.render(_deon("laser", **{"deon.irradiance_size": 512}))
    assert "deon_blur_0" in rep.ran
    rep = renderer.render(_deon("head", **{"deon.irradiance_size": 256, "deon.fold_below_texels": 0.0}))
    assert "deon_blur_0" in rep.pruned and "deon_blur_1" in rep.ran  # (folding would prune blur_1 too)


def test_laser_scales_with_mm_per_unit(renderer):
    s1 = _deon("laser", **{"deon.irradiance_size": 256})
    renderer.render(s1)
    a = renderer.read(s1, "deon_stretch")[128, 128, :2].copy()
    s2 = _deon("laser", **{"deon.irradiance_size": 256, "scene.mm_per_unit": 2.0})
    renderer.render(s2)
    b = renderer.read(s2, "deon_stretch")[128, 128, :2]
    assert np.allclose(a, 0.96 / 24.0, rtol=1e-3)  # UV per mm
    assert np.allclose(b, a / 2, rtol=1e-3)


# ---------------------------------------------------------------------------------------------
# stretch


def _second_moments(D, dx, dy, rmax):
    m = (np.hypot(dx, dy) < rmax)
    out = []
    for ch in range(1):
        w = D[..., ch] * m
        out.append((float(np.sum(w * dx * dx) / w.sum()), float(np.sum(w * dy * dy) / w.sum())))
    return out[0]


def test_stretch_plane_matches_laser(renderer):
    prof = [{"variance": 0.05, "weights": [0.5, 0.5, 0.5]}, {"variance": 0.3, "weights": [0.5, 0.5, 0.5]}]
    expect = 0.5 * 0.05 + 0.5 * 0.3
    common = {"deon.irradiance_size": 512, "deon.reuse_irradiance_below_texels": 0.0, "deon.gaussians": prof,
              "lights.0.beam_radius": 0.06}
    D, _, dx, dy, _ = _diffuse_and_reference(renderer, _deon("laser", **common))
    vx_l, vy_l = _second_moments(D, dx, dy, 2.8)
    D, ref, dx, dy, _ = _diffuse_and_reference(renderer, _deon("stretch-plane", **common))
    vx_s, vy_s = _second_moments(D, dx, dy, 2.8)
    err_on = _radial_error(D, ref, np.hypot(dx, dy), rmax=2.5, bins=50)
    D, ref_off, dx, dy, _ = _diffuse_and_reference(renderer, _deon("stretch-plane", **common, **{"deon.stretch": False}))
    vx_o, vy_o = _second_moments(D, dx, dy, 2.8)
    err_off = _radial_error(D, ref_off, np.hypot(dx, dy), rmax=2.5, bins=50)
    for v in (vx_l, vy_l, vx_s, vy_s):
        assert abs(v - expect) < 0.12 * expect, (vx_l, vy_l, vx_s, vy_s, expect)
    assert max(err_on) < 0.08, err_on
    assert vy_o / vx_o > 4.0 and max(err_off) > max(0.15, 4 * max(err_on)), (vx_o, vy_o, err_off, err_on)


def test_stretch_per_gaussian(renderer):
    """Seed 000 end of §4.2.4: the stretch map blurred along the chain. On a uniformly stretched
    plane the blurred stretch equals the raw one, so the profile is unchanged; on the head, where
    stretch varies, the wide Gaussians change; toggling it re-runs the blurs, not the irradiance."""
    prof = [{"variance": 0.05, "weights": [0.5, 0.5, 0.5]}, {"variance": 0.3, "weights": [0.5, 0.5, 0.5]}]
    common = {"deon.irradiance_size": 512, "deon.reuse_irradiance_below_texels": 0.0, "deon.gaussians": prof,
              "lights.0.beam_radius": 0.06}
    D0, _, dx, dy, _ = _diffuse_and_reference(renderer, _deon("stretch-plane", **common))
    s = _deon("stretch-plane", **common, **{"deon.stretch_per_gaussian": True})
    D1, _, _, _, _ = _diffuse_and_reference(renderer, s)
    rep = renderer.graph("deon").last_report
    assert "deon_stretch_blur_0" in rep.ran and "deon_stretch_blur_1" in rep.pruned  # nobody after blur_1
    assert "deon_irradiance" in rep.cached and "deon_stretch" in rep.cached
    assert set(rep.ran) >= {"deon_blur_1", "deon_final"}
    v0, v1 = _second_moments(D0, dx, dy, 2.8), _second_moments(D1, dx, dy, 2.8)
    assert np.allclose(v0, v1, rtol=0.02), (v0, v1)

    # folded, blur_5 would start from the raw stretch; summed over the surface (deon_surface_gather, a
    # step under deon.surface_gather_below_texels texels) it reads no stretch chain at all
    head = _deon("head", **{"deon.irradiance_size": 256, "deon.fold_below_texels": 0.0,
                            "deon.surface_gather_below_texels": 0.0})
    renderer.render(head)
    a = renderer.read(head, "blur_5")
    head2 = with_values(head, {"deon.stretch_per_gaussian": True})
    renderer.render(head2)
    b = renderer.read(head2, "blur_5")
    assert np.all(np.isfinite(b)) and np.abs(a - b).max() > 1e-4 * np.abs(a).max()


# ---------------------------------------------------------------------------------------------
# TSM


def _front_column(renderer, s):
    renderer.render(s)
    lit = renderer.read(s, "lit")[..., :3]
    n = lit.shape[0]
    # the flap spans y in [-20, 20] mm and fills the middle of the 64 px view; sample its centre line
    col = lit[:, n // 2, 0]
    return col, lit


def test_backlit_ear_transmission_falls_off_with_thickness(renderer):
    s_on = _deon("backlit-ear")
    col, lit = _front_column(renderer, s_on)
    g = renderer.graph("deon")
    thick = g.read("deon_irradiance")[..., 3]
    # front island u in [0.02, 0.48]: thickness 1.5 mm at the top, 6 mm at the bottom (row 0 = bottom)
    c = int(0.25 * thick.shape[1])
    assert thick[int(0.9 * thick.shape[0]), c] < 2.2 and thick[int(0.1 * thick.shape[0]), c] > 5.0
    n = col.shape[0]
    top, mid, bottom = col[int(0.68 * n)], col[n // 2], col[int(0.32 * n)]
    assert top > mid > bottom > 0, (top, mid, bottom)
    assert lit[int(0.6 * n), n // 2, 0] > 3 * lit[int(0.6 * n), n // 2, 2]  # the glow is red
    s_off = with_values(s_on, {"deon.tsm": False})
    col_off, _ = _front_column(renderer, s_off)
    assert "deon_tsm" in renderer.graph("deon").last_report.pruned
    assert np.all(col_off[int(0.3 * n):int(0.7 * n)] < 1e-3 * top), col_off


# ---------------------------------------------------------------------------------------------
# rho_dt: the uploaded texture sampled in GLSL agrees with numpy


def test_rho_dt_texture_on_gpu(renderer, gl_ctx):
    from skinviewer.ground import paths
    from skinviewer.physics import specular
    s = _deon("laser", **{"deon.irradiance_size": 256, "specular.f0": 0.05, "specular.rho_s": 0.4})
    renderer.render(s)
    tex = renderer.graph("deon").texture("rho_dt_lut")
    kel = (paths.shaders_dir() / "lib" / "kelemen.glsl").read_text()
    n = 64
    cos = np.linspace(0.0, 1.0, n)
    ms = np.array([0.12, 0.3, 0.55])
    prog = gl_ctx.program(
        vertex_shader="#version 330 core\nvoid main(){vec2 p=vec2((gl_VertexID<<1)&2,gl_VertexID&2);"
                      "gl_Position=vec4(p*2.0-1.0,0.0,1.0);}",
        fragment_shader="#version 330 core\n" + kel + """
uniform sampler2D rho_dt_tex; uniform float u_m[3]; uniform int n; out vec4 f;
void main(){ ivec2 p = ivec2(gl_FragCoord.xy); float c = float(p.x) / float(n - 1);
  f = vec4(rho_dt_lookup(rho_dt_tex, c, u_m[p.y]), 0.0, 0.0, 1.0); }""")
    prog["u_m"].write(ms.astype(np.float32).tobytes())
    prog["n"].value = n
    tex.use(0)
    prog["rho_dt_tex"].value = 0
    out = gl_ctx.texture((n, 3), 4, dtype="f4")
    fbo = gl_ctx.framebuffer([out])
    fbo.use()
    gl_ctx.vertex_array(prog, []).render(vertices=3)
    got = np.frombuffer(out.read(), np.float32).reshape(3, n, 4)[..., 0]
    fbo.release(), out.release(), prog.release()
    table = specular.rho_dt_table(0.05, 0.4)
    want = specular.sample_bilinear(table, cos[None, :], ms[:, None])
    assert np.all((got >= 0) & (got <= 1))
    assert np.max(np.abs(got - want)) < 1e-4
    exact = specular.rho_dt(cos[None, :], ms[:, None], 0.05, 0.4)
    inner = (cos > 0.05)[None, :].repeat(3, 0)
    assert np.max(np.abs(got - exact)[inner]) < 0.01


# ---------------------------------------------------------------------------------------------
# caching


def test_caching_rules(renderer):
    s = _deon("backlit-ear")
    r0 = renderer.render(s)
    assert "deon_stretch" in r0.ran and "deon_tsm" in r0.ran
    blurs = [f"deon_blur_{i}" for i in range(1, 6)]
    # transmitted (eq. 33, texture space) + sum_i w_i blur_i, then the view
    summed = ["deon_transmitted", "deon_combine", "deon_final", "output"]

    def ran(**kw):
        nonlocal s
        s = with_values(s, kw)
        return renderer.render(s).ran

    # the final pass split (passes.deon.split_final: auto on llvmpipe): its view pass re-runs on an orbit
    view = ["deon_final_view"] if any(k.startswith("deon_final_view") for k in renderer.graph("deon").resources()) else []
    assert ran(**{"camera.yaw": 40.0}) == [*view, "deon_final", "output"]  # orbit
    got = ran(**{"lights.0.direction": [0.1, 0.3, -1.0]})  # light move
    assert set(got) == {"shadow_map_0", "deon_tsm", "deon_tsm_max", "deon_irradiance", *blurs, *summed}, got
    got = ran(**{"lights.0.intensity": 5.0})  # light colour/intensity: no shadow map, no TSM
    assert set(got) == {"deon_irradiance", *blurs, *summed}, got
    # the view pass holds the environment's translucency, whose profile is the Gaussians (deon_final_view_x)
    tr = ["deon_final_view"] if "deon_final_view_x" in renderer.graph("deon").resources() else []
    got = ran(**{"deon.gaussians.2.weights": [0.2, 0.1, 0.0]})  # weight edit: no blur
    assert sorted(got) == sorted(summed + tr) and got[-2:] == summed[-2:], got
    got = ran(**{"deon.gaussians.3.variance": 0.6})  # v_4 (index 3)
    assert set(got) == {"deon_blur_3", "deon_blur_4", "deon_blur_5", *summed, *tr}, got
    got = ran(**{"specular.f0": 0.04})
    assert set(got) == {"rho_dt_lut", "deon_irradiance", *blurs, *summed, *view}, got  # f0: rho_dt(N.V) too
    assert ran(**{"specular.m": 0.35}) and "rho_dt_lut" not in renderer.graph("deon").last_report.ran
    rep = renderer.render(with_values(s, {"deon.gaussians.5.weights": [0, 0, 0], "deon.gaussians.4.weights": [0, 0, 0]}))
    assert {"deon_blur_4", "deon_blur_5"} <= set(rep.pruned) and "deon_blur_3" in rep.cached
    rep = renderer.render(with_values(s, {"deon.tsm": False, "deon.energy_conservation": False}))
    assert {"deon_tsm", "rho_dt_lut"} <= set(rep.pruned)


def test_middle_zero_weight_keeps_chain(renderer):
    s = _deon("laser", **{"deon.gaussians.2.weights": [0, 0, 0]})
    rep = renderer.render(s)
    assert "deon_blur_2" in rep.ran and "deon_blur_5" in rep.ran


# ---------------------------------------------------------------------------------------------
# hard cases: every intermediate texture finite


def _write_hard_mesh(tmp_path):
    """A 10 mm quad plus a zero-UV-area triangle, a UV sliver and a zero-world-area triangle."""
    v = [(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0),
         (-4, -4, 1), (4, -4, 1), (0, 4, 1),  # zero UV area (all at one uv)
         (-4, -4, 2), (4, -4, 2), (0, 4, 2),  # UV sliver
         (1, 1, 3), (2, 2, 3), (3, 3, 3)]  # collinear: zero world area, normal UVs
    vt = [(0.05, 0.05), (0.6, 0.05), (0.6, 0.6), (0.05, 0.6),
          (0.8, 0.8), (0.8, 0.8), (0.8, 0.8),
          (0.7, 0.7), (0.9, 0.7000001), (0.8, 0.7000002),
          (0.7, 0.9), (0.95, 0.9), (0.8, 0.98)]
    f = [(1, 2, 3), (1, 3, 4), (5, 6, 7), (8, 9, 10), (11, 12, 13)]
    lines = [f"v {x} {y} {z}" for x, y, z in v] + [f"vt {a} {b}" for a, b in vt]
    lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in f]
    p = tmp_path / "hard.obj"
    p.write_text("\n".join(lines) + "\n")
    from PIL import Image
    img = np.full((8, 8, 3), 200, np.uint8)
    img[:, :4] = 0  # black albedo texels: 0^mix
    Image.fromarray(img).save(tmp_path / "albedo.png")
    return str(p), str(tmp_path / "albedo.png")


HARD = {
    "variance0": {"deon.gaussians.0.variance": 0.0, "deon.gaussians.3.variance": 0.0},
    "non_ascending": {"deon.gaussians.1.variance": 3.0, "deon.gaussians.2.variance": 0.01},
    "zero_weights": {f"deon.gaussians.{i}.weights": [0, 0, 0] for i in range(6)},
    "light_1e6": {"lights.0.intensity": 1e6},
    "mix0": {"deon.mix": 0.0},
    "mix1": {"deon.mix": 1.0},
    "huge_thickness": {"scene.mm_per_unit": 1e5},
    "lit_front": {"lights.0.direction": [0.0, 0.0, 1.0]},
    "no_stretch_lut": {"deon.stretch": False, "specular.mode": "beckmann_lut", "specular.m": 0.0},
}


@pytest.mark.parametrize("case", sorted(HARD))
def test_hard_cases_finite(renderer, case):
    s = _deon("backlit-ear", **HARD[case])
    tex = assert_all_finite(renderer, s)
    assert np.all(tex["lit"][..., :3] >= 0)
    if case == "light_1e6":
        base = _deon("backlit-ear")
        e_big = tex["deon_irradiance"][..., :3].max()
        renderer.render(base)
        e = renderer.read(base, "deon_irradiance")[..., :3].max()
        assert e_big > 65504 and abs(e_big / e / (1e6 / 3.0) - 1) < 1e-3  # beyond half floats, exact
    if case == "huge_thickness":
        assert tex["deon_irradiance"][..., 3].max() <= 100.0


def test_hard_mesh_black_albedo(renderer, tmp_path):
    mesh, albedo = _write_hard_mesh(tmp_path)
    for mix in (0.0, 0.5, 1.0):
        s = _deon("laser", **{"scene.mesh": mesh, "scene.albedo_map": albedo, "deon.mix": mix,
                              "lights.0.kind": "directional", "lights.0.cast_shadow": True,
                              "lights.0.intensity": 1e6, "camera.target": None, "camera.distance": None})
        tex = assert_all_finite(renderer, s)
        st = tex["deon_stretch"][..., :2]
        assert np.all(st > 0) and np.all(st <= 10.0)
        assert tex["lit"][..., 3].max() == 1.0


def test_tsm_light_is_selectable(renderer):
    """deon.tsm_light picks the light the TSM is rendered from; moving another light leaves it."""
    lights = [{"kind": "directional", "direction": [0.0, 0.15, 1.0], "intensity": 1.0},
              {"kind": "directional", "direction": [0.0, 0.15, -1.0], "intensity": 3.0}]
    s = _deon("backlit-ear", **{"lights": lights, "deon.tsm_light": 1, "deon.tsm_auto": False})  # selection, not the rule
    renderer.render(s)
    rep = renderer.render(with_values(s, {"lights.0.direction": [0.2, 0.15, 1.0]}))
    assert "deon_tsm" in rep.cached  # rendered from light 1
    rep = renderer.render(with_values(s, {"lights.0.direction": [0.2, 0.15, 1.0], "lights.1.direction": [0.1, 0.15, -1.0]}))
    assert "deon_tsm" in rep.ran
    # a light that casts no shadow cannot carry the TSM: the first shadow-casting one does
    s2 = with_values(s, {"lights.1.cast_shadow": False})
    renderer.render(s2)
    rep = renderer.render(with_values(s2, {"lights.0.direction": [0.3, 0.15, 1.0]}))
    assert "deon_tsm" in rep.ran


def test_max_stretch_from_the_mesh_bounds_the_stretch_map(renderer):
    """The narrow-blur choice (deon_blur NARROW_TAPS) is made in reflect from the mesh's largest
    per-triangle stretch: it must bound what deon_stretch.frag writes."""
    s = _deon("head")
    renderer.render(s)
    st = renderer.read(s, "deon_stretch")[..., :2]
    gpu_max = float(st[np.isfinite(st)].max())
    cpu_max = renderer.scene.gpu.max_uv_per_mm
    assert gpu_max <= cpu_max * (1 + 1e-4)
    assert cpu_max < 20 * gpu_max  # and is not a loose bound


@pytest.mark.parametrize("texel_surface", [True, False])
def test_a_texel_a_shadow_edge_crosses_carries_its_lit_fraction(renderer, texel_surface):
    """deon.texel_samples = 4 (issue 30 item 4): the irradiance pass averages the shadow test over a
    rotated 2 x 2 grid of the texel's patch, so a texel the cast edge crosses (shadow-edge lit at 30
    degrees, hard shadow, 256^2 map: 0.31 mm texels) is within a quarter of its lit fraction, while one
    sample per texel gives all or nothing."""
    import math

    from skinviewer.physics.diffusion import IRRADIANCE
    from skinviewer.scene.scenes import build_scene
    xe = 21.0 * math.tan(math.radians(30.0))
    m = build_scene("shadow-edge").mesh
    X, _, _ = plane_coords(m.positions, m.uvs, m.mm_per_unit, 256, np.abs(m.positions[:, 2]) < 1e-6)
    lit = 0.8 * 0.866 / math.hypot(0.5, 0.866)
    frac = np.clip((X[0] - xe) / (X[0, 1] - X[0, 0]) + 0.5, 0.0, 1.0)
    edge = (frac > 0.05) & (frac < 0.95)
    near = np.abs(X[0] - xe) < 3.0
    got = {}
    for k in (1, 4):
        s = small_settings("shadow-edge", "deon", 32, **{
            "deon.irradiance_size": 256, "deon.tsm": False, "deon.energy_conservation": False,
            "shadow.map_size": 4096, "shadow.pcf": 0, "deon.texel_samples": k,
            "render.texel_surface": texel_surface,
            "lights": [{"kind": "directional", "direction": [-0.5, 0.0, 0.866], "intensity": 0.8,
                        "cast_shadow": True}]})
        renderer.render(s)
        got[k] = renderer.graph("deon").read(IRRADIANCE)[128, :, 0].astype(np.float64) / lit
    assert edge.sum() >= 1
    assert np.all(np.isin(np.round(got[1][near], 3), (0.0, 1.0)))
    assert np.abs(got[4][edge] - frac[edge]).max() <= 0.26
    assert np.abs(got[4][near & ~edge] - np.round(frac[near & ~edge])).max() < 1e-3
    assert 0.0 < got[4][edge].max() < 1.0


@pytest.mark.parametrize("map_size", [512, 2048])
def test_the_four_samples_lit_fraction_follows_a_shadow_edge_moved_by_less_than_a_shadow_texel(renderer, map_size):
    """deon.texel_samples = 4 (issue 30 item 4): as the light tilts by 0.1 degree steps (the shadow-edge's
    cast edge moves 0.16 of a 0.31 mm texel a step on the 256^2 map), the edge the texels' lit fractions
    put (one row: where sum(lit fraction) says it is) moves at every step, as the surface's lit fraction
    does. Each sample tested the nearest shadow-map texel alone, so all four snapped to the map's grid and
    the edge stalled every other step (moved 0.00 then 0.25 texel; notes/truth.md session 12)."""
    import math

    from skinviewer.physics.diffusion import IRRADIANCE
    from skinviewer.scene.scenes import build_scene
    m = build_scene("shadow-edge").mesh
    X, _, _ = plane_coords(m.positions, m.uvs, m.mm_per_unit, 256, np.abs(m.positions[:, 2]) < 1e-6)
    x = X[128]
    dx = x[1] - x[0]
    near = np.abs(x - 21.0 * math.tan(math.radians(30.5))) < 3.0
    edges, exact = [], []
    for deg in np.linspace(30.0, 31.0, 11):
        a = math.radians(deg)
        s = small_settings("shadow-edge", "deon", 32, **{
            "deon.irradiance_size": 256, "deon.tsm": False, "deon.energy_conservation": False,
            "shadow.map_size": map_size, "deon.texel_samples": 4,
            "lights": [{"kind": "directional", "direction": [-math.sin(a), 0.0, math.cos(a)], "intensity": 1.0,
                        "cast_shadow": True}]})
        renderer.render(s)
        frac = renderer.graph("deon").read(IRRADIANCE)[128, :, 0].astype(np.float64) / math.cos(a)
        edges.append(x[near].max() + dx / 2 - frac[near].sum() * dx)  # lit for x past the edge
        exact.append(21.0 * math.tan(a))
    steps, true_steps = np.diff(edges) / dx, np.diff(exact) / dx
    assert np.all(true_steps > 0.15)
    assert steps.min() > 0.05, f"the edge stalled: steps {np.round(steps, 2)} texels (exact {true_steps[0]:.2f})"
    assert np.abs(np.array(edges) - exact).max() < 1.0 * dx  # and it stays within a texel of the exact edge


def test_the_four_texel_samples_take_the_hard_shadow_test_not_the_pcf(renderer):
    """deon.texel_samples = 4 averages four hard eq. (7) tests over the texel's patch: with the PCF on,
    the irradiance map equals the one with shadow.pcf 0 (a PCF under the four samples filtered the shadow
    twice: against the judge that shares no shadow, green / blue p99 5.2 / 3.6 % against 3.7 / 1.7 %,
    notes/truth.md item 4), and one sample still takes the PCF (its map differs with shadow.pcf 0)."""
    from skinviewer.physics.diffusion import IRRADIANCE
    got = {}
    for k in (1, 4):
        for pcf in (0, 1):
            s = small_settings("shadow-edge", "deon", 32, **{
                "deon.irradiance_size": 256, "deon.tsm": False, "shadow.map_size": 512, "shadow.pcf": pcf,
                "deon.texel_samples": k,
                "lights": [{"kind": "directional", "direction": [-0.5, 0.0, 0.866], "intensity": 0.8,
                            "cast_shadow": True}]})
            renderer.render(s)
            got[k, pcf] = renderer.graph("deon").read(IRRADIANCE)[..., :3].astype(np.float64)
    assert np.array_equal(got[4, 0], got[4, 1])
    assert np.abs(got[1, 0] - got[1, 1]).max() > 0.01
