"""Shader hot reload: poll the library about twice a second; a changed GLSL file recompiles the
programs that include it (the graph's cache keys hold shader versions, so their passes re-run).
A failing compile keeps the last good program running; its errors stay listed until fixed."""
from __future__ import annotations

import time

from skinviewer.kernel.shaders import ShaderError, ShaderLibrary


class ShaderWatcher:
    def __init__(self, shaders: ShaderLibrary, interval: float = 0.5):
        self.shaders = shaders
        self.interval = interval
        self._next = 0.0
        self.errors: dict[str, list[ShaderError]] = {}
        self.last_reloaded: list[str] = []
        self._failure: dict[str, list[ShaderError]] = {}  # a reload that raised (listed until one succeeds)

    def poll(self, now: float | None = None, force: bool = False) -> list[str]:
        """Recompile changed programs when due; returns the names replaced this call."""
        now = time.monotonic() if now is None else now
        if not force and now < self._next:
            return []
        self._next = now + self.interval
        try:
            replaced, _ = self.shaders.reload(force=force)
            self._failure = {}
        except Exception as exc:  # e.g. a file saved in another encoding: listed, the session goes on
            replaced = []
            self._failure = {"(reload)": [ShaderError(str(self.shaders.root), 0, f"{type(exc).__name__}: {exc}")]}
        self.refresh_errors()
        if replaced:
            self.last_reloaded = replaced
        return replaced

    def refresh_errors(self) -> None:
        self.errors = {**self.shaders.errors(), **self._failure}
