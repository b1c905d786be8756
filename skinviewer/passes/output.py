"""Display transform: exposure, tone map, background, sRGB encoding of a technique's linear ``lit`` image."""
from __future__ import annotations

import numpy as np

from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, declare
from skinviewer.physics.color import srgb_to_linear

TONE_MAPS = {"linear": 0, "filmic": 1}


def tone_map(x, mode: str = "filmic"):
    """The display curve of shaders/output.frag (after exposure, before sRGB): ``linear`` clamps,
    ``filmic`` is Narkowicz's fit of the ACES reference tone curve, x(2.51x + 0.03) /
    (x(2.43x + 0.59) + 0.14), which rolls highlights off instead of clipping them."""
    x = np.maximum(np.asarray(x, dtype=np.float64), 0.0)
    if mode == "linear":
        return np.clip(x, 0.0, 1.0)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


BACKGROUND_MODES = {"off": 0, "sharp": 1, "blurred": 2}


def _background_env(r) -> tuple[int | None, int]:
    """(the environment light's index, BG_ENV: 0 off, 1 sharp, 2 blurred) of render.background_environment."""
    from skinviewer.passes.environment import env_index
    i = env_index(r)
    mode = BACKGROUND_MODES[r.peeked.render.background_environment]
    return (i, mode) if i is not None and mode else (None, 0)


class OutputPass(Pass):
    name = "output"
    uses_scene = False
    view_dependent = True  # the environment in the background follows the camera (downstream of the view anyway)

    def __init__(self, source: str = "lit"):
        self.source = source

    def reflect(self, r: Reflection) -> None:
        from skinviewer.passes.environment import BACKGROUND_BLUR_LEVEL, ENV_BACKGROUND, ENV_PREFILTERED
        r.input(self.source)
        rs = r.settings.render
        declare(rs.exposure, rs.background, rs.background_environment)
        w, h = rs.width, rs.height
        i, bg = _background_env(r)
        r.plan(env=i, background=ENV_BACKGROUND if bg == 1 else ENV_PREFILTERED if bg else None)
        if bg and i is not None:
            e = r.settings.lights[i]
            declare(e.environment, e.layout, e.yaw, e.color, e.intensity)
            r.input(r.planned.background)
        r.program("output", TONE_MAP=TONE_MAPS[rs.tone_map], BG_ENV=bg,
                  BG_LEVEL=BACKGROUND_BLUR_LEVEL)
        r.output("image", TexSpec((w, h), 4, "f1"))

    def execute(self, ec) -> None:
        import math

        from skinviewer.scene.camera import gl_bytes
        i, background = ec.plan.env, ec.plan.background  # the environment light and its background texture
        prog = ec.program("output")  # the variant reflect declared (tone map, BG_ENV)
        ec.bind(prog, "lit", self.source)
        ec.uniforms(prog, u_exposure=ec.settings.render.exposure,
                    u_background=tuple(srgb_to_linear(ec.settings.render.background)))
        if background:  # the environment seen through each pixel: R_y(-yaw) of the view ray (physics rotate_yaw)
            e = ec.settings.lights[i]
            view = ec.view
            yaw = math.radians(float(e.yaw))
            ec.bind(prog, "env_background", background)
            ec.uniforms(prog, u_inv_view_proj=gl_bytes(np.linalg.inv(view.view_proj)),
                        u_eye=tuple(float(x) for x in view.eye), u_env_yaw=(math.cos(yaw), math.sin(yaw)),
                        u_env_scale=tuple(float(x) for x in np.asarray(e.color, np.float64) * float(e.intensity)))
        ec.draw_fullscreen(prog, "image")
