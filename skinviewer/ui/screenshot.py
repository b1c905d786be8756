"""Screenshots: PNG of the 3D view (optionally with the UI), timestamped name in a folder,
optionally the linear image as float32 .npy and/or OpenEXR. Written atomically."""
from __future__ import annotations

import datetime as _dt
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass
class ScreenshotOptions:
    folder: str = "screenshots"
    include_ui: bool = False
    save_linear_npy: bool = False
    save_linear_exr: bool = False


def timestamped_path(folder: str | os.PathLike, prefix: str = "skinviewer", ext: str = ".png") -> Path:
    stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S-%f")[:-3]
    return Path(folder) / f"{prefix}-{stamp}{ext}"


def read_screen(ctx, size: tuple[int, int], origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """A region of the default framebuffer (back buffer) as uint8 (H, W, 3), top row first.
    ``origin``: the region's bottom-left corner in framebuffer pixels (GL convention)."""
    w, h = size
    raw = ctx.screen.read(viewport=(int(origin[0]), int(origin[1]), w, h), components=3, alignment=1)
    return np.frombuffer(raw, dtype=np.uint8).reshape(h, w, 3)[::-1].copy()
