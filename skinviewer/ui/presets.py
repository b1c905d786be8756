"""Preset state of the viewer: the current file, the saved baseline (for the unsaved-changes
marker), the two preset folders, and the errors of a refused load.

Two folders: the **shipped** presets (``presets/`` of the checkout or the wheel, or
``SKINVIEWER_PRESETS``) are read-only — saving over one becomes a "save as" into the **user** folder
(``SKINVIEWER_USER_PRESETS``, else ``$XDG_CONFIG_HOME/skinviewer/presets``, else
``~/.config/skinviewer/presets``). A preset written by the viewer holds what the user chose: never
the render size (it follows the window), floats rounded to 6 significant digits (no
``0.30000000000000004`` from a slider)."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from skinviewer.ground import paths
from skinviewer.ground.files import list_files
from skinviewer.ground.settings import (
    Settings,
    SettingsError,
    load_preset,
    save_preset,
    to_dict,
    with_values,
)
from skinviewer.ui.screenshot import timestamped_path

# these follow the window, not the user's choices: never compared, never saved
_VOLATILE = (("render", "width"), ("render", "height"))
FLOAT_DIGITS = 6


def _comparable(s: Settings, camera: bool = True) -> dict:
    d = to_dict(s)
    for a, b in _VOLATILE:
        d.get(a, {}).pop(b, None)
    if not camera:
        d.pop("camera", None)  # orbiting is looking, not editing (unless the user opts in)
    return d


def _rounded(v):
    if isinstance(v, float):
        return float(f"{v:.{FLOAT_DIGITS}g}")
    if isinstance(v, dict):
        return {k: _rounded(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_rounded(x) for x in v]
    return v


def preset_payload(s: Settings, camera: bool = True) -> dict:
    """What the viewer writes to a preset file: the settings without the render size (and without the
    camera unless ``camera``), floats rounded."""
    return _rounded(_comparable(s, camera))


def _names_camera(path: str) -> bool:
    """The preset file sets a camera (a preset saved without one keeps the viewer's)."""
    import json
    try:
        with open(path, encoding="utf-8-sig") as f:
            return isinstance(json.load(f).get("camera"), dict)
    except (OSError, ValueError, AttributeError, RecursionError):
        return True


def name_to_path(name: str) -> Path | None:
    """A preset name typed in *Save as*: a bare name goes to the user folder as NAME.json; a path is
    taken as it is. None for an empty or unusable name."""
    name = name.strip()
    if not name or "\x00" in name or name in (".", ".."):
        return None
    p = Path(name).expanduser()
    if len(p.parts) == 1:
        p = user_presets_dir() / (name if name.endswith(".json") else f"{name}.json")
    elif p.suffix != ".json":
        p = p.with_suffix(".json")
    return p


def user_presets_dir() -> Path:
    env = os.environ.get("SKINVIEWER_USER_PRESETS")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CONFIG_HOME") or (Path.home() / ".config")
    return Path(base) / "skinviewer" / "presets"


def shipped_presets_dir() -> Path | None:
    try:
        return paths.presets_dir()
    except FileNotFoundError:
        return None


def is_shipped(path: str | os.PathLike) -> bool:
    """``path`` is (or would be) a file in the shipped presets folder: read-only."""
    d = shipped_presets_dir()
    if d is None:
        return False
    try:
        return Path(path).expanduser().resolve().parent == d.resolve()
    except (OSError, RuntimeError, ValueError):
        return False


def _free_name(folder: Path, name: str) -> Path:
    """``folder/name``, or ``stem-2.json``, ``stem-3.json``, ... when taken: never over another file."""
    p = folder / name
    k = 2
    while p.exists():
        p = folder / f"{Path(name).stem}-{k}{Path(name).suffix or '.json'}"
        k += 1
    return p


def _json_files(folder: Path | None) -> list[Path]:
    if folder is None or not folder.is_dir():
        return []
    return list_files(folder)  # regular files only: never hidden files or our own save temporaries


class PresetState:
    def __init__(self, settings: Settings, path: str | None = None):
        self.path: str | None = path
        self.edit_path: str = path or ""
        self._baseline = _comparable(settings)
        self._dirty_of: tuple[Settings, bool] | None = None  # (settings, dirty): asked several times a frame
        # camera moves are unsaved changes and presets store the camera only when the user opts in
        self.track_camera = False
        self.naming = False  # the "Save as" name popup is open
        self.name_text = ""
        self.errors: list[tuple[str, str]] = []
        self.error_source: str = ""
        self.message: str = ""
        self.pending_load: str | None = None  # a load waiting for "discard unsaved changes?"

    # -- reading -----------------------------------------------------------------------------
    def dirty(self, s: Settings) -> bool:
        # Settings are replaced, never edited in place (with_values): the answer for the same object holds
        if self._dirty_of is None or self._dirty_of[0] is not s:
            base = dict(self._baseline)
            if not self.track_camera:
                base.pop("camera", None)
            self._dirty_of = (s, _comparable(s, self.track_camera) != base)
        return self._dirty_of[1]

    def set_track_camera(self, on: bool) -> None:
        self.track_camera = bool(on)
        self._dirty_of = None

    def ask_name(self, suggestion: str = "") -> None:
        """Open *Save as*: the name field starts with ``suggestion`` (the current preset's name)."""
        self.naming = True
        self.name_text = suggestion or (Path(self.path).stem if self.path else "my-skin")

    def set_name_text(self, text: str) -> None:
        self.name_text = text

    def close_naming(self) -> None:
        self.naming = False

    @property
    def read_only(self) -> bool:
        return self.path is not None and bool(self.path) and is_shipped(self.path)

    @staticmethod
    def listing() -> list[tuple[str, list[Path]]]:
        """(folder title, files) for the shipped and the user folder."""
        user = user_presets_dir()
        return [("shipped (read-only)", _json_files(shipped_presets_dir())), (f"yours ({user})", _json_files(user))]

    # -- edits -------------------------------------------------------------------------------
    def set_edit_path(self, text: str) -> None:
        self.edit_path = text

    def set_path(self, path: str | None) -> None:
        """The file Ctrl+S writes (None: a new file in the user folder)."""
        self.path = path

    def mark_saved(self, s: Settings, path: str | None) -> None:
        self._baseline = _comparable(s)
        self._dirty_of = None
        self.path = path

    def load(self, path: str, current: Settings) -> Settings | None:
        """A validated Settings from ``path`` (window size kept), or None with ``errors`` set.
        The state is not touched: the caller calls ``accepted`` once it has taken the settings (it
        may still refuse them, e.g. an unavailable technique or an unloadable mesh)."""
        try:
            s = load_preset(path)
        except SettingsError as exc:
            self.refused(path, exc.errors, exc.source or path)
            return None
        keep: dict[str, Any] = {"render.width": current.render.width, "render.height": current.render.height}
        if not _names_camera(path):
            keep["camera"] = current.camera.model_dump(mode="json")  # saved without a camera: keep the view
        return with_values(s, keep)

    def accepted(self, s: Settings, path: str) -> None:
        """``s`` (loaded from ``path``) is now the viewer's state: it becomes the saved baseline."""
        self.errors = []
        self.pending_load = None
        self.message = f"loaded {path}"
        self.mark_saved(s, path)
        self.edit_path = path

    def refused(self, path: str, errors: list[tuple[str, str]], source: str = "") -> None:
        """A load of ``path`` was refused: the current file, baseline and state stay as they were."""
        self.errors = list(errors)
        self.error_source = source or path
        self.message = f"refused {path}"

    def save_target(self) -> tuple[Path, str]:
        """Where Ctrl+S writes, and a note: the current file; a new file in the user folder when
        there is none; a copy in the user folder when the current one is shipped (read-only)."""
        user = user_presets_dir()
        if not self.path:  # the viewer asks for a name first (ViewerState.save_preset); scripts get a stamp
            return timestamped_path(user, prefix="preset", ext=".json"), ""
        if is_shipped(self.path):
            name = Path(self.path).name
            return _free_name(user, name), f"{name} is a shipped preset (read-only): saved a copy as"
        return Path(self.path), ""

    def save(self, s: Settings, path: str | os.PathLike | None = None, note: str = "") -> bool:
        target = str(path or self.path or "")
        if not target:
            self.message = "no preset path: use Save as"
            return False
        if is_shipped(target):
            self.errors = [("<file>", "shipped presets are read-only: save as a file in "
                                      f"{user_presets_dir()} (Ctrl+S does)")]
            self.error_source = target
            self.message = f"not saved: {Path(target).name} is a shipped preset"
            return False
        try:
            Path(target).parent.mkdir(parents=True, exist_ok=True)
            save_preset(s, target, preset_payload(s, self.track_camera))  # scene paths relative to its folder
        except OSError as exc:
            self.errors = [("<file>", f"cannot write: {exc.strerror or exc}")]
            self.error_source = target
            self.message = f"could not save {target}"
            return False
        self.errors = []
        self.mark_saved(s, target)
        self.edit_path = target
        self.message = f"{note} {target}" if note else f"saved {target}"
        return True

    # -- "discard unsaved changes?" ------------------------------------------------------------
    def ask_before_loading(self, path: str) -> None:
        self.pending_load = path

    def cancel_pending(self) -> None:
        self.pending_load = None
