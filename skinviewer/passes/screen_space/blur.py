"""A separable screen-space blur: a horizontal pass into a scratch texture, a vertical pass into
the output (spec §4.2 "run twice"). Subclasses declare their settings and set their uniforms."""
from __future__ import annotations

import moderngl

from skinviewer.core.graph import Pass, Reflection, TexSpec
from skinviewer.passes.common import draw_fullscreen, set_uniform
from skinviewer.passes.screen_space.lighting import DEPTH, screen_size


def blur_spec(r) -> TexSpec:
    return TexSpec(screen_size(r), 4, "f4")


class SeparableScreenBlur(Pass):
    """``source`` -> ``output``: rgb blurred, alpha (the SSS mask) kept. Reads ss_depth too."""
    uses_scene = False
    program_name = ""

    def __init__(self, name: str, source: str, output: str):
        self.name = name
        self.source = source
        self.output = output

    def declare(self, r: Reflection) -> bool:
        """Declare the pass's settings; False: the pass is not part of this frame's graph."""
        return True

    def set_uniforms(self, ec, prog) -> None:
        raise NotImplementedError

    def reflect(self, r: Reflection) -> None:
        if not self.declare(r):
            return
        r.input(self.source)
        r.input(DEPTH)
        r.program(self.program_name)
        r.output(self.output, blur_spec(r))

    def execute(self, ec) -> None:
        prog = ec.program(self.program_name)
        self.set_uniforms(ec, prog)
        ec.input(DEPTH).use(1)
        set_uniform(prog, "depth_tex", 1)
        set_uniform(prog, "source", 0)
        ec.gl.disable(moderngl.DEPTH_TEST)
        tmp = ec.scratch(blur_spec(ec))
        ec.input(self.source).use(0)
        set_uniform(prog, "u_dir", (1.0, 0.0))
        ec.scratch_framebuffer(tmp).use()
        draw_fullscreen(ec, prog)
        tmp.use(0)
        set_uniform(prog, "u_dir", (0.0, 1.0))
        ec.framebuffer(self.output).use()
        draw_fullscreen(ec, prog)
