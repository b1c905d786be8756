"""The burley and burley2 techniques end to end on the default head (small sizes): finite everywhere, the
view modes, the GPU sample count in the frame report, caching, the reuse variant; nested sample sets."""
from __future__ import annotations

import numpy as np
import pytest
from burley_gpu import Harness, plane
from helpers import assert_all_finite, backlit_flap_column, small_settings

from skinviewer.ground.settings import SettingsError, with_values
from skinviewer.passes import burley as PB
from skinviewer.physics import burley as B


@pytest.mark.parametrize("tech,assign", [("burley", {}), ("burley", {"burley.budget": False, "burley.samples": 8}),
                                         ("burley2", {}), ("burley2", {"burley.budget": False}),
                                         ("burley2", {"burley2.reuse": 1, "burley2.base": 8,
                                                                       "burley2.extra": 14}),
                                         ("burley2", {"burley2.mode": "beyond", "burley.budget": False}),
                                         ("burley2", {"burley2.mode": "nested", "burley2.base": 6, "burley2.extra": 24,
                                                      "burley2.contrast": "minmax"})])
def test_techniques_render_finite_and_count_samples(renderer, tech, assign):
    s = small_settings(technique=tech, size=80, **assign)
    report = renderer.render(s)
    tex = assert_all_finite(renderer, s, report)
    rec = next(p for p in report.passes if p.name == "burley_count")
    assert rec.status == "ran" and rec.figures["samples"] > 0 and "samples on the GPU" in rec.note
    stats = tex[PB.STATS]
    assert rec.figures["samples"] == int(stats[..., 0].sum())
    assert rec.figures["triggered"] == int((stats[..., 1] > 0.5).sum())
    lit, diffuse = tex["lit"], tex["ss_diffuse"]
    skin = diffuse[..., 3] > 0.5
    assert skin.any() and np.all(lit[skin][:, :3] >= 0)
    assert ("burley_reuse" in report.ran) == (assign.get("burley2.reuse", 0) > 0
                                              or assign.get("burley2.mode") == "beyond")
    if tech == "burley2" and assign == {"burley.budget": False}:
        # Algorithm 1's accounting on a real frame: 12 per blurred pixel plus 10 per triggered one
        assert rec.figures["samples"] == 12 * rec.figures["pixels"] + 10 * rec.figures["triggered"]


def test_view_modes_show_the_extra_samples_and_recompute_little(renderer):
    s = small_settings(technique="burley2", size=96, **{"burley.budget": False})
    renderer.render(s)
    img = renderer.image(s).astype(int)
    s2 = with_values(s, {"burley.view": "extra"})
    rep = renderer.render(s2)
    assert set(rep.ran) == {"burley_view", "output"}  # the blur and the count stay cached
    over = renderer.image(s2).astype(int)
    stats = renderer.read(s2, PB.STATS)[::-1]
    trig = stats[..., 1] > 0.5
    assert trig.any()
    # magenta where extra samples were taken: red and blue above green
    px = over[trig]
    assert np.mean((px[:, 0] > px[:, 1]) & (px[:, 2] > px[:, 1])) > 0.9
    assert np.abs(over - img).sum() > 0
    s3 = with_values(s, {"burley.view": "samples"})
    renderer.render(s3)
    heat = renderer.image(s3).astype(int)
    assert not np.array_equal(heat, over)
    rec = next(p for p in renderer.graph("burley2").last_report.passes if p.name == "burley_count")
    assert rec.status == "cached" and rec.note  # the figure stays shown while cached


def test_nested_sets_complete_one_golubev_set():
    base, extra = B.nested_sets(6, 30)
    full = B.sample_set(30)
    np.testing.assert_allclose(base.x, B.sample_set(6).x, atol=1e-12)  # Golubev's 6 radii
    np.testing.assert_allclose(np.sort(np.concatenate([base.x, extra.x])), full.x)
    with pytest.raises(ValueError):
        B.nested_sets(6, 24)  # 24 / 6 = 4 is even: no centred subset
    with pytest.raises(SettingsError):
        with_values(small_settings(), {"burley2.mode": "nested", "burley2.base": 6, "burley2.extra": 18})


def test_nested_two_level_always_equals_the_full_set(gl_ctx):
    """A triggered pixel of the nested mode is Golubev's (base+extra)-sample estimate."""
    rng = np.random.default_rng(2)
    E, z, mask = plane(48, 40, 150.0, E=0.2 + rng.random((40, 48, 3)))
    a = {"burley.fit": "direct", "burley.budget": False, "burley.mfp": [0.5, 0.3, 0.2]}
    hs = [Harness(gl_ctx, PB.BurleyBlurPass("golubev", PB.Plan((6, 24), ((-1.0,) * 3,), nested=True))),
          Harness(gl_ctx, PB.BurleyBlurPass("golubev", PB.Plan((30,))))]
    try:
        nested, _, cn = hs[0].run(E, z, mask, **a)
        full, _, cf = hs[1].run(E, z, mask, **a)
        np.testing.assert_allclose(nested, full, rtol=1e-5)  # same samples, another summation order
        assert cn.samples == cf.samples == 30 * cf.pixels
    finally:
        for h in hs:
            h.release()


def test_reuse_keeps_energy_and_lowers_noise(gl_ctx):
    w, hgt = 96, 64
    a = {"burley.fit": "direct", "burley.budget": False, "burley.mfp": [1.0, 1.0, 1.0]}
    plan = PB.Plan((8,), reuse=1, reuse_split=0.5)

    def run(E, z, mask, reuse):
        h = Harness(gl_ctx, PB.BurleyBlurPass("golubev", plan if reuse else PB.Plan((8,))))
        if reuse:
            h.extra = [PB.BurleyReusePass(plan)]
        try:
            return h.run(E, z, mask, **a)[0]
        finally:
            h.release()

    E, z, mask = plane(w, hgt, 60.0)
    const = E * (0.2, 0.4, 0.8)
    np.testing.assert_allclose(run(const, z, mask, True), const, rtol=1e-5)  # constant stays constant
    edge = np.ones((hgt, w, 3))
    edge[:, w // 2:] = 0.0
    own, pooled = run(edge, z, mask, False), run(edge, z, mask, True)
    col = slice(w // 2 - 4, w // 2 + 4)
    # the same mean response along the edge, with less pixel-to-pixel noise
    assert abs(own[8:-8, col, 0].mean() - pooled[8:-8, col, 0].mean()) < 0.01
    assert pooled[8:-8, col, 0].std(axis=0).mean() < 0.6 * own[8:-8, col, 0].std(axis=0).mean()


@pytest.mark.parametrize("mode", ["closed-form", "thick"])
def test_burley_transmission_through_a_slab(renderer, mode):
    """Spec §5.4 wired into the Burley techniques: the backlit flap's unlit front shows T(t) x Lc with
    Burley's closed form (or HDRP's thick mode) at the flap's thickness t, within a shadow texel;
    T <= T(0) = 1 (no energy from nowhere); jimenez2010 keeps the Gaussian form."""
    s = small_settings("backlit-ear", "burley", 96, **{"screen.texturing": "post", "shadow.map_size": 512,
                                                       "lights.0.direction": [0.0, 0.0, -1.0],
                                                       "burley.transmission": mode})
    _, thick, got = backlit_flap_column(renderer, s)
    S = B.profile_of_section(s.burley).S
    lc = s.lights[0].intensity
    texel = 2 * 1.02 * 27.0 / 512  # mm: one shadow texel (the flap's bounding radius ~27 mm)

    def T(t):
        t = np.maximum(t, 0.0)[:, None]
        return B.transmittance(t, S) if mode == "closed-form" else np.exp(-S * t / 3.0)
    lo, hi = T(thick + texel) * lc, T(thick - 3 * texel) * lc
    assert np.all(got >= lo - 1e-3) and np.all(got <= hi + 1e-3)
    assert np.all(got <= lc + 1e-6) and np.all(np.isfinite(got))
    assert got[:, 1].max() > 0.05  # Burley's green passes a thin flap (the Gaussian form's does not)
    _, _, gauss = backlit_flap_column(renderer, with_values(s, {"burley.transmission": "jimenez2010"}))
    assert not np.allclose(gauss, got, atol=1e-3)


@pytest.mark.parametrize("R", [1, 2])
def test_reuse_pass_equals_its_formula_on_the_blur_passs_own_buffers(gl_ctx, R):
    """shaders/burley_reuse.frag against a numpy evaluation of its formula on the very buffers the blur
    pass wrote (near/far weighted sums and weights): (near + tent-mean far) / (near w + tent-mean far w),
    tent weight (R + 1 - |dx|)(R + 1 - |dy|) over blurred neighbours on the image whose depth is within
    u_reuse_dz (+ 1.5 x slope x offset; the uploaded slope is 0). The scene has a depth step, a mask hole
    and the image's border, so every rule of the neighbourhood is used."""
    from burley_gpu import UploadPass, view_for

    from skinviewer.ground.settings import Settings, with_values
    from skinviewer.kernel.graph import FrameInputs, RenderGraph
    from skinviewer.kernel.shaders import ShaderLibrary
    w, hgt = 24, 16
    rng = np.random.default_rng(2)
    E = rng.uniform(0.2, 1.0, (hgt, w, 3))
    z = np.full((hgt, w), 60.0)
    z[:, 15:] = 61.5  # beyond the tolerance (0.05 x filter radius ~ 0.83 mm)
    z[10:, :6] += 0.3  # within it
    mask = np.ones((hgt, w))
    mask[5:7, 8:11] = 0.0
    plan = PB.Plan((8,), reuse=R, reuse_split=1.0)
    names = [PB.PARTIAL, PB.NEAR_W, PB.FAR, PB.FAR_W, PB.BLURRED]
    g = RenderGraph(gl_ctx, ShaderLibrary(gl_ctx), [UploadPass(E, z, mask), PB.BurleyBlurPass("golubev", plan),
                                                   PB.BurleyReusePass(plan)], names)
    try:
        s = with_values(Settings(), {"render.width": w, "render.height": hgt, "burley.fit": "direct",
                                     "burley.budget": False, "burley.mfp": [1.0, 0.5, 0.25]})
        v = view_for(w, hgt)
        g.run(FrameInputs(settings=s, scene=None, scene_version=0, view=v, view_key=v.key()), force=True)
        part, nw, far, fw, got = (g.read(n).astype(np.float64) for n in names)
    finally:
        g.release()
    tol = plan.reuse_dz * B.profile_of_section(s.burley).filter_radius
    blurred = nw[..., 3] >= 0.5
    assert blurred.sum() == mask.sum() and far[..., :3].max() > 0
    expect = part.copy()
    for y, x in zip(*np.nonzero(blurred)):
        acc, wt, gs = np.zeros(3), np.zeros(3), 0.0
        for dy in range(-R, R + 1):
            for dx in range(-R, R + 1):
                qy, qx = y + dy, x + dx
                if not (0 <= qy < hgt and 0 <= qx < w) or not blurred[qy, qx] or abs(z[qy, qx] - z[y, x]) > tol:
                    continue
                gw = (R + 1 - abs(dx)) * (R + 1 - abs(dy))
                acc += gw * far[qy, qx, :3]
                wt += gw * fw[qy, qx, :3]
                gs += gw
        expect[y, x, :3] = (part[y, x, :3] + acc / gs) / (nw[y, x, :3] + wt / gs)
    np.testing.assert_allclose(got, expect, rtol=2e-5, atol=1e-6)  # float32 sums in the shader
