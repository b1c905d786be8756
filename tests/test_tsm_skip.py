"""d'Eon's transmitted light skips the texels no TSM read can reach (issue 27; lib/tsm_transmit.glsl
TSM_SKIP, shaders/deon_tsm_max.frag, passes.deon.TsmMaxPass): every eq. 33 term is exp(-m^2 / (k2 v)) with
m >= d(C) - (the largest t.r within reach), which underflows to exactly 0 past TSM_ZERO, so the skip
returns what the loops return. Checked against the shader without the skip on llvmpipe, the max map
against numpy over the TSM read back, the reach against the gather's own spiral, and the graph's
run report (a light move re-runs the max, a camera move keeps it)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import small_settings

import skinviewer.passes.deon as deon_passes
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import with_values
from skinviewer.kernel.gl import software_renderer
from skinviewer.passes.deon import TRANSMITTED, TSM, TSM_MAX, tsm_max_covered, tsm_max_radii, tsm_reach_texels

# llvmpipe does not reproduce its own denormals: two renders of the unchanged shader in one process
# differ by up to ~1.2e-38 in a few texels (seen in blur_4, blur_5 and the transmitted light alike).
# Everything from the smallest normal float up must be equal.
FLT_MIN = float(np.finfo(np.float32).tiny)

BACK_LIT = {"lights.0.direction": [0.0, 0.2, -1.0], "lights.1.direction": [0.1, 0.0, -1.0]}


def _render(ctx, s, skip: bool, mark: bool = False, cut: bool = False):
    """(report, every texture) of a render with the skip on or off; ``cut``: its threshold at 2^-24
    (passes.deon.TSM_CUT, the default) instead of float32's underflow (exact)."""
    deon_passes.TSM_SKIP, deon_passes.TSM_SKIP_MARK, deon_passes.TSM_CUT = skip, mark, cut
    r = Renderer(ctx)
    try:
        rep = r.render(s)
        g = r.graph("deon")
        return rep, {k: g.read(k) for k in g.resources()}
    finally:
        r.release()
        deon_passes.TSM_SKIP, deon_passes.TSM_SKIP_MARK, deon_passes.TSM_CUT = True, False, True


@pytest.mark.parametrize("scene,extra", [("backlit-ear", {}), ("head", {}), ("head", BACK_LIT)],
                         ids=["backlit-ear", "head-front-lit", "head-back-lit"])
def test_the_skip_is_the_full_path(gl_ctx, scene, extra):
    """The transmitted light and the image with the skip equal those without it (up to llvmpipe's own
    denormal noise), while the skip does skip texels on the head (a -1 marker counts them; on the thin
    ear none is out of reach) and the term is not all zero (the comparison means something)."""
    # a TSM of the defaults' size on the head: the max map's channels have distinct windows (taps, gathers)
    tsm_size = 1024 if scene == "head" else 256
    s = small_settings(scene, "deon", 64, **{"deon.irradiance_size": 256, "deon.tsm_size": tsm_size, **extra})
    _, full = _render(gl_ctx, s, skip=False)
    rep, skip = _render(gl_ctx, s, skip=True)
    assert "deon_tsm_max" in {p.name for p in rep.passes if p.status == "ran"}
    assert TSM_MAX not in full  # without the skip nobody reads it
    # a GPU compiler may schedule the two variants' arithmetic differently (fused multiply-adds): the H200
    # read 6e-8 apart in texels neither skips; llvmpipe compiles them alike
    tol = FLT_MIN if software_renderer(gl_ctx) else 1e-6
    for name in (TRANSMITTED, "deon_diffuse", "image"):
        a, b = skip[name].astype(np.float64), full[name].astype(np.float64)
        if skip[name].dtype.kind in "ui":  # 8-bit: a difference that rounds across a level
            assert np.abs(a - b).max() <= (0 if tol == FLT_MIN else 1), name
        else:
            assert np.abs(a - b).max() <= tol * max(1.0, np.abs(b).max()), name
    lit = full[TRANSMITTED][..., :3]
    assert (lit > FLT_MIN).any(axis=-1).sum() > 100  # light goes through
    _, marked = _render(gl_ctx, s, skip=True, mark=True)
    t = marked[TRANSMITTED][..., :3]
    skipped = (t == -1.0).all(axis=-1)
    if scene == "head":  # the back of the head (front-lit) or the face (back-lit): ~40-50 % of the texels
        assert skipped.sum() > 0.3 * (marked["texel_surface_128_p"][..., 3] != 0).sum(), "too little skipped"
    else:  # a thin slab: every texel is within reach of its lit side
        assert skipped.sum() == 0
    assert np.abs(np.where(skipped[..., None], 0.0, t) - lit).max() <= tol * max(1.0, np.abs(lit).max())  # only the marked differ
    assert not (lit[skipped] > FLT_MIN).any()


def _window_max(r: np.ndarray, lit: np.ndarray, block: int, radius: int) -> np.ndarray:
    """numpy: the largest r of the lit texels over each block's box window (radius blocks each side,
    clamped to the map); -inf where none."""
    n = r.shape[0]
    nb = -(-n // block)
    rr = np.where(lit, r, -np.inf)
    pad = np.full((nb * block, nb * block), -np.inf)
    pad[:n, :n] = rr
    blocks = pad.reshape(nb, block, nb, block).max(axis=(1, 3))
    out = np.full_like(blocks, -np.inf)
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            sh = np.full_like(blocks, -np.inf)
            ys, yd = slice(max(dy, 0), nb + min(dy, 0)), slice(max(-dy, 0), nb + min(-dy, 0))
            xs, xd = slice(max(dx, 0), nb + min(dx, 0)), slice(max(-dx, 0), nb + min(-dx, 0))
            sh[yd, xd] = blocks[ys, xs]
            out = np.maximum(out, sh)
    return out


@pytest.mark.parametrize("scene,extra", [("head", {}), ("backlit-ear", {})])
def test_the_max_map_holds_the_farthest_first_surface_in_reach(renderer, scene, extra):
    """deon_tsm_max = numpy's max over the TSM read back (texels with a surface), block by block over
    each channel's planned window; so no TSM texel within a channel's covered reach of a texel's block is
    farther."""
    tsm_size = 1024 if scene == "head" else 256  # the head's at the defaults: the reaches fill several windows
    s = small_settings(scene, "deon", 48, **{"deon.irradiance_size": 256, "deon.tsm_size": tsm_size, **extra})
    renderer.render(s)
    g = renderer.graph("deon")
    tsm, got = g.read(TSM), g.read(TSM_MAX)[..., 0]
    n, block, radii = g._last_refl["deon_tsm_max"].planned["tsm_max"]
    assert tsm.shape[:2] == (n, n) and got.shape == (-(-n // block),) * 2
    got4 = g.read(TSM_MAX)
    for ch, radius in enumerate(radii):  # each channel its own window
        want = _window_max(tsm[..., 0].astype(np.float64), tsm[..., 3] >= 0.0, block, radius)
        empty = ~np.isfinite(want)
        assert np.array_equal(got4[..., ch][~empty], want[~empty].astype(np.float32)), ch
        assert (got4[..., ch][empty] <= -1e29).all()  # no surface in reach: below any distance
        assert (~empty).sum() > 10 and radius * block >= 3
    assert radii[0] == max(radii)  # R: the widest reach (the texel's bound before the per-Gaussian channels)
    if scene == "head":  # the taps' 1 texel and the gathered Gaussians' spirals: several windows
        assert len(set(radii)) >= 2 and min(radii) == 1


@pytest.mark.parametrize("n_gather", [1, 4, 16, 64])
def test_the_reach_covers_the_gather_spiral(n_gather):
    """tsm_reach_texels bounds every sample lib/tsm_transmit.glsl's tsm_gathered takes (its spiral's
    radii, computed as the shader does), and the planned blocks cover it with the shader's +2 texels."""
    texel_mm = 0.31
    for v in (0.567, 1.99, 7.41):
        for k2 in (1.0, 2.0):
            reach = tsm_reach_texels(v, texel_mm, n_gather, k2)
            sig = math.sqrt(0.5 * k2 * v)
            k = np.arange(n_gather, dtype=np.float64)
            rad = sig * np.sqrt(-2.0 * np.log(1.0 - (k + 0.5) / n_gather))
            assert rad.max() / texel_mm <= reach * (1 + 1e-9)
            radius = math.ceil((reach + 3.0) / 8)
            assert min(tsm_max_covered((1024, 8, (radius,) * 4))) >= reach + 2.0
            radii = tsm_max_radii([1.0, reach, 2.0 * reach], 1024, 8)
            assert radius in radii and max(radii) == radii[0] and min(radii) == 1
    assert tsm_reach_texels(7.41, 0.31, 0, 2.0) == 1.0  # no gather: the 3x3 taps
    assert tsm_reach_texels(0.1, 0.31, 16, 2.0) == 1.0  # narrower than 2 texels: not gathered


def _ran(rep) -> set[str]:
    return {p.name for p in rep.passes if p.status == "ran"}


def test_a_light_move_reruns_the_max_and_a_camera_move_keeps_it(renderer):
    s = small_settings("head", "deon", 48, **{"deon.irradiance_size": 256, "deon.tsm_size": 256})
    assert "deon_tsm_max" in _ran(renderer.render(s))
    moved = with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0], "lights.1.direction": [-0.4, 0.1, -1.0]})
    ran = _ran(renderer.render(moved))
    assert {"deon_tsm", "deon_tsm_max", "deon_transmitted"} <= ran
    ran = _ran(renderer.render(with_values(moved, {"camera.yaw": 25.0})))
    assert "deon_tsm_max" not in ran and "deon_tsm" not in ran
    # the reach follows the widest Gaussian: a wider one re-plans the window
    wide = with_values(moved, {"deon.gaussians.5.variance": 4.0 * s.deon.gaussians[5].variance})
    assert "deon_tsm_max" in _ran(renderer.render(wide))


@pytest.mark.skipif(__import__("shutil").which("glslangValidator") is None, reason="glslangValidator not installed")
def test_the_skip_shaders_pass_the_reference_compiler(gl_ctx, tmp_path):
    """deon_tsm_max's two programs and the transmitted programs with the skip compile with Khronos'
    reference compiler (stricter than Mesa)."""
    import subprocess

    from skinviewer.kernel.shaders import ShaderLibrary
    lib = ShaderLibrary(gl_ctx)
    skip = {"GAUSSIAN_MASK": 63, "TSM_SKIP": 1}
    for name, defines in [("deon_tsm_max", {"TSM_MAX_BLOCK": 1}), ("deon_tsm_max", {"TSM_MAX_BLOCK": 0}),
                          ("deon_transmitted_texels", {**skip, "TSM_GATHER_N": 16, "TILED": 1, "TEXEL_STEPS": 0}),
                          ("deon_transmitted_texels", {**skip, "TSM_GATHER_N": 0, "TILED": 1, "TEXEL_STEPS": 0,
                                                       "TSM_SKIP_MARK": -1.0}),
                          ("deon_transmitted", {**skip, "TSM_GATHER_N": 16})]:
        srcs = lib._assemble(name, tuple((str(k), str(v)) for k, v in sorted(defines.items())))[0]
        f = tmp_path / f"{name}.frag"
        f.write_text(srcs["fragment_shader"])
        r = subprocess.run(["glslangValidator", str(f)], capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, (name, defines, r.stdout[-600:])


def _render_cut(ctx, s, cut: bool):
    deon_passes.TSM_TAPS_CUT, deon_passes.TSM_CUT = cut, False  # exact: the taps' cuts alone
    r = Renderer(ctx)
    try:
        r.render(s)
        g = r.graph("deon")
        return {k: g.read(k) for k in (TRANSMITTED, "deon_diffuse", "image")}
    finally:
        r.release()
        deon_passes.TSM_TAPS_CUT, deon_passes.TSM_CUT = True, True


@pytest.mark.parametrize("scene,extra", [("backlit-ear", {}), ("head", {}), ("head", BACK_LIT)],
                         ids=["backlit-ear", "head-front-lit", "head-back-lit"])
def test_the_tap_cuts_are_the_full_taps(gl_ctx, scene, extra):
    """The 3x3 taps' terms computed only for the Gaussians that read them (not gathered) and that the max
    map does not prove 0 (TSM_TAPS_NARROW, TSM_TAPS_SKIP) give the transmitted light, the diffuse sum and
    the image of every tap term computed (up to llvmpipe's own denormal noise), with light going through."""
    tsm_size = 1024 if scene == "head" else 256
    s = small_settings(scene, "deon", 64, **{"deon.irradiance_size": 256, "deon.tsm_size": tsm_size, **extra})
    full, cut = _render_cut(gl_ctx, s, cut=False), _render_cut(gl_ctx, s, cut=True)
    tol = FLT_MIN if software_renderer(gl_ctx) else 1e-6
    for name in (TRANSMITTED, "deon_diffuse", "image"):
        a, b = cut[name].astype(np.float64), full[name].astype(np.float64)
        if cut[name].dtype.kind in "ui":
            assert np.abs(a - b).max() <= (0 if tol == FLT_MIN else 1), name
        else:
            assert np.abs(a - b).max() <= tol * max(1.0, np.abs(b).max()), name
    assert (full[TRANSMITTED][..., :3] > FLT_MIN).any(axis=-1).sum() > 100  # light goes through


@pytest.mark.parametrize("scene,extra", [("backlit-ear", {}), ("head", {}), ("head", BACK_LIT)],
                         ids=["backlit-ear", "head-front-lit", "head-back-lit"])
def test_the_cut_stays_under_its_bound(gl_ctx, scene, extra):
    """The default threshold (passes.deon.TSM_CUT: a term below 2^-24 of its lit point's light counts as 0)
    against the full path: every texel of the transmitted light within e^-TSM_CUT_ZERO x sum_i w_i x
    max(20 max E, max blur) per channel (numpy, from the maps read back: eq. 33's terms are each below
    e^-Z times E / cos A <= 20 E or a blur), it does cut something on the head, and the lit and displayed
    images are the same bit for bit (what the cut is allowed to do)."""
    tsm_size = 1024 if scene == "head" else 256
    s = small_settings(scene, "deon", 64, **{"deon.irradiance_size": 256, "deon.tsm_size": tsm_size, **extra})
    _, full = _render(gl_ctx, s, skip=False)
    _, cut = _render(gl_ctx, s, skip=True, cut=True)
    e_max = max(float(np.abs(full[deon_passes.IRRADIANCE][..., :3]).max()) * 20.0,
                max(float(np.abs(v[..., :3]).max()) for k, v in full.items() if k.startswith("blur_")))
    w = np.array([g.weights for g in s.deon.gaussians], np.float64)  # (Gaussians, rgb)
    bound = math.exp(-deon_passes.TSM_CUT_ZERO) * np.abs(w).sum(axis=0) * e_max  # per channel
    d = np.abs(cut[TRANSMITTED][..., :3].astype(np.float64) - full[TRANSMITTED][..., :3].astype(np.float64))
    assert (d <= bound + FLT_MIN).all(), (d.max(axis=(0, 1)), bound)
    if scene == "head":
        assert (d > 0).any()  # it cuts (a threshold that never acts tests nothing)
    assert (full[TRANSMITTED][..., :3] > FLT_MIN).any(axis=-1).sum() > 100  # light goes through
    for name in ("lit", "image"):
        assert np.array_equal(cut[name], full[name]), name
