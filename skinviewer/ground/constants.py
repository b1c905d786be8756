"""The one source of every constant shared by Python and GLSL (the Falcor "host/device" file).

The ShaderLibrary injects ``GLSL_DEFINES`` as ``#define``s into every program it compiles, so a
shader writes ``MAX_LIGHTS`` and never the number; Python imports the names from here.
"""
from __future__ import annotations

MAX_LIGHTS = 4      # lights a lit pass evaluates (settings.lights max_length; shadow_map0..3)
MAX_GAUSSIANS = 8   # d'Eon sum-of-Gaussians terms (settings.deon.gaussians max_length; blur0..7)
MAX_PCF = 3         # largest percentage-closer filter radius in texels (a 7x7 footprint)

# Facial regions of the region-ID map; the ID stored in the map is the index in this tuple.
REGIONS: tuple[str, ...] = ("other", "forehead", "nose", "cheeks", "lips", "chin", "ears", "neck", "scalp")
N_REGIONS = len(REGIONS)

# Largest magnitude a pass writes into a texture: every lit value is made finite and clamped to
# the range of its format (half floats hold 65504; float32 targets keep lights of 1e6 exact).
HALF_MAX = 65000.0
FLOAT_MAX = 1e30

# Light kinds as the shaders see them (u_light_kind, u_tsm_kind).
LIGHT_KINDS: dict[str, int] = {"directional": 0, "point": 1, "beam": 2, "environment": 3}


def _glsl_float(x: float) -> str:
    s = repr(float(x))
    return s if ("." in s or "e" in s) else s + ".0"


GLSL_DEFINES: dict[str, str] = {
    "MAX_LIGHTS": str(MAX_LIGHTS),
    "MAX_GAUSSIANS": str(MAX_GAUSSIANS),
    "MAX_PCF": str(MAX_PCF),
    "N_REGIONS": str(N_REGIONS),
    "HALF_MAX": _glsl_float(HALF_MAX),
    "FLOAT_MAX": _glsl_float(FLOAT_MAX),
    **{f"LIGHT_{k.upper()}": str(v) for k, v in LIGHT_KINDS.items()},
}
