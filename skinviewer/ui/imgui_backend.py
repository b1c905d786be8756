"""moderngl-window's imgui-bundle renderer (pre-1.92 font atlas API), with buffers that grow when
a draw list outgrows them, a real frame delta, and a nicer font scaled for HiDPI."""
from __future__ import annotations

import ctypes
from pathlib import Path

import moderngl
from imgui_bundle import imgui
from moderngl_window.integrations.imgui_bundle import ModernglWindowRenderer


def _font_path() -> Path | None:
    try:
        import imgui_bundle
        p = Path(imgui_bundle.__file__).parent / "assets" / "fonts" / "DroidSans.ttf"
        return p if p.is_file() else None
    except Exception:
        return None


class ImguiRenderer(ModernglWindowRenderer):
    def __init__(self, window, font_px: float = 15.0):
        self._font_px = font_px
        super().__init__(window)

    def refresh_font_texture(self):
        # load the font once, before the atlas is built (pixel ratio > 1: rasterise bigger, draw scaled)
        if not getattr(self, "_font_loaded", False):
            self._font_loaded = True
            path = _font_path()
            ratio = max(1.0, float(getattr(self.wnd, "pixel_ratio", 1.0) or 1.0)) if getattr(self, "wnd", None) else 1.0
            if path is not None:
                self.io.fonts.clear()
                self.io.fonts.add_font_from_file_ttf(str(path), self._font_px * ratio)
                self.io.font_global_scale = 1.0 / ratio
        super().refresh_font_texture()

    def _fit(self, buf: moderngl.Buffer, nbytes: int) -> None:
        if nbytes > buf.size:
            buf.orphan(max(nbytes, buf.size * 2))

    def render(self, draw_data):
        # same as the base class, but the buffers grow instead of overflowing
        io = self.io
        dw, dh = io.display_size
        fb_w = int(dw * io.display_framebuffer_scale[0])
        fb_h = int(dh * io.display_framebuffer_scale[1])
        if fb_w == 0 or fb_h == 0:
            return
        self.projMat.value = (2.0 / dw, 0.0, 0.0, 0.0, 0.0, 2.0 / -dh, 0.0, 0.0,
                              0.0, 0.0, -1.0, 0.0, -1.0, 1.0, 0.0, 1.0)
        draw_data.scale_clip_rects(imgui.ImVec2(*io.display_framebuffer_scale))
        self.ctx.viewport = (0, 0, fb_w, fb_h)
        self.ctx.enable_only(moderngl.BLEND)
        self.ctx.blend_equation = moderngl.FUNC_ADD
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        for commands in draw_data.cmd_lists:
            vbytes = commands.vtx_buffer.size() * imgui.VERTEX_SIZE
            ibytes = commands.idx_buffer.size() * imgui.INDEX_SIZE
            self._fit(self._vertex_buffer, vbytes)
            self._fit(self._index_buffer, ibytes)
            vtx = (ctypes.c_byte * vbytes).from_address(commands.vtx_buffer.data_address())
            idx = (ctypes.c_byte * ibytes).from_address(commands.idx_buffer.data_address())
            self._vertex_buffer.write(vtx)
            self._index_buffer.write(idx)
            pos = 0
            for command in commands.cmd_buffer:
                tex = self._textures.get(command.texture_id)
                if tex is not None:
                    tex.use(0)
                x, y, z, w = command.clip_rect
                self.ctx.scissor = int(x), int(fb_h - w), int(z - x), int(w - y)
                self._vao.render(moderngl.TRIANGLES, vertices=command.elem_count, first=pos)
                pos += command.elem_count
        self.ctx.scissor = None
        self.ctx.disable(moderngl.BLEND)
