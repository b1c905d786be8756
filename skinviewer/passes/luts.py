"""Lookup-texture passes shared by the texture-space techniques (Gosselin and d'Eon).

Each LUT is computed in numpy (``skinviewer.physics.specular``) and uploaded into the graph-owned output
texture (f4, one channel, LINEAR, CLAMP_TO_EDGE: the sampling ``shaders/lib/kelemen.glsl`` assumes).
A LUT pass reads no scene and no camera, so it runs once per change of its own settings; passes that
sample it declare it as an input only in the mode that uses it, so otherwise it is pruned.
"""
from __future__ import annotations

import functools

import numpy as np

from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec
from skinviewer.physics import specular

BECKMANN_LUT = "beckmann_lut"


@functools.lru_cache(maxsize=4)
def _beckmann_table(size: int) -> bytes:
    return np.ascontiguousarray(specular.beckmann_lut(size), dtype=np.float32).tobytes()


class BeckmannLutPass(Pass):
    """Listing 14-2 (seed 002): 0.5 * PH(N.H, m)^0.1, columns = N.H, rows = m, texel centres.
    Depends on ``specular.lut_size`` only."""
    name = "beckmann_lut"
    uses_scene = False

    def reflect(self, r: Reflection) -> None:
        n = r.settings.specular.lut_size
        r.output(BECKMANN_LUT, TexSpec((n, n), 1, "f4", filter="linear"))

    def execute(self, ec) -> None:
        n = ec.settings.specular.lut_size
        tex = ec.output(BECKMANN_LUT)
        tex.repeat_x = tex.repeat_y = False
        tex.write(_beckmann_table(int(n)))
