"""Display transform: exposure, background, sRGB encoding of a technique's linear ``lit`` image."""
from __future__ import annotations

import numpy as np

from skinviewer.core.graph import Pass, Reflection, TexSpec
from skinviewer.passes.common import draw_fullscreen, set_uniform


def srgb_to_linear(c):
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


class OutputPass(Pass):
    name = "output"
    uses_scene = False

    def __init__(self, source: str = "lit"):
        self.source = source

    def reflect(self, r: Reflection) -> None:
        r.input(self.source)
        r.setting("render.exposure")
        r.setting("render.background")
        w, h = r.setting("render.width"), r.setting("render.height")
        r.program("output")
        r.output("image", TexSpec((w, h), 4, "f1"))

    def execute(self, ec) -> None:
        prog = ec.program("output")
        ec.input(self.source).use(0)
        set_uniform(prog, "lit", 0)
        set_uniform(prog, "u_exposure", ec.setting("render.exposure"))
        set_uniform(prog, "u_background", tuple(srgb_to_linear(ec.setting("render.background"))))
        fbo = ec.framebuffer("image")
        fbo.use()
        draw_fullscreen(ec, prog)
