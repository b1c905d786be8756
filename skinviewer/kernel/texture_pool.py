"""Free textures by spec, shared by every graph of a renderer."""
from __future__ import annotations

import moderngl

from skinviewer.kernel.pass_api import TexSpec


class TexturePool:
    """Free textures by spec; a released texture is handed to the next request of the same spec."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self._free: dict[tuple[object, ...], list[moderngl.Texture]] = {}
        self.allocated = 0
        self.allocated_bytes = 0
        self.reused = 0

    @staticmethod
    def _k(spec: TexSpec) -> tuple[object, ...]:
        return (spec.size, spec.components, spec.dtype, spec.filter)

    def take(self, spec: TexSpec) -> moderngl.Texture:
        free = self._free.get(self._k(spec))
        if free:
            self.reused += 1
            return free.pop()
        tex = self.ctx.texture(spec.size, spec.components, dtype=spec.dtype)
        f = moderngl.NEAREST if spec.filter == "nearest" else moderngl.LINEAR
        tex.filter = (f, f)
        tex.repeat_x = tex.repeat_y = False
        tex.extra = spec
        self.allocated += 1
        self.allocated_bytes += spec.nbytes
        return tex

    def give(self, tex: moderngl.Texture) -> None:
        self._free.setdefault(self._k(tex.extra), []).append(tex)

    def release(self) -> None:
        for lst in self._free.values():
            for t in lst:
                t.release()
        self._free.clear()

