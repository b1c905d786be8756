"""Putting textures on the screen: the rendered image, any pass output (channel / exposure / float
aware) and the A/B split or difference view. A small full-screen program from the shader library
(shaders/display.frag, one variant per mode: hot reload and defines like every pass's program);
letterboxed when the texture's aspect differs from the viewport's."""
from __future__ import annotations

import moderngl

from skinviewer.kernel.gpu import write_uniform
from skinviewer.kernel.shaders import ShaderLibrary

CHANNELS = ("RGB", "R", "G", "B", "A")
MODES = {"show": 0, "inspect": 1, "split": 2, "difference": 3}  # shaders/display.frag's DISPLAY_MODE


class Display:
    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary):
        self.ctx = ctx
        self.shaders = shaders
        self._vaos: dict[int, tuple[moderngl.Program, moderngl.VertexArray]] = {}  # mode -> (program, vao)

    def _program(self, mode: int) -> moderngl.Program:
        """This mode's program (the library's last good one: a hot reload swaps it, the vao follows)."""
        prog = self.shaders.get("display", {"DISPLAY_MODE": mode})
        have = self._vaos.get(mode)
        if have is None or have[0] is not prog:
            if have is not None:
                have[1].release()
            self._vaos[mode] = (prog, self.ctx.vertex_array(prog, []))
        self.prog = prog
        return prog

    def _set(self, name, value):
        if name in self.prog:
            write_uniform(self.prog[name], value)

    def _draw(self, tex: moderngl.Texture, viewport: tuple[int, int, int, int], mode: int, letterbox: bool,
              tex_b: moderngl.Texture | None = None, **uniforms) -> None:
        ctx = self.ctx
        self._program(mode)
        ctx.screen.use()
        ctx.viewport = viewport
        ctx.enable_only(moderngl.NOTHING)
        sx, sy = 1.0, 1.0
        if letterbox:
            vw, vh = viewport[2], viewport[3]
            ta, va = tex.size[0] / max(tex.size[1], 1), vw / max(vh, 1)
            if ta > va:
                sy = va / ta
            else:
                sx = ta / va
        self._set("u_scale", (sx, sy))
        tex.use(0)
        self._set("u_tex", 0)
        (tex_b or tex).use(1)
        self._set("u_tex_b", 1)
        for k, v in uniforms.items():
            self._set(k, v)
        self._vaos[mode][1].render(moderngl.TRIANGLES, vertices=3)

    def show(self, tex, viewport):
        self._draw(tex, viewport, MODES["show"], letterbox=True)

    def inspect(self, tex, viewport, channel: str = "RGB", exposure: float = 1.0, components: int = 4):
        self._draw(tex, viewport, MODES["inspect"], letterbox=True, u_channel=CHANNELS.index(channel),
                   u_exposure=float(exposure), u_components=int(components))

    def split(self, tex_a, tex_b, viewport, divider: float):
        self._draw(tex_a, viewport, MODES["split"], letterbox=True, tex_b=tex_b, u_divider=float(divider))

    def difference(self, tex_a, tex_b, viewport, gain: float):
        self._draw(tex_a, viewport, MODES["difference"], letterbox=True, tex_b=tex_b, u_gain=float(gain))

    def release(self):
        for _prog, vao in self._vaos.values():  # the programs are the library's
            vao.release()
        self._vaos = {}
