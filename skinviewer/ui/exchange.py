"""Presets > Export... / Import... / Turntable in the viewer (issue 33).

Export and import call the same code as ``skinviewer export`` / ``skinviewer import``
(:mod:`skinviewer.engine.exchange`). The turntable runs ``skinviewer turntable`` as a child process (its
own headless GL context, so the viewer's frame loop is untouched); its progress lines are read on a
thread, and cancel sends it SIGINT, on which it removes its temporary output: nothing half-written."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

from skinviewer.engine.exchange import (
    SUFFIX,
    ExchangeError,
    export,
    read_any,
    settings_with,
)
from skinviewer.ground.settings import Settings, SettingsError, to_dict
from skinviewer.physics.engines import TARGETS


def export_current(s: Settings, target: str, path: str) -> tuple[bool, str]:
    """(ok, message): the message names what was written and the fit's loss per channel."""
    try:
        r = export(s, target, path)
    except (ExchangeError, OSError) as exc:
        return False, f"export failed: {exc}"
    loss = " / ".join(f"{100 * e:.1f}" for e in r.fit.error)
    return True, f"wrote {', '.join(str(w) for w in r.written)} (Burley fit loses {loss} % of r R(r), R/G/B)"


def import_into(s: Settings, path: str) -> tuple[Settings | None, str]:
    """The settings with the imported profile (or None) and a message listing what was skipped."""
    try:
        imp = read_any(path)
        new, fit = settings_with(s, imp)
    except (ExchangeError, SettingsError) as exc:
        return None, f"import refused: {exc}"
    msg = f"imported a {imp.target} profile (Gaussian fit error " + \
        " / ".join(f"{100 * e:.1f}" for e in fit.errors) + " %)"
    if imp.skipped:
        msg += f"; skipped: {', '.join(imp.skipped)}"
    if imp.notes:
        msg += "; " + "; ".join(imp.notes)
    return new, msg


class TurntableJob:
    """``skinviewer turntable`` in a child process, with progress and cancel."""

    def __init__(self, s: Settings, out: str, frames: int = 36, size: tuple[int, int] = (384, 384),
                 light_orbit: bool = False):
        self.out = out
        self.total = frames
        self.done = 0
        self.message = ""
        self.finished = False
        self.ok = False
        fd, self._preset = tempfile.mkstemp(prefix="skinviewer-turntable-", suffix=".json")
        with os.fdopen(fd, "w") as f:
            json.dump(to_dict(s), f)
        cmd = [sys.executable, "-m", "skinviewer", "turntable", "--preset", self._preset, "--frames", str(frames),
               "--size", f"{size[0]}x{size[1]}", "--out", out, "--progress-lines"]
        if light_orbit:
            cmd.append("--light-orbit")
        env = dict(os.environ)
        root = str(Path(__file__).resolve().parents[2])
        env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        self._proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        self._err: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()
        threading.Thread(target=lambda: self._err.extend(self._proc.stderr or ()), daemon=True).start()

    def _read(self) -> None:
        for line in self._proc.stdout or ():
            parts = line.split()
            if len(parts) == 3 and parts[0] == "progress":
                self.done = int(parts[1])
            elif line.startswith("wrote"):
                self.message = line.strip()
        code = self._proc.wait()
        self.ok = code == 0
        if not self.ok:
            err = [ln.strip() for ln in self._err if ln.strip()]
            self.message = "turntable cancelled, nothing written" if code in (130, -signal.SIGINT) else \
                (err[-1] if err else f"turntable failed (exit {code})")
        Path(self._preset).unlink(missing_ok=True)
        self.finished = True

    def take_message(self) -> str:
        """The finished job's message, once."""
        m, self.message = self.message, ""
        return m

    @property
    def fraction(self) -> float:
        return self.done / max(self.total, 1)

    def cancel(self) -> None:
        if self._proc.poll() is None:
            self._proc.send_signal(signal.SIGINT)  # the child's KeyboardInterrupt removes its temporaries

    def wait(self, timeout: float | None = None) -> bool:
        try:
            self._proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return False
        for _ in range(200):
            if self.finished:
                break
            threading.Event().wait(0.01)
        return self.finished


class ExchangeTools:
    """The compact block under Presets: target + path, Export..., Import..., Turntable."""

    def __init__(self) -> None:
        self.target = 0
        self.path = ""
        self.message = ""
        self.error = False
        self.job: TurntableJob | None = None
        self.frames = 36

    def default_path(self) -> str:
        t = TARGETS[self.target]
        return str(Path.cwd() / f"skin_{t}{SUFFIX[t]}")

    def draw(self, st, ui) -> None:
        from imgui_bundle import imgui

        from skinviewer.ui.widgets import ERR, OK, tooltip, wrapped
        if ui.expand_all:
            imgui.set_next_item_open(True)
        if not imgui.tree_node("Export / Import / Turntable"):
            return
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.4)
        ch, i = imgui.combo("target", self.target, list(TARGETS))
        if ch:
            self.target = i
            self.path = ""
        _, self.path = imgui.input_text("file##exchange", self.path or self.default_path())
        tooltip(".asset (HDRP), .py (Unreal, Blender), .mtlx (MaterialX, OpenPBR); Import also reads .json")
        if imgui.button("Export..."):
            ok, self.message = export_current(st.settings, TARGETS[self.target], self.path.strip())
            self.error = not ok
        imgui.same_line()
        if imgui.button("Import..."):
            new, self.message = import_into(st.settings, self.path.strip())
            self.error = new is None or not st.set_settings(new, f"import {self.path.strip()}")
        imgui.same_line()
        if self.job is None or self.job.finished:
            if imgui.button("Turntable"):
                out = str(Path(self.path.strip() or self.default_path()).with_suffix(".mp4"))
                self.job = TurntableJob(st.settings, out, self.frames)
                self.message, self.error = f"rendering {out} in the background", False
            tooltip("renders a 360 degree orbit to an MP4 beside the file above, in the background")
        else:
            if imgui.button("Cancel turntable"):
                self.job.cancel()
            imgui.progress_bar(self.job.fraction, imgui.ImVec2(-1, 0), f"{self.job.done}/{self.job.total} frames")
        if self.job is not None and self.job.finished and self.job.message:
            self.message, self.error = self.job.take_message(), not self.job.ok
        if self.message:
            wrapped(self.message, ERR if self.error else OK)
        imgui.tree_pop()
