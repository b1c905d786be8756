"""The summed step's seam fill split into seam and plain tiles, and deon_combine fetching a texture two blur
slots share once (issue 27, session 9: passes.deon.GATHER_FILL_SPLIT, COMBINE_ONCE, blur_sources): the
same textures bit for bit as without them, whole and in bands, on the head (quad sum on and off), without
seams, on the scan and past an open border (where the fill is not split)."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import LPS_GLB
from helpers import small_settings

import skinviewer.passes.deon as deon_passes
from skinviewer.physics.diffusion import blur_resource

CASES = {
    "head": ("head", {}, "auto"),
    "head-one-texel-sum": ("head", {}, "0"),  # the fill split with deon_gather_sum.frag
    "head-no-seams": ("head", {"scene.seam_aware": False}, "auto"),  # no fill at all
    "scan": ("head", "scan", "auto"),
    "shadow-edge": ("shadow-edge", {}, "auto"),  # an open border: the fill keeps its one draw (RIM_SHARE)
}


def _flushed(a: np.ndarray) -> np.ndarray:
    """Values under 1e-30 as 0 (llvmpipe flushes float32 denormals or not, run to run: test_gather_quad)."""
    return np.where(np.abs(a) < 1e-30, 0.0, a)


def _cuts(monkeypatch, on: bool) -> None:
    monkeypatch.setattr(deon_passes, "GATHER_FILL_SPLIT", on)
    monkeypatch.setattr(deon_passes, "COMBINE_ONCE", on)


def _settings(scene, extra):
    if extra == "scan":
        if not LPS_GLB.is_file():
            pytest.skip(f"needs the shared Lee Perry-Smith scan at {LPS_GLB}")
        extra = {"scene.mesh": str(LPS_GLB), "scene.mm_per_unit": 48.0}
    return small_settings(scene, "deon", size=64, **{"deon.irradiance_size": 256, **extra})


def _run(renderer, monkeypatch, s, on: bool):
    _cuts(monkeypatch, on)
    rep = renderer.render(s, force=True)  # a forced run reflects afresh: the switches are module constants
    g = renderer.graph("deon")
    gathered = [p.name for p in rep.passes if p.name.startswith("deon_blur_") and "sigma_texels" in p.figures]
    assert gathered, "no summed step ran"
    names = [blur_resource(int(p.rsplit("_", 1)[1])) for p in gathered]
    out = {k: g.read(k).copy() for k in (*names, "deon_diffuse", "lit", "image")}
    draws = {p.name: p.draws for p in rep.passes}
    programs = {p: [d for n, d in g._last_refl[p].programs] for p in (*gathered, "deon_combine")}
    return out, draws, programs, gathered


@pytest.mark.parametrize("case", list(CASES))
def test_the_cuts_give_the_same_textures_bit_for_bit(renderer, monkeypatch, case):
    scene, extra, quad = CASES[case]
    monkeypatch.setattr(deon_passes, "QUAD_SUM", quad)
    s = _settings(scene, extra)
    before, draws0, _, gathered = _run(renderer, monkeypatch, s, False)
    after, draws1, programs, _ = _run(renderer, monkeypatch, s, True)
    for k, want in before.items():
        assert np.array_equal(_flushed(after[k]), _flushed(want), equal_nan=True), (case, k, float(np.nanmax(np.abs(after[k] - want))))
    g = gathered[0]
    fills = [d for d in programs[g] if ("RIM_SHARE", 1) not in d and any(k == "NO_SEAM" for k, _ in d)]
    if case in ("head", "head-one-texel-sum", "scan"):  # seams, no border: the plain tiles take one more draw
        assert fills, programs[g]
        assert draws1[g] == draws0[g] + 1, (draws0[g], draws1[g])
    else:
        assert not fills and draws1[g] == draws0[g]
    (d,) = programs["deon_combine"]  # the sources of the used slots that share a texture
    d = dict(d)
    textures = tuple(renderer.graph("deon")._last_refl["deon_combine"].planned.textures)
    shared = deon_passes.blur_sources(textures, d["GAUSSIAN_MASK"])
    assert d.get("BLUR_SOURCES", 0o76543210) == shared
    if case.startswith("head"):  # blur_0..2 are the irradiance itself on the head at 256^2
        assert shared != 0o76543210


def test_the_cuts_are_bit_identical_in_bands(renderer, monkeypatch):
    """Under a tiny frame budget the summed step (its split fill in the first band) and the combine run in
    bands over frames: the same textures as one whole frame."""
    from test_tiles import settle
    _cuts(monkeypatch, True)
    s = _settings("head", {})
    renderer.render(s, force=True)
    g = renderer.graph("deon")
    keys = ("blur_5", "deon_diffuse", "image")
    whole = {k: g.read(k).copy() for k in keys}
    from skinviewer.ground.settings import with_values
    renderer.render(with_values(s, {"lights.0.direction": [0.3, 0.2, 1.0]}))
    reports = settle(renderer, s)
    assert any(p.status == "deferred" and "band" in p.reason for rep in reports for p in rep.passes
               if p.name == "deon_blur_5")
    for k, want in whole.items():
        assert np.array_equal(_flushed(g.read(k)), _flushed(want)), k


def test_blur_sources_names_the_first_used_slot_with_the_same_texture():
    tex = ("deon_irradiance", "deon_irradiance", "deon_irradiance", "blur_3", "blur_4", "blur_5")
    own = 0o76543210

    def slot(code, k):
        return (code >> (3 * k)) & 7
    code = deon_passes.blur_sources(tex, 0b111111)
    assert [slot(code, k) for k in range(8)] == [0, 0, 0, 3, 4, 5, 6, 7]
    code = deon_passes.blur_sources(tex, 0b111110)  # slot 0 unused: slot 2 takes slot 1's fetch
    assert [slot(code, k) for k in range(8)] == [0, 1, 1, 3, 4, 5, 6, 7]
    code = deon_passes.blur_sources(tex, 0b111010)  # slot 2 unused too: nothing shared
    assert code == own
    assert deon_passes.blur_sources(("a", "b", "c", "d"), 0b1111) == own
    assert "BLUR_SOURCES" not in deon_passes.combine_defines(("a", "b"), 3, 0)


def test_the_combine_with_shared_fetches_is_the_combine_for_every_mask(renderer, monkeypatch):
    """A weight toggled to zero changes which slot fetches (blur_sources): each mask's image equals the one
    without the shared fetches, and the variants warmed for the toggles carry their own sources."""
    from skinviewer.ground.settings import with_values
    s = _settings("head", {})
    for w in ([0.0, 0.0, 0.0], None):
        t = with_values(s, {"deon.gaussians.0.weights": w}) if w else s
        before, _, _, _ = _run(renderer, monkeypatch, t, False)
        after, _, programs, _ = _run(renderer, monkeypatch, t, True)
        for k in ("deon_diffuse", "image"):
            assert np.array_equal(_flushed(after[k]), _flushed(before[k])), (w, k)
        (d,) = programs["deon_combine"]
        d = dict(d)
        assert d["BLUR_SOURCES"] == deon_passes.blur_sources(
            tuple(renderer.graph("deon")._last_refl["deon_combine"].planned.textures), d["GAUSSIAN_MASK"])
    likely = [v for n, v in renderer.graph("deon").likely_programs() if n == "deon_combine"]
    assert likely
    textures = tuple(renderer.graph("deon")._last_refl["deon_combine"].planned.textures)
    for v in likely:
        assert v.get("BLUR_SOURCES", 0o76543210) == deon_passes.blur_sources(textures, v["GAUSSIAN_MASK"]), v


@pytest.mark.skipif(__import__("shutil").which("glslangValidator") is None, reason="glslangValidator not installed")
def test_the_combine_with_shared_fetches_passes_the_reference_compiler(gl_ctx, tmp_path):
    """deon_combine with BLUR_SOURCES (slots 1 and 2 from slot 0; slot 2 from slot 1; slot 3 from slot 0) and
    the split fill's variants compile with Khronos' reference compiler (stricter than Mesa)."""
    import subprocess

    from skinviewer.kernel.shaders import ShaderLibrary
    lib = ShaderLibrary(gl_ctx)
    same = deon_passes.blur_sources(("e", "e", "e", "b3", "b4", "b5"), 63)
    cases = [("deon_combine", {"GAUSSIAN_MASK": 63, "HALF_MASK": 48, "BLUR_SOURCES": same}),
             ("deon_combine", {"GAUSSIAN_MASK": 62, "BLUR_SOURCES": deon_passes.blur_sources(("e", "e", "e", "e"), 62)}),
             ("deon_combine", {"GAUSSIAN_MASK": 15, "BLUR_SOURCES": deon_passes.blur_sources(("e", "a", "b", "e"), 15)}),
             ("seam_fill", {"TILED": 2}), ("seam_fill", {"TILED": 2, "NO_SEAM": 1})]
    for name, defines in cases:
        srcs = lib._assemble(name, tuple((str(k), str(v)) for k, v in sorted(defines.items())))[0]
        for stage, ext in (("vertex_shader", "vert"), ("fragment_shader", "frag")):
            f = tmp_path / f"{name}.{ext}"
            f.write_text(srcs[stage])
            r = subprocess.run(["glslangValidator", str(f)], capture_output=True, text=True, timeout=60)
            assert r.returncode == 0, (name, defines, stage, r.stdout[-600:])
