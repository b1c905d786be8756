"""Display transform: exposure, tone map, background, sRGB encoding of a technique's linear ``lit`` image."""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from skinviewer.core.graph import Pass, Reflection, TexSpec

TONE_MAPS = {"linear": 0, "filmic": 1}


def tone_map(x, mode: str = "filmic"):
    """The display curve of shaders/output.frag (after exposure, before sRGB): ``linear`` clamps,
    ``filmic`` is Narkowicz's fit of the ACES reference tone curve, x(2.51x + 0.03) /
    (x(2.43x + 0.59) + 0.14), which rolls highlights off instead of clipping them."""
    x = np.maximum(np.asarray(x, dtype=np.float64), 0.0)
    if mode == "linear":
        return np.clip(x, 0.0, 1.0)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def srgb_to_linear(c: ArrayLike) -> NDArray[np.float64]:
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
        r.program("output", TONE_MAP=TONE_MAPS[r.setting("render.tone_map")])
        r.output("image", TexSpec((w, h), 4, "f1"))

    def execute(self, ec) -> None:
        prog = ec.program("output", TONE_MAP=TONE_MAPS[ec.setting("render.tone_map")])
        ec.bind(prog, "lit", self.source)
        ec.uniforms(prog, u_exposure=ec.setting("render.exposure"),
                    u_background=tuple(srgb_to_linear(ec.setting("render.background"))))
        ec.draw_fullscreen(prog, "image")
