"""Putting a frame on the 3D view: the rendered image, the inspected pass output, or the A/B
compare (split, toggle, difference) -- each compare slot rendered by its own Renderer, made on first
use and sharing the GL context and the shader library (ui/compare.py says what that costs)."""
from __future__ import annotations

from skinviewer.engine.renderer import Renderer
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.ui.display import Display
from skinviewer.ui.layout import Layout
from skinviewer.ui.state import ViewerState


class ViewPresenter:
    def __init__(self, ctx, state: ViewerState, shaders: ShaderLibrary):
        self.ctx = ctx
        self.state = state
        self.shaders = shaders
        self.display = Display(ctx, shaders)
        self._slot_renderers: dict[str, Renderer] = {}
        # a copy of the last complete image: what the view shows while the next frame is spread
        # over several (row bands) -- its own textures may be reallocated (a new size) or half made
        self._kept = None
        self._kept_from: tuple[int, int] | None = None  # (graph, texture) it was copied from

    def renderers(self) -> list[Renderer]:
        """The compare slots' renderers made so far."""
        return list(self._slot_renderers.values())

    def _render_slot(self, slot):
        r = self._slot_renderers.get(slot.label)
        if r is None:
            r = self._slot_renderers[slot.label] = Renderer(self.ctx, self.shaders)
        try:
            s = self.state.compare.frame_settings(slot, self.state.settings)
            r.render(s)
            slot.set_error("")
            return r.graph(s.technique).texture("image")
        except Exception as exc:
            slot.set_error(f"{type(exc).__name__}: {exc}")
            return None

    def keep(self, graph, changed: bool) -> None:
        """The frame of ``graph`` is complete: copy its image for the view (``changed``: passes ran;
        an idle frame of the same graph copies nothing)."""
        if "image" not in graph.resources():
            return
        tex = graph.texture("image")
        src = (id(graph), tex.glo)
        if not changed and src == self._kept_from and self._kept is not None:
            return
        k = self._kept
        if k is None or (k.size, k.components, k.dtype) != (tex.size, tex.components, tex.dtype):
            if k is not None:
                k.release()
            k = self._kept = self.ctx.texture(tex.size, tex.components, dtype=tex.dtype)
        fbo = self.ctx.framebuffer(color_attachments=[tex])
        try:
            self.ctx.copy_framebuffer(k, fbo)
        finally:
            fbo.release()
        self._kept_from = src

    def draw(self, graph, layout: Layout, hooks=()) -> None:
        """Clear the window, then show in the view region: A/B when comparing, else the inspected
        output of ``graph`` (the current technique's), else the first of ``hooks`` (windows' own
        view modes, ``draw_view(viewport) -> bool``) that draws it, else the image."""
        ctx, viewport = self.ctx, layout.view_fb
        ctx.screen.use()
        ctx.viewport = (0, 0, *layout.framebuffer)
        ctx.clear(*self.state.settings.render.background, 1.0)
        ctx.viewport = viewport
        cmp = self.state.compare
        if cmp.active:
            if cmp.mode == "toggle":
                tex = self._render_slot(cmp.b if cmp.show_b else cmp.a)
                if tex is not None:
                    self.display.show(tex, viewport)
                return
            ta, tb = self._render_slot(cmp.a), self._render_slot(cmp.b)
            if ta is not None and tb is not None:
                if cmp.mode == "split":
                    self.display.split(ta, tb, viewport, cmp.divider)
                else:
                    self.display.difference(ta, tb, viewport, cmp.diff_gain)
            return
        if graph is None:
            return
        ins = self.state.inspect
        if ins.resource is not None:
            spec = graph.resources().get(ins.resource)
            if spec is not None:
                self.display.inspect(graph.texture(ins.resource), viewport, ins.channel, ins.exposure, spec.components)
                return
        for hook in hooks:
            if hook(viewport):
                return
        if self._kept is not None:
            self.display.show(self._kept, viewport)
        elif "image" in graph.resources():
            self.display.show(graph.texture("image"), viewport)

    def release(self) -> None:
        if self._kept is not None:
            self._kept.release()
            self._kept = None
        for r in self._slot_renderers.values():
            r.release()
        self._slot_renderers = {}
        self.display.release()
