"""Preset state of the viewer: the current file, the saved baseline (for the unsaved-changes
marker), the listing of ``presets/``, and the errors of a refused load."""
from __future__ import annotations

from pathlib import Path

from skinviewer.core import paths
from skinviewer.core.settings import (
    Settings,
    SettingsError,
    load_preset,
    save_preset,
    to_dict,
    with_values,
)

# these follow the window, not the user's choices
_VOLATILE = (("render", "width"), ("render", "height"))


def _comparable(s: Settings) -> dict:
    d = to_dict(s)
    for a, b in _VOLATILE:
        d.get(a, {}).pop(b, None)
    return d


class PresetState:
    def __init__(self, settings: Settings, path: str | None = None):
        self.path: str | None = path
        self.edit_path: str = path or ""
        self._baseline = _comparable(settings)
        self._dirty_of: tuple[Settings, bool] | None = None  # (settings, dirty): asked several times a frame
        self.errors: list[tuple[str, str]] = []
        self.error_source: str = ""
        self.message: str = ""

    def dirty(self, s: Settings) -> bool:
        # Settings are replaced, never edited in place (with_values): the answer for the same object holds
        if self._dirty_of is None or self._dirty_of[0] is not s:
            self._dirty_of = (s, _comparable(s) != self._baseline)
        return self._dirty_of[1]

    def mark_saved(self, s: Settings, path: str | None) -> None:
        self._baseline = _comparable(s)
        self._dirty_of = None
        self.path = path

    @staticmethod
    def listing() -> list[Path]:
        try:
            d = paths.presets_dir()
        except FileNotFoundError:
            return []
        return sorted(d.glob("*.json"))

    def load(self, path: str, current: Settings) -> Settings | None:
        """A validated Settings from ``path`` (window size kept), or None with ``errors`` set.
        The state is not touched: the caller calls ``accepted`` once it has taken the settings (it
        may still refuse them, e.g. an unavailable technique or an unloadable mesh)."""
        try:
            s = load_preset(path)
        except SettingsError as exc:
            self.refused(path, exc.errors, exc.source or path)
            return None
        return with_values(s, {"render.width": current.render.width, "render.height": current.render.height})

    def accepted(self, s: Settings, path: str) -> None:
        """``s`` (loaded from ``path``) is now the viewer's state: it becomes the saved baseline."""
        self.errors = []
        self.message = f"loaded {path}"
        self.mark_saved(s, path)
        self.edit_path = path

    def refused(self, path: str, errors: list[tuple[str, str]], source: str = "") -> None:
        """A load of ``path`` was refused: the current file, baseline and state stay as they were."""
        self.errors = list(errors)
        self.error_source = source or path
        self.message = f"refused {path}"

    def save(self, s: Settings, path: str | None = None) -> bool:
        target = path or self.path
        if not target:
            self.message = "no preset path: use Save as"
            return False
        try:
            save_preset(s, target)
        except OSError as exc:
            self.errors = [("<file>", f"cannot write: {exc.strerror or exc}")]
            self.error_source = target
            self.message = f"could not save {target}"
            return False
        self.errors = []
        self.mark_saved(s, target)
        self.edit_path = target
        self.message = f"saved {target}"
        return True
