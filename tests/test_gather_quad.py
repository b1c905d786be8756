"""d'Eon's split summed step four texels a fragment (issue 27, passes.deon.quad_sum: deon_gather_quad.frag
sums the island texels of each 2 x 2 block at half size, sharing their taps' fetches; deon_gather_pick.frag
gives each texel its island texel's sum): bit for bit the one-texel sum (deon_gather_sum.frag), whole, in
tiles, with the flat outer rings, with rings past the kept ones, without seams and on the scan; where it
applies."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import LPS_GLB
from helpers import first_gathered_step, small_settings

import skinviewer.passes.deon as deon_passes
from skinviewer.physics.diffusion import blur_resource

CASES = {
    "head": ("head", {}, None),
    "head-flat-rings": ("head", {}, 2),  # rings past LIT_RING at the area's mean light (FLAT)
    "head-no-seams": ("head", {"scene.seam_aware": False}, None),  # the sum reads the irradiance itself
    "scan": ("head", "scan", None),
    "shadow-edge": ("shadow-edge", {}, None),  # an open border; a fourth ring, its weights computed in the sum (LIVE)
    "shadow-edge-flat": ("shadow-edge", {}, 2),
}


def _run(renderer, monkeypatch, s, quad: str) -> dict[str, np.ndarray]:
    monkeypatch.setattr(deon_passes, "QUAD_SUM", quad)
    rep = renderer.render(s, force=True)  # a forced run reflects afresh: QUAD_SUM is a module constant
    g, _, step = first_gathered_step(renderer, s, s.deon.irradiance_size)
    blur = next(p for p in rep.passes if p.name == f"deon_blur_{step.index}")
    assert blur.status == "ran"
    programs = {name for name, _ in g._last_refl[blur.name].programs}
    assert ({"deon_gather_quad", "deon_gather_pick"} <= programs) is (quad == "1"), programs
    return {k: g.read(k).copy() for k in (blur_resource(step.index), "lit", "image")}


@pytest.mark.parametrize("case", list(CASES))
def test_the_quad_sum_is_the_one_texel_sum_bit_for_bit(renderer, monkeypatch, case):
    scene, extra, lit_ring = CASES[case]
    if extra == "scan":
        if not LPS_GLB.is_file():
            pytest.skip(f"needs the shared Lee Perry-Smith scan at {LPS_GLB}")
        extra = {"scene.mesh": str(LPS_GLB), "scene.mm_per_unit": 48.0}
    monkeypatch.setattr(deon_passes, "LIT_RING", lit_ring)
    s = small_settings(scene, "deon", size=64, **{"deon.irradiance_size": 256, **extra})
    one = _run(renderer, monkeypatch, s, "0")
    quad = _run(renderer, monkeypatch, s, "1")
    for k, want in one.items():
        assert np.array_equal(_flushed(quad[k]), _flushed(want), equal_nan=True), (case, k, float(np.abs(quad[k] - want).max()))


def _flushed(a: np.ndarray) -> np.ndarray:
    """Values under 1e-30 as 0: llvmpipe's threads flush float32 denormals or not, run to run (the one-texel
    sum rendered twice differs there, by < 1e-36), so only those are not compared bit for bit."""
    return np.where(np.abs(a) < 1e-30, 0.0, a)


def test_the_quad_sum_applies_on_a_software_rasterizer_to_even_maps(renderer, monkeypatch):
    s = small_settings("head", "deon", size=64, **{"deon.irradiance_size": 256})
    g, texel, step = first_gathered_step(renderer, s, 256)
    r = type("R", (), {"settings": s, "scene": renderer.scene.gpu})()
    from skinviewer.kernel.gl import software_renderer
    soft = software_renderer(renderer.ctx)
    for mode, want in (("auto", soft), ("1", True), ("0", False)):  # auto: a software rasterizer only
        monkeypatch.setattr(deon_passes, "QUAD_SUM", mode)
        assert deon_passes.quad_sum(r, step, 256) is want, mode
    monkeypatch.setattr(deon_passes, "QUAD_SUM", "1")
    assert not deon_passes.quad_sum(r, step, 255)  # an odd map: the half-size sums would miss a column


@pytest.mark.skipif(__import__("shutil").which("glslangValidator") is None, reason="glslangValidator not installed")
def test_the_quad_shaders_pass_the_reference_compiler(gl_ctx, tmp_path):
    """deon_gather_quad (kept rings, a live fourth ring, flat rings; tiled) and deon_gather_pick compile with
    Khronos' reference compiler (stricter than Mesa: four MRT outputs, constant indices only)."""
    import subprocess

    from skinviewer.kernel.shaders import ShaderLibrary
    lib = ShaderLibrary(gl_ctx)
    base = {"KEPT_RINGS": 3, "WEIGHT_TEXTURES": 19, "TILED": 2}
    for name, defines in [("deon_gather_quad", {**base, "GATHER_BLOCKS": 3}),
                          ("deon_gather_quad", {**base, "GATHER_BLOCKS": 5}),
                          ("deon_gather_quad", {**base, "GATHER_BLOCKS": 4, "LIT_RING": 2}),
                          ("deon_gather_pick", {"TILED": 2})]:
        srcs = lib._assemble(name, tuple((str(k), str(v)) for k, v in sorted(defines.items())))[0]
        for stage, ext in (("vertex_shader", "vert"), ("fragment_shader", "frag")):
            f = tmp_path / f"{name}.{ext}"
            f.write_text(srcs[stage])
            r = subprocess.run(["glslangValidator", str(f)], capture_output=True, text=True, timeout=60)
            assert r.returncode == 0, (name, defines, stage, r.stdout[-600:])
