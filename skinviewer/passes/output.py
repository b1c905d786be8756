"""Display transform: exposure, background, sRGB encoding of a technique's linear ``lit`` image."""
from __future__ import annotations

import numpy as np

from skinviewer.core.graph import Pass, Reflection, TexSpec


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
        ec.bind(prog, "lit", self.source)
        ec.uniforms(prog, u_exposure=ec.setting("render.exposure"),
                    u_background=tuple(srgb_to_linear(ec.setting("render.background"))))
        ec.draw_fullscreen(prog, "image")
