"""Specialised lit shaders (LIGHT_COUNT, SHADOW_PCF, SHADOW_MASK, POINT_MASK, BEAM_MASK defines;
shaders/lib/lights.glsl)
give bit-identical images to the generic, uniform-driven version (GENERIC_SHADERS)."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import small_settings

from skinviewer.kernel.shaders import ShaderCompileError, ShaderLibrary

# default lights (two, both shadowed, PCF 1); then three lights of every kind with an unshadowed
# one in the middle slot, a disabled one before it, and a wider PCF
CASES = {
    "default": {},
    "mixed": {"shadow.pcf": 2,
              "lights": [{"kind": "directional", "direction": (0.5, 0.3, 1.0), "intensity": 1.5},
                         {"kind": "point", "position": (0.0, 0.0, 400.0), "enabled": False},
                         {"kind": "point", "position": (-150.0, 80.0, 250.0), "intensity": 0.8,
                          "cast_shadow": False},
                         {"kind": "directional", "direction": (-0.7, 0.2, -0.9), "intensity": 1.1}]},
    "hard": {"shadow.pcf": 0},
    "beam": {"lights": [{"kind": "point", "position": (120.0, 60.0, 300.0), "intensity": 0.6},
                        {"kind": "beam", "position": (0.0, 20.0, 150.0), "direction": (0.0, 0.0, 1.0),
                         "beam_radius": 30.0, "intensity": 2.0}]},
    "box": {"shadow.pcf_filter": "box"},
    "npot": {"shadow.map_size": 200, "shadow.pcf": 2},  # the PCF's gathers at (X + 1) / size, size not 2^k
}


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("technique", ["phong", "gosselin", "deon"])
def test_specialised_equals_generic(renderer, generic, technique, case):
    s = small_settings("head", technique, 64, **CASES[case])
    renderer.render(s)
    generic.render(s)
    prog = [d for n, d in renderer.graph(technique)._last_refl[_lit_pass(technique)].programs
            if n != "dilate"][0]
    defines = dict(prog)
    assert defines["LIGHT_COUNT"] == sum(1 for l in s.lights if l.enabled)
    assert defines["SHADOW_PCF"] == s.shadow.pcf
    assert defines["SHADOW_BILINEAR"] == (s.shadow.pcf_filter == "bilinear")
    want_mask = sum(1 << k for k, l in enumerate([l for l in s.lights if l.enabled]) if l.cast_shadow)
    assert defines["SHADOW_MASK"] == want_mask
    on = [l for l in s.lights if l.enabled]
    assert defines["POINT_MASK"] == sum(1 << k for k, l in enumerate(on) if l.kind == "point")
    assert defines["BEAM_MASK"] == sum(1 << k for k, l in enumerate(on) if l.kind == "beam")
    for res in ("lit", "image") + (("deon_irradiance",) if technique == "deon" else ()) \
            + (("gosselin_light_map",) if technique == "gosselin" else ()):
        a, b = renderer.read(s, res), generic.read(s, res)
        assert np.array_equal(a, b), f"{technique}/{case}: {res} differs by up to {np.abs(a - b).max()}"
    assert renderer.image(s).max() > 0  # something was lit


def _lit_pass(technique):
    return {"phong": "phong", "gosselin": "gosselin_final", "deon": "deon_final"}[technique]


def test_generic_define_reaches_the_source(gl_ctx):
    lib, lib_spec = ShaderLibrary(gl_ctx, defines={"GENERIC_SHADERS": 1}), ShaderLibrary(gl_ctx)
    try:
        defines = {"LIGHT_COUNT": 1, "SHADOW_PCF": 1, "SHADOW_MASK": 1, "POINT_MASK": 0, "BEAM_MASK": 0}
        assert "u_light_count" in lib.get("phong", defines)  # the uniform-driven loop
        spec = lib_spec.get("phong", defines)
        assert "u_light_count" not in spec and "u_shadow_pcf" not in spec and "shadow_map1" not in spec
        assert "u_light_kind" not in spec and "u_beam_radius" not in spec  # no kind test, no beam coverage left
    finally:
        lib.release()
        lib_spec.release()


@pytest.mark.parametrize("samples", [1, 4])
def test_deon_texel_samples_compiled_in(renderer, generic, samples):
    """deon.texel_samples is a define of the irradiance program (issue 27: llvmpipe runs both sides of a
    branch on a uniform, so the unused 4-sample path cost the default 10-20 % of the pass): the
    uniform-driven branch is gone from it, and the irradiance equals the generic program's bit for bit."""
    s = small_settings("head", "deon", 64, **{"deon.texel_samples": samples})
    renderer.render(s)
    generic.render(s)
    graph = renderer.graph("deon")
    name, defines = [(n, dict(d)) for n, d in graph._last_refl["deon_irradiance"].programs if n != "dilate"][0]
    assert defines["DEON_TEXEL_SAMPLES"] == samples
    assert "u_texel_samples" not in graph.shaders.get(name, defines)  # no branch on the uniform left
    a, b = renderer.read(s, "deon_irradiance"), generic.read(s, "deon_irradiance")
    assert np.array_equal(a, b), f"texel_samples {samples}: the irradiance differs by up to {np.abs(a - b).max()}"
    assert a[..., :3].max() > 0


def test_pcf_taps_gathered(gl_ctx):
    """The specialised bilinear PCF reads its taps as textureGather 2 x 2 footprints where the GL has it
    (lib/lights.glsl PCF_GATHER, ~10 % of a lit pass's CPU on llvmpipe; notes/deon_light_move.md section
    18): a define that breaks the name breaks the bilinear program, not the box filter's, nor PCF_GATHER=0's.
    test_specialised_equals_generic checks its images against the generic shaders' texel fetches bit for bit."""
    assert "GL_ARB_texture_gather" in gl_ctx.extensions or gl_ctx.version_code >= 400
    lib = ShaderLibrary(gl_ctx)
    try:
        defines = {"LIGHT_COUNT": 1, "SHADOW_PCF": 1, "SHADOW_BILINEAR": 1, "SHADOW_MASK": 1, "POINT_MASK": 0,
                   "BEAM_MASK": 0, "textureGather": "no_such_function"}
        for name in ("phong", "deon_irradiance_texels"):
            with pytest.raises(ShaderCompileError):
                lib.get(name, defines)
            assert "shadow_map0" in lib.get(name, {**defines, "PCF_GATHER": 0})
            assert "shadow_map0" in lib.get(name, {**defines, "SHADOW_BILINEAR": 0})
    finally:
        lib.release()
