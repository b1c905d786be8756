"""moderngl-window's imgui-bundle renderer (pre-1.92 font atlas API), with buffers that grow when
a draw list outgrows them, a real frame delta, and a nicer font scaled for HiDPI.

Input goes through imgui's event queue (``add_mouse_*_event`` / ``add_key_event``) instead of the
base class's direct ``io.mouse_down[...] = ...`` writes: a real click (press and release arriving
between two frames, which is every click when a frame takes longer than a click, as on llvmpipe)
was lost, wheel notches in one frame overwrote each other, and text fields got neither modifiers
(Ctrl+A/C/V/X/Z) nor letter keys."""
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

    def _init_key_maps(self):
        super()._init_key_maps()
        keys = self.wnd.keys
        extra = {"KEYPAD_ENTER": imgui.Key.keypad_enter, "INSERT": imgui.Key.insert}
        for c in "ABCDEFGHIJKLMNOPQRSTUVWXYZ":
            extra[c] = getattr(imgui.Key, c.lower())
        for name, k in extra.items():
            code = getattr(keys, name, None)
            if code is not None:
                self.REVERSE_KEYMAP.setdefault(code, k)
        # the modifier keys themselves: X11 reports the modifier state from *before* the event, so a
        # Ctrl release still says "ctrl" and imgui would keep seeing Ctrl held (Ctrl+click on a slider
        # then turns it into a text field) until the next key event
        self._mod_keys = {}
        names = {"LEFT_CTRL": "ctrl", "RIGHT_CTRL": "ctrl", "LEFT_SHIFT": "shift", "RIGHT_SHIFT": "shift",
                 "LEFT_ALT": "alt", "RIGHT_ALT": "alt"}
        for name, mod in names.items():
            code = getattr(keys, name, None)
            if code is not None:
                self._mod_keys[code] = mod
        if type(self.wnd).__module__.startswith("moderngl_window.context.glfw"):
            import glfw
            for code, mod in ((glfw.KEY_LEFT_CONTROL, "ctrl"), (glfw.KEY_RIGHT_CONTROL, "ctrl"),
                              (glfw.KEY_LEFT_SHIFT, "shift"), (glfw.KEY_RIGHT_SHIFT, "shift"),
                              (glfw.KEY_LEFT_ALT, "alt"), (glfw.KEY_RIGHT_ALT, "alt")):
                self._mod_keys.setdefault(code, mod)

    # -- input through imgui's event queue ----------------------------------------------------
    def _imgui_button(self, button) -> int | None:
        m = self.wnd.mouse
        return {m.left: 0, m.right: 1, m.middle: 2}.get(button)

    def mouse_position_event(self, x, y, dx, dy):
        self.io.add_mouse_pos_event(*(float(v) for v in self._mouse_pos_viewport(x, y)))

    def mouse_drag_event(self, x, y, dx, dy):
        self.mouse_position_event(x, y, dx, dy)

    def mouse_press_event(self, x, y, button):
        self.mouse_position_event(x, y, 0, 0)
        b = self._imgui_button(button)
        if b is not None:
            self.io.add_mouse_button_event(b, True)

    def mouse_release_event(self, x, y, button):
        self.mouse_position_event(x, y, 0, 0)
        b = self._imgui_button(button)
        if b is not None:
            self.io.add_mouse_button_event(b, False)

    def mouse_scroll_event(self, x_offset, y_offset):
        self.io.add_mouse_wheel_event(float(x_offset), float(y_offset))

    def key_event(self, key, action, modifiers):
        keys = self.wnd.keys
        io = self.io
        held = {m: bool(getattr(modifiers, m, False)) for m in ("ctrl", "shift", "alt")}
        mod = getattr(self, "_mod_keys", {}).get(key)
        if mod is not None and action in (keys.ACTION_PRESS, keys.ACTION_RELEASE):
            held[mod] = action == keys.ACTION_PRESS
        for k, m in ((imgui.Key.mod_ctrl, "ctrl"), (imgui.Key.mod_shift, "shift"), (imgui.Key.mod_alt, "alt")):
            io.add_key_event(k, held[m])
        k = self.REVERSE_KEYMAP.get(key)
        if k is None:
            return
        if action == keys.ACTION_PRESS:
            io.add_key_event(k, True)
        elif action == keys.ACTION_RELEASE:
            io.add_key_event(k, False)
        # key repeat: imgui repeats held keys itself (the base class turned a repeat into a release)

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
