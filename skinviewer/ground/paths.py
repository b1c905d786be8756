"""Where the GLSL (`shaders/`) and presets (`presets/`) are: the source checkout first (so edits
are live), else the copies installed inside the wheel as `skinviewer/shaders` and `skinviewer/presets`."""
from __future__ import annotations

import os
from pathlib import Path

_PKG = Path(__file__).resolve().parents[1]  # the skinviewer package
_CHECKOUT = _PKG.parent


def _find(name: str, env: str) -> Path:
    override = os.environ.get(env)
    if override:
        p = Path(override).resolve()
        if not p.is_dir():
            raise FileNotFoundError(f"{env}={override}: not a folder")
        return p
    source = _CHECKOUT / name
    if source.is_dir() and (_CHECKOUT / "pyproject.toml").is_file():
        return source
    installed = _PKG / name
    if installed.is_dir():
        return installed
    raise FileNotFoundError(f"cannot find the {name}/ folder (looked in {source} and {installed}); set {env}")


def shaders_dir() -> Path:
    return _find("shaders", "SKINVIEWER_SHADERS")


def presets_dir() -> Path:
    return _find("presets", "SKINVIEWER_PRESETS")


class CacheDirError(OSError):
    """The cache folder cannot be used; the message names where it came from (SKINVIEWER_CACHE)."""


def cache_dir() -> Path:
    env = os.environ.get("SKINVIEWER_CACHE")
    d = Path(env or Path.home() / ".cache" / "skinviewer")
    where = f"SKINVIEWER_CACHE={env}" if env else f"the cache folder {d}"
    try:
        d.mkdir(parents=True, exist_ok=True)
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the variable
        why = "it is a file, not a folder" if d.is_file() else getattr(exc, "strerror", None) or str(exc)
        raise CacheDirError(f"{where}: {why}; point SKINVIEWER_CACHE at a writable folder") from None
    if not os.access(d, os.W_OK | os.X_OK):
        raise CacheDirError(f"{where}: not writable; point SKINVIEWER_CACHE at a writable folder")
    return d
