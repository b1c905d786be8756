"""A separable screen-space blur: a horizontal pass into a scratch texture, a vertical pass into
the output (spec §4.2 "run twice"). Subclasses declare their settings and program (``declare``)
and set their uniforms (``set_uniforms``); the program reads ``source``, ``depth_tex`` and
``u_dir``."""
from __future__ import annotations

from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec
from skinviewer.passes.screen_space.lighting import DEPTH, screen_size


def blur_spec(r) -> TexSpec:
    return TexSpec(screen_size(r), 4, "f4")


class SeparableScreenBlur(Pass):
    """``source`` -> ``output``: rgb blurred, alpha (the SSS mask) kept. Reads ss_depth too."""
    uses_scene = False
    tileable = True

    def __init__(self, name: str, source: str, output: str):
        self.name = name
        self.source = source
        self.output = output

    def declare(self, r: Reflection) -> bool:
        """Declare the pass's settings and its program; False: not part of this frame's graph."""
        raise NotImplementedError

    def program(self, ec):
        raise NotImplementedError

    def set_uniforms(self, ec, prog) -> None:
        raise NotImplementedError

    def reflect(self, r: Reflection) -> None:
        if not self.declare(r):
            return
        r.input(self.source)
        r.input(DEPTH)
        spec = blur_spec(r)
        r.plan(spec=spec)  # the output's and the held horizontal result's
        r.output(self.output, spec)

    def execute(self, ec) -> None:
        prog = self.program(ec)
        self.set_uniforms(ec, prog)
        # the horizontal result is kept across the pass's bands (issue 27): under the viewer's frame
        # budget each draw runs in row bands, the horizontal one complete before the vertical starts
        tmp = ec.held("tmp", ec.plan.spec)[0]
        ec.bind(prog, "depth_tex", DEPTH)
        for d, sub, subs in ec.units(2):
            ec.bind(prog, "source", self.source if d == 0 else tmp)
            ec.set(prog, "u_dir", (1.0, 0.0) if d == 0 else (0.0, 1.0))
            with ec.band(sub, subs):
                ec.draw_fullscreen(prog, tmp if d == 0 else self.output)
