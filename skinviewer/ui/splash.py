"""The start-up screen: from the moment the window exists until the viewer's first frame, the window shows
what is happening and for how long (generating the default head on a first start, loading the scene,
compiling the shaders and rendering the first frame) instead of staying black.

No imgui (its context belongs to the viewer's UI host, made later): the lines are drawn with Pillow into
one texture, shown by a full-window triangle. Long steps run in a worker thread while the screen is
redrawn every ``interval`` seconds with the elapsed time (GL stays on the main thread)."""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

_VS = """#version 330
out vec2 uv;
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);  // one triangle covering the window
    uv = vec2(p.x, 1.0 - p.y);  // image row 0 (uploaded first, t = 0) at the top
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""
_FS = """#version 330
in vec2 uv;
out vec4 color;
uniform sampler2D tex;
void main() { color = texture(tex, uv); }
"""
BG = (20, 20, 24)
FG = (225, 225, 230)
DIM = (150, 150, 160)
TEXT_W = 960  # the text block's width (pixels)


def _font(size: int):
    from PIL import ImageFont
    try:
        return ImageFont.load_default(size=size)  # Pillow >= 10.1: a scalable built-in font
    except TypeError:
        return ImageFont.load_default()


# Pillow's built-in font has no glyph for these (the preview ladder's labels use them): a box was drawn
_PLAIN = str.maketrans({"¼": "1/4", "½": "1/2", "²": "^2", "±": "+-", "·": "-"})


def plain(text: str) -> str:
    return text.translate(_PLAIN)


def _wrap(d, text: str, font, width: float) -> list[str]:
    """``text`` in lines at most ``width`` pixels wide, broken after ", " or at a space."""
    out: list[str] = []
    while text and d.textlength(text, font=font) > width:
        k = len(text)
        while k > 1 and d.textlength(text[:k], font=font) > width:
            k -= 1
        cut = text.rfind(", ", 0, k)
        cut = cut + 1 if cut > 0 else text.rfind(" ", 0, k)
        if cut <= 0:
            cut = k
        out.append(text[:cut].rstrip())
        text = text[cut:].lstrip()
    return out + ([text] if text else [])


class Splash:
    """``show(line)`` adds a progress line and redraws; ``run(line, fn)`` runs ``fn`` in a thread while
    the line's elapsed time ticks; ``release()`` frees the GL objects. ``lines``: (seconds, text)."""

    def __init__(self, wnd, interval: float = 0.25):
        self.wnd = wnd
        self.ctx = wnd.ctx
        self.t0 = time.perf_counter()
        self.interval = float(interval)
        self.lines: list[tuple[float, str]] = []
        self.frames = 0  # screens presented (tests)
        self._prog = self.ctx.program(vertex_shader=_VS, fragment_shader=_FS)
        self._vao = self.ctx.vertex_array(self._prog, [])
        self._tex: Any = None
        self._drawn_at = 0.0
        self.headline = "starting: the panel comes first, then the image"

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def _image(self, busy: str = "", size: tuple[int, int] | None = None) -> np.ndarray:
        """The text block (at most ``size``: the rest of the screen is cleared to BG, not drawn): a
        whole 1280x800 image cost ~80 ms a redraw here, GIL time taken from the start's worker."""
        from PIL import Image, ImageDraw
        w, h = size or self.wnd.buffer_size
        w = max(min(int(w), TEXT_W), 16)
        big, small = _font(28), _font(16)
        x = 40
        measure = ImageDraw.Draw(Image.new("RGB", (1, 1)))
        rows: list[tuple[str, tuple[int, int, int]]] = []  # the lines, wrapped to the block's width
        for k, (t, text) in enumerate(self.lines):
            last = k == len(self.lines) - 1
            tail = f"  ({self.elapsed() - t:.1f} s){busy}" if last else ""
            for i, part in enumerate(_wrap(measure, plain(f"{text}{tail}"), small, w - x - 16 - 64)):
                rows.append(((f"{t:5.1f} s   " if i == 0 else " " * 12) + part, FG if last else DIM))
        h = max(min(int(h), 124 + 24 * len(rows) + 16), 16)
        img = Image.new("RGB", (w, h), BG)
        d = ImageDraw.Draw(img)
        y = 40
        d.text((x, y), "skinviewer", fill=FG, font=big)
        y += 50
        d.text((x, y), plain(self.headline), fill=DIM, font=small)
        y += 34
        for line, colour in rows:
            d.text((x, y), line, fill=colour, font=small)
            y += 24
        return np.asarray(img, np.uint8)

    def draw(self, busy: str = "") -> None:
        w, h = self.wnd.buffer_size
        self.draw_into((0, 0, int(w), int(h)), busy, force=True)
        self.wnd.swap_buffers()
        self.frames += 1

    def draw_into(self, viewport: tuple[int, int, int, int], busy: str = "", force: bool = False) -> None:
        """The screen's image in ``viewport`` (x, y, w, h framebuffer pixels) of the window, not
        presented: the viewer's view region while its first image is being made (the panel beside it)."""
        x0, y0, vw, vh = (int(v) for v in viewport)
        now = time.perf_counter()
        # the text is drawn again at most every ``interval`` (the viewer's frames come faster than that)
        if force or self._tex is None or now - self._drawn_at >= self.interval:
            img = np.ascontiguousarray(self._image(busy, (vw, vh)))
            h, w = img.shape[:2]
            if self._tex is None or self._tex.size != (w, h):
                if self._tex is not None:
                    self._tex.release()
                self._tex = self.ctx.texture((w, h), 3, img.tobytes(), alignment=1)
            else:
                self._tex.write(img.tobytes(), alignment=1)
            self._drawn_at = now
        w, h = self._tex.size
        self.ctx.screen.use()
        self.ctx.clear(*(c / 255.0 for c in BG), 1.0, viewport=(x0, y0, vw, vh))
        self.ctx.viewport = (x0, y0 + max(vh - h, 0), w, h)  # the text block at the top left
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND)
        self._tex.use(0)
        self._prog["tex"].value = 0
        self._vao.render(vertices=3)

    def hand_over(self, line: str, headline: str) -> None:
        """The viewer takes the screen: a last line, and the headline for the view until its first image."""
        self.headline = headline
        self.lines.append((self.elapsed(), line))

    def show(self, line: str) -> None:
        self.lines.append((self.elapsed(), line))
        try:
            self.draw()
        except Exception:  # a start-up screen must never stop the start
            pass

    def run(self, line: str, fn: Callable[[], Any]) -> Any:
        """``fn()`` in a worker thread, the screen redrawn meanwhile; its result (or its exception)."""
        self.show(line)
        out: dict = {}

        def work():
            try:
                out["value"] = fn()
            except BaseException as exc:  # re-raised on the main thread
                out["error"] = exc

        th = threading.Thread(target=work, daemon=True)
        th.start()
        dots = 0
        while th.is_alive():
            th.join(self.interval)
            dots = (dots + 1) % 4
            try:
                self.draw(" " + "." * dots)  # swap_buffers also polls the window's events
            except Exception:
                pass
        if "error" in out:
            raise out["error"]
        return out.get("value")

    def released(self) -> bool:
        return self._prog is None

    def release(self) -> None:
        for obj in (self._tex, self._vao, self._prog):
            try:
                if obj is not None:
                    obj.release()
            except Exception:
                pass
        self._tex = self._vao = self._prog = None


class StartupView:
    """The start-up screen in the 3D view until the viewer's first complete image, the panel beside it
    (a window of ui/windows.py that draws no imgui, only its ``draw_view``): the steps and the running
    time of the first image stay readable, and the panel can be used meanwhile. Releases the screen
    once an image is complete or the first render failed (the status bar says why)."""

    def __init__(self, splash: Splash, frame):
        self.splash: Splash | None = splash
        self.frame = frame
        self._phase = ""

    def draw(self, ui) -> None:
        pass

    def phase(self) -> tuple[str, str]:
        """What the start is doing now (a progress line) and how far (its tail): the first frame's
        CPU work in a worker (ui/warm.py) before anything renders, then the first image -- the
        governor's preview where there is one -- with its passes done so far (a pass's first run
        compiles its shaders)."""
        f = self.frame
        if getattr(getattr(f, "state", None), "scene", True) is None:  # the panel came before the mesh
            return "the scene: the default head read from the cache (generated on a first start), then uploaded", ""
        if f.frames == 0:
            return "preparing the first frame: the mesh's tables (border edges, rays to the lights, rho_dt)", ""
        rung = getattr(f, "_rung", None)
        what = (f"the first preview ({rung.label}): compiling shaders, rendering"
                if getattr(f, "_governing", False) and rung is not None and not rung.final
                else "the first image at your settings: compiling shaders, rendering")
        rep = f.report
        if rep is None:
            return what, ""
        done = len(rep.ran) + len(rep.cached)
        return what, f", {done}/{done + len(rep.deferred)} passes"

    def draw_view(self, viewport) -> bool:
        sp = self.splash
        if sp is None:
            return False
        rep = self.frame.report
        # a complete image exists (the view keeps the last one: the first preview while the user's
        # settings are made, issue 34), or the first render failed
        kept = getattr(getattr(self.frame, "view", None), "_kept", None) is not None
        if (rep is not None and rep.complete) or kept or self.frame.render_error:
            self.release()
            return False
        try:
            line, tail = self.phase()
            force = line != self._phase
            if force:
                self._phase = line
                sp.lines.append((sp.elapsed(), line))
            sp.draw_into(viewport, tail, force=force)
        except Exception:  # never in the way of the viewer
            self.release()
            return False
        return True

    def release(self) -> None:
        if self.splash is not None:
            self.splash.release()
            self.splash = None
