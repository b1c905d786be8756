"""The PCF's exact early-out (issue 27; lib/lights.glsl SHADOW_BOUNDS, shaders/shadow_bounds.frag,
passes.shadow_map.ShadowBoundsPass; off by default, passes.common.PCF_BOUNDS / SKINVIEWER_PCF_BOUNDS=1):
the bounds map holds, per block of the shadow map, a plane under every depth a lookup from the block
reads and the span above it, and the specialised shadow test returns what its taps would (every test 1 or
every test 0) without reading them. Checked: d'Eon's irradiance and visibility and Phong's image with the
early-out equal those without it bit for bit (head front- and back-lit, a shadow edge, a grazing light,
pcf 1 / 2, bilinear and box), while it does decide lookups (a marker counts them); the bounds map
against numpy over the shadow map read back; the run report (a light move re-runs the bounds, a camera
move keeps them); pcf 0 (one tap: nothing to skip) declares no bounds."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import small_settings

import skinviewer.passes.common as common
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import with_values

BACK_LIT = {"lights.0.direction": [0.0, 0.2, -1.0], "lights.1.direction": [0.1, 0.0, -1.0]}
GRAZING = {"lights.0.direction": [1.0, 0.05, 0.06]}


def _render(ctx, s, bounds: bool, mark: bool = False):
    common.PCF_BOUNDS, common.PCF_BOUNDS_MARK = bounds, mark
    r = Renderer(ctx)
    try:
        rep = r.render(s)
        g = r.graph(s.technique)
        return rep, {k: g.read(k) for k in g.resources()}
    finally:
        r.release()
        common.PCF_BOUNDS, common.PCF_BOUNDS_MARK = False, False


def _ran(rep) -> set[str]:
    return {p.name for p in rep.passes if p.status == "ran"}


CASES = [("head", {}), ("head", BACK_LIT), ("shadow-edge", {}), ("head", GRAZING),
         ("head", {"shadow.pcf": 2}), ("head", {"shadow.pcf_filter": "box"}),
         ("head", {"shadow.pcf_filter": "box", "shadow.pcf": 2, **BACK_LIT})]
IDS = ["head-front-lit", "head-back-lit", "shadow-edge", "grazing", "pcf2", "box", "box-pcf2-back-lit"]


@pytest.mark.parametrize("scene,extra", CASES, ids=IDS)
def test_the_early_out_is_the_full_pcf(gl_ctx, scene, extra):
    """d'Eon's irradiance and per-light visibility (the shadow test's own output), and its image, are
    the same bits with the early-out as without; the early-out decided lookups lit and shadowed."""
    s = small_settings(scene, "deon", 64, **{"deon.specular_shadows": "texture", **extra})
    _, full = _render(gl_ctx, s, bounds=False)
    rep, fast = _render(gl_ctx, s, bounds=True)
    assert "shadow_bounds_0" in _ran(rep) and "shadow_bounds_0" not in full
    for name in ("deon_irradiance", "deon_visibility", "image"):  # the bytes: -0.0 is not +0.0
        assert fast[name].tobytes() == full[name].tobytes(), name
    vis = full["deon_visibility"][..., 0].astype(np.float32)
    assert (vis > 0.0).sum() > 100 and (vis == 0.0).sum() > 100  # lit and shadowed texels
    _, marked = _render(gl_ctx, s, bounds=True, mark=True)
    m = marked["deon_visibility"][..., 0].astype(np.float32)
    decided = (m == -1.0) | (m == -2.0)
    assert (m == -1.0).sum() > 100, "no lookup decided lit"
    if scene == "head" and "shadow.pcf_filter" not in extra:  # bilinear: most lit lookups decided
        assert decided.sum() > 0.3 * (vis > 0.0).sum()
    # a decided texel is one whose full test was all lit (the weights' sum / 9: 1 within float32's rounding,
    # which the half-float visibility may store one step under 1) or all shadowed (0)
    assert (vis[m == -1.0] >= 1.0 - 2.0 ** -10).all() and (vis[m == -2.0] == 0.0).all()
    assert np.array_equal(m[~decided], vis[~decided])


@pytest.mark.parametrize("extra", [{}, {"shadow.pcf_filter": "box"}, GRAZING], ids=["bilinear", "box", "grazing"])
def test_phong_is_the_same_with_the_early_out(gl_ctx, extra):
    """Every technique's lit passes share the test: Phong's every texture is the same bits."""
    s = small_settings("head", "phong", 96, **extra)
    _, full = _render(gl_ctx, s, bounds=False)
    rep, fast = _render(gl_ctx, s, bounds=True)
    assert "shadow_bounds_0" in _ran(rep)
    for name, tex in full.items():  # the bytes: -0.0 is not +0.0
        assert fast[name].tobytes() == tex.tobytes(), name


@pytest.mark.parametrize("scene,extra", [("head", {}), ("head", {"shadow.pcf": 3}), ("shadow-edge", {})],
                         ids=["head", "pcf3", "shadow-edge"])
def test_the_bounds_hold_every_depth_of_the_window(gl_ctx, scene, extra):
    """numpy over the shadow map read back: for every block whose window (the block +- pcf + 2 texels)
    is inside the map, every depth of the window lies in [P'(u), P'(u) + s] (P' the stored plane, up to
    float32 rounding far below the shader's 1e-5 margin) and the lowest touches the plane; a block at
    the map's edge stores s = -1 (never decided)."""
    s = small_settings(scene, "phong", 48, **extra)
    common.PCF_BOUNDS = True
    r = Renderer(gl_ctx)
    try:
        r.render(s)
        g = r.graph("phong")
        depth = g.read("shadow_map_0")[..., 0].astype(np.float64)
        got = g.read("shadow_bounds_0").astype(np.float64)
    finally:
        r.release()
        common.PCF_BOUNDS = False
    n, B, m = depth.shape[0], common.SHADOW_BOUNDS_BLOCK, int(s.shadow.pcf) + 2
    nb = -(-n // B)
    assert got.shape[:2] == (nb, nb)
    inside = 0
    for by in range(nb):
        for bx in range(nb):
            a, gx, gy, span = got[by, bx]
            lo, hi = np.array([bx, by]) * B - m, np.array([bx, by]) * B + B + m - 1
            if (lo < 0).any() or (hi >= n).any():
                assert span == -1.0
                continue
            assert span >= 0.0 and np.isfinite([a, gx, gy]).all()
            y, x = np.mgrid[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1]
            ub = (np.array([bx, by]) * B + 0.5 * B) / n
            plane = a + gx * ((x + 0.5) / n - ub[0]) + gy * ((y + 0.5) / n - ub[1])
            res = depth[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1] - plane
            tol = 1e-6 * (1.0 + abs(a) + (abs(gx) + abs(gy)) * (B + 2 * m) / n)
            assert res.min() >= -tol and res.max() <= span + tol, (bx, by)
            assert res.min() <= tol  # the lower envelope: the plane touches the window's lowest depth
            inside += 1
    assert inside > nb * nb // 2


def test_a_light_move_reruns_the_bounds_and_a_camera_move_keeps_them(gl_ctx):
    common.PCF_BOUNDS = True
    r = Renderer(gl_ctx)
    try:
        s = small_settings("head", "deon", 48)
        assert "shadow_bounds_0" in _ran(r.render(s))
        moved = with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0]})
        assert {"shadow_map_0", "shadow_bounds_0", "deon_irradiance"} <= _ran(r.render(moved))
        ran = _ran(r.render(with_values(moved, {"camera.yaw": 40.0})))
        assert "shadow_bounds_0" not in ran and "deon_irradiance" not in ran
        ran = _ran(r.render(with_values(moved, {"lights.0.intensity": 2.0})))  # the colour: the map is kept
        assert "shadow_bounds_0" not in ran and "deon_irradiance" in ran
        assert "shadow_bounds_0" in _ran(r.render(with_values(moved, {"shadow.pcf": 2})))  # the window's margin
        rep = r.render(with_values(moved, {"shadow.pcf": 0}))  # one tap: nothing to skip, no bounds read
        assert "shadow_bounds_0" not in _ran(rep)
        assert any(p.name == "shadow_bounds_0" and p.status == "pruned" for p in rep.passes)
    finally:
        r.release()
        common.PCF_BOUNDS = False


@pytest.mark.skipif(__import__("shutil").which("glslangValidator") is None, reason="glslangValidator not installed")
def test_the_bounds_shaders_pass_the_reference_compiler(gl_ctx, tmp_path):
    """shadow_bounds and a lit program with the early-out (bilinear, box, marked) compile with Khronos'
    reference compiler (stricter than Mesa)."""
    import subprocess

    from skinviewer.kernel.shaders import ShaderLibrary
    lib = ShaderLibrary(gl_ctx)
    lit = {"LIGHT_COUNT": 2, "SHADOW_MASK": 3, "POINT_MASK": 0, "BEAM_MASK": 0, "SHADOW_PCF": 1,
           "SHADOW_BOUNDS": 1, "SHADOW_BOUNDS_BLOCK": 8}
    for name, defines in [("shadow_bounds", {"SHADOW_BOUNDS_BLOCK": 8}), ("phong", {**lit, "SHADOW_BILINEAR": 1}),
                          ("phong", {**lit, "SHADOW_BILINEAR": 0}),
                          ("phong", {**lit, "SHADOW_BILINEAR": 1, "SHADOW_BOUNDS_MARK": 1})]:
        srcs = lib._assemble(name, tuple((str(k), str(v)) for k, v in sorted(defines.items())))[0]
        f = tmp_path / f"{name}.frag"
        f.write_text(srcs["fragment_shader"])
        r = subprocess.run(["glslangValidator", str(f)], capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, (name, defines, r.stdout[-600:])


@pytest.mark.parametrize("extra", [{}, {"deon.texel_samples": 4}, {"render.texel_surface": False}],
                         ids=["texels", "four-samples", "unwrapped"])
def test_the_irradiance_and_its_visibility_dilated_in_one_draw(gl_ctx, extra):
    """d'Eon's irradiance and visibility dilated in one draw (dilate.frag DILATE_MORE, issue 27) are the
    same bytes as dilated one draw each (texture_space.DILATE_PAIRS off), one draw fewer."""
    import skinviewer.passes.texture_space as ts
    s = small_settings("head", "deon", 64, **{"deon.specular_shadows": "texture", **extra})
    got = {}
    for pair in (False, True):
        ts.DILATE_PAIRS = pair
        r = Renderer(gl_ctx)
        try:
            rep = r.render(s)
            drew = [p.draws for p in rep.passes if p.name == "deon_irradiance"][0]
            g = r.graph("deon")
            got[pair] = ({k: g.read(k).tobytes() for k in ("deon_irradiance", "deon_visibility", "image")}, drew)
        finally:
            r.release()
            ts.DILATE_PAIRS = True
    assert got[True][0] == got[False][0]
    assert got[True][1] == got[False][1] - 1  # one dilate draw fewer
