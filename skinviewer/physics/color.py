"""Colour encodings shared by the renderer (albedo maps, the background), the ground truth and the
output pass: numpy, float64. ``shaders/lib/color.glsl`` is the GLSL twin of the decoding."""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def srgb_to_linear(c: ArrayLike) -> NDArray[np.float64]:
    """The sRGB decoding (IEC 61966-2-1): c / 12.92 up to 0.04045, ((c + 0.055) / 1.055)^2.4 above;
    input clamped to [0, 1]."""
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    out: NDArray[np.float64] = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return out
