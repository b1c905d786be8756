"""The screen-space combine pass: lit = blurred diffuse x albedo^(1-f) + specular (seed 001 §3.6)."""
from __future__ import annotations

from skinviewer.kernel.pass_api import Pass, Reflection
from skinviewer.passes.common import LIT, declare_lit
from skinviewer.passes.screen_space.lighting import ALBEDO, DIFFUSE, SPECULAR


class CombinePass(Pass):
    """``source``: the resource holding the blurred diffuse (rgb); DIFFUSE = no scattering."""
    name = "ss_combine"
    uses_scene = False
    tileable = True  # in row bands under the viewer's frame budget (issue 27)

    def __init__(self, source: str = DIFFUSE):
        self.source = source

    def reflect(self, r: Reflection) -> None:
        for res in (self.source, SPECULAR, ALBEDO):
            r.input(res)
        declare_lit(r, "ss_combine")

    def execute(self, ec) -> None:
        prog = ec.program("ss_combine")
        ec.textures(prog, diffuse=self.source, specular=SPECULAR, albedo=ALBEDO)
        with ec.band():
            ec.draw_fullscreen(prog, LIT)
