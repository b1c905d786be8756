"""End to end: the real viewer as a subprocess on a private Xvfb display, driven by real X input
events (xdotool), as a person would: a left-drag in the 3D view, a click on a panel header, the
technique keys, F1 / F12, Escape, and closing the window. Unlike tests/test_viewer.py (which calls
the app's handlers in-process) this goes through glfw, moderngl-window's event plumbing and imgui's
real input, where a click (press and release between two frames) used to be lost and Escape used to
quit the session.

Needs the Debian packages xvfb, xdotool and x11-apps (xwd); skipped without them."""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.viewer

WIN_W, WIN_H = 900, 600
TOOLS = {"Xvfb": "xvfb", "xdotool": "xdotool", "xwd": "x11-apps"}


def _wait(pred, timeout: float, what: str, proc: subprocess.Popen | None = None, log: Path | None = None):
    """Poll ``pred`` until it returns something truthy; fail (with the app's log) after ``timeout``."""
    deadline = time.monotonic() + timeout
    while True:
        got = pred()
        if got:
            return got
        if proc is not None and proc.poll() is not None:
            pytest.fail(f"the viewer exited ({proc.returncode}) while waiting for {what}\n{_tail(log)}")
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout:.0f} s waiting for {what}\n{_tail(log)}")
        time.sleep(0.1)


def _tail(log: Path | None) -> str:
    if log is None or not log.exists():
        return ""
    return "viewer output:\n" + "\n".join(log.read_text(errors="replace").splitlines()[-30:])


@pytest.fixture
def xdisplay():
    missing = [f"{exe} (apt package {pkg})" for exe, pkg in TOOLS.items() if shutil.which(exe) is None]
    if missing:
        pytest.skip("end-to-end viewer test needs " + ", ".join(missing))
    r, w = os.pipe()
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", "1024x700x24", "-nolisten", "tcp"],
                            pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    num = b""
    with os.fdopen(r, "rb") as f:  # Xvfb writes its display number when it is ready
        while (ch := f.read(1)) and ch != b"\n":
            num += ch
    if not num.strip():
        xvfb.kill()
        pytest.skip("Xvfb did not start")
    try:
        yield f":{num.decode().strip()}"
    finally:
        xvfb.terminate()
        try:
            xvfb.wait(5)
        except subprocess.TimeoutExpired:
            xvfb.kill()


class Session:
    """The running viewer and the X display it is on."""

    def __init__(self, display: str, proc: subprocess.Popen, cwd: Path, log: Path):
        self.env = dict(os.environ, DISPLAY=display)
        self.display, self.proc, self.cwd, self.log = display, proc, cwd, log
        self.win = ""

    def xdo(self, *args: str) -> str:
        r = subprocess.run(["xdotool", *args], env=self.env, capture_output=True, text=True, timeout=10)
        return r.stdout.strip() if r.returncode == 0 else ""

    def wait(self, pred, timeout: float, what: str):
        return _wait(pred, timeout, what, self.proc, self.log)

    def title(self) -> str:
        return self.xdo("getwindowname", self.win)

    def grab(self) -> np.ndarray:
        """The whole X screen as uint8 (H, W, 3), through xwd."""
        raw = subprocess.run(["xwd", "-root", "-silent", "-display", self.display], capture_output=True,
                             timeout=10, check=True).stdout
        return _parse_xwd(raw)

    def shots(self) -> set[Path]:
        d = self.cwd / "screenshots"
        return {p for p in d.glob("*.png") if not p.name.startswith(".")} if d.is_dir() else set()

    def f12(self, accept=lambda img: True, timeout: float = 20.0) -> np.ndarray:
        """Press F12 until the app writes a screenshot that ``accept``s (the view may still be settling)."""
        from PIL import Image
        last = {"img": None}

        def attempt():
            before = self.shots()
            self.xdo("key", "F12")
            new = _wait(lambda: self.shots() - before, 10.0, "the F12 screenshot", self.proc, self.log)
            img = np.asarray(Image.open(sorted(new)[-1]).convert("RGB")).astype(np.float32)
            last["img"] = img
            return accept(img)

        self.wait(attempt, timeout, "an F12 screenshot showing the expected change")
        return last["img"]

    def drag(self, button: int, x0: int, y0: int, x1: int, y1: int, steps: int = 8) -> None:
        self.xdo("mousemove", "--window", self.win, str(x0), str(y0))
        self.xdo("mousedown", str(button))
        for k in range(1, steps + 1):
            self.xdo("mousemove", "--window", self.win, str(x0 + (x1 - x0) * k // steps), str(y0 + (y1 - y0) * k // steps))
            time.sleep(0.03)
        self.xdo("mouseup", str(button))


def _parse_xwd(raw: bytes) -> np.ndarray:
    """An xwd dump (ZPixmap, TrueColor, 24 or 32 bits per pixel) as uint8 RGB."""
    h = np.frombuffer(raw[:100], dtype=">u4")
    header_size, width, height = int(h[0]), int(h[4]), int(h[5])
    byte_order, bpp, bpl = int(h[7]), int(h[11]), int(h[12])
    masks, ncolors = (int(h[14]), int(h[15]), int(h[16])), int(h[19])
    assert bpp in (24, 32), f"xwd: {bpp} bits per pixel"
    nb = bpp // 8
    off = header_size + 12 * ncolors
    b = np.frombuffer(raw[off:off + height * bpl], dtype=np.uint8).reshape(height, bpl)[:, :width * nb]
    b = b.reshape(height, width, nb).astype(np.uint32)
    order = range(nb) if byte_order == 0 else range(nb - 1, -1, -1)  # 0: LSBFirst
    px = sum(b[..., i] << (8 * k) for k, i in enumerate(order))
    out = []
    for m in masks:
        shift = (m & -m).bit_length() - 1
        out.append(((px & m) >> shift).astype(np.uint8))
    return np.stack(out, axis=-1)


def _header_bands(img: np.ndarray, xs=(8, 300, 370)) -> list[int]:
    """Top rows of the collapsing headers in the panel: runs of rows that are the same blue across
    the whole panel width (a combo, slider or text field does not span it), sampled clear of the
    header's arrow and label."""
    cols = img[:, list(xs)].astype(int)  # (H, len(xs), 3)
    same = (np.abs(cols - cols[:, :1]).max(axis=(1, 2)) <= 2)
    blue = (cols[:, 0, 2] - cols[:, 0, 0] > 40) & (cols[:, 0, 2] > 80)
    rows = same & blue
    starts = [y for y in range(1, len(rows)) if rows[y] and not rows[y - 1]]
    return [y for y in starts if rows[y:y + 12].all()]  # a header is ~20 px tall


def _send_wm_delete(display: str, win: int) -> None:
    """What a window manager's close button does: a WM_DELETE_WINDOW client message (xdotool's
    windowclose destroys the window under the app instead)."""
    c = ctypes

    class ClientMessage(c.Structure):
        _fields_ = [("type", c.c_int), ("serial", c.c_ulong), ("send_event", c.c_int), ("display", c.c_void_p),
                    ("window", c.c_ulong), ("message_type", c.c_ulong), ("format", c.c_int), ("l", c.c_long * 5)]

    class XEvent(c.Union):
        _fields_ = [("xclient", ClientMessage), ("pad", c.c_long * 24)]

    x11 = c.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    x11.XOpenDisplay.restype, x11.XOpenDisplay.argtypes = c.c_void_p, [c.c_char_p]
    x11.XInternAtom.restype, x11.XInternAtom.argtypes = c.c_ulong, [c.c_void_p, c.c_char_p, c.c_int]
    x11.XSendEvent.argtypes = [c.c_void_p, c.c_ulong, c.c_int, c.c_long, c.POINTER(XEvent)]
    x11.XFlush.argtypes = x11.XCloseDisplay.argtypes = [c.c_void_p]
    d = x11.XOpenDisplay(display.encode())
    assert d, f"cannot open {display}"
    try:
        ev = XEvent()
        ev.xclient.type, ev.xclient.window, ev.xclient.format = 33, win, 32  # ClientMessage
        ev.xclient.message_type = x11.XInternAtom(d, b"WM_PROTOCOLS", 0)
        ev.xclient.l[0] = x11.XInternAtom(d, b"WM_DELETE_WINDOW", 0)
        x11.XSendEvent(d, win, 0, 0, c.byref(ev))
        x11.XFlush(d)
    finally:
        x11.XCloseDisplay(d)


def _diff(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).mean()) if a.shape == b.shape else float("inf")


def test_real_input_drives_the_viewer(xdisplay, tmp_path):
    log = tmp_path / "viewer.log"
    env = dict(os.environ, DISPLAY=xdisplay)
    env.setdefault("SKINVIEWER_CACHE", str(tmp_path / "cache"))
    cmd = [sys.executable, "-m", "skinviewer.cli", "--scene", "shadow-edge", "--technique", "gosselin",
           "--size", f"{WIN_W}x{WIN_H}", "--set", "shadow.map_size=256", "--set", "gosselin.light_map_size=256"]
    with open(log, "wb") as out:
        proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=out, stderr=subprocess.STDOUT)
    s = Session(xdisplay, proc, tmp_path, log)
    try:
        s.win = s.wait(lambda: (s.xdo("search", "--name", "^skinviewer") or "").split("\n")[0], 30, "the window")
        s.xdo("windowfocus", s.win)  # no window manager: give it the keyboard explicitly
        s.wait(lambda: "gosselin" in s.title(), 15, "the title to name the technique")

        # F12: the 3D view (right of the 400 px panel, above the status bar) with the subject in it
        a = s.f12(lambda img: img.std() > 10)
        assert a.shape[1] < WIN_W, "with the UI shown the screenshot is the 3D view only"

        # left-drag in the 3D view orbits the camera: the image changes
        vx = WIN_W - a.shape[1]
        cx, cy = vx + a.shape[1] // 2, a.shape[0] // 2
        s.drag(1, cx, cy, cx + 120, cy + 20)
        b = s.f12(lambda img: _diff(img, a) > 2.0)
        assert "*" not in s.title(), "an orbit is not an unsaved change (unless the camera is part of the preset)"

        # a click (press + release, as fast as xdotool makes it) on the first panel header collapses it
        # the panel settled first: the orbit's frames may still be completing (row bands), and the
        # "last change" line above the headers takes one or two lines as they finish
        def settled():
            first = s.grab()[:WIN_H, :400]
            time.sleep(1.5)
            again = s.grab()[:WIN_H, :400]
            return _header_bands(again) if np.array_equal(first, again) else None
        hdr = s.wait(settled, 30, "the panel headers, settled")
        # 'Look' starts open: its section fills the panel (the next header is far below, or off screen)
        assert hdr and (len(hdr) == 1 or hdr[1] - hdr[0] > 60), f"'Look' starts open (headers at {hdr})"
        s.xdo("mousemove", "--window", s.win, "60", str(hdr[0] + 10))
        s.xdo("click", "1")
        s.wait(lambda: (lambda h: len(h) >= 2 and h[0] == hdr[0] and h[1] - h[0] < 40)(
            _header_bands(s.grab()[:WIN_H, :400])), 10, "the clicked header to collapse its section")

        # keys: 1 = phong (title and image change); Escape must not quit; F1 hides the UI
        s.xdo("mousemove", "--window", s.win, str(cx), str(cy))
        s.xdo("key", "1")
        s.wait(lambda: s.title().endswith("phong"), 10, "key 1 to switch to phong")
        s.f12(lambda img: _diff(img, b) > 0.5)
        s.xdo("key", "Escape")
        s.xdo("key", "F1")
        full = s.f12(lambda img: img.shape[:2] == (WIN_H, WIN_W))  # UI hidden: the view is the window
        assert full.std() > 10
        assert proc.poll() is None, "Escape closed the viewer"

        # closing the window ends the session cleanly
        _send_wm_delete(xdisplay, int(s.win))
        try:
            rc = proc.wait(15)
        except subprocess.TimeoutExpired:
            pytest.fail("the viewer did not exit after its window was closed\n" + _tail(log))
        assert rc == 0, f"exit code {rc}\n{_tail(log)}"
        assert "Traceback" not in log.read_text(errors="replace"), _tail(log)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)
