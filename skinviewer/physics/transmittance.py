"""Jimenez et al. 2010 translucency (seed 001 §3.5, eq. 3.14-3.18; spec §6), numpy reference of
the transmittance the screen-space transmittance pass adds (shaders/ss_transmittance.frag)."""
from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import FloatArray

# [SEP] SSSSTransmittance: scale = 8.25 (1 - translucency) / sssWidth; sssWidth <-> 3 mm of profile
SEP_SCALE = 8.25
SEP_WIDTH_MM = 3.0


def profile_distance(thickness_mm: ArrayLike, translucency: float) -> FloatArray:
    """The profile distance d for a thickness (mm): 8.25 (1 - translucency) / 3 mm x thickness."""
    return SEP_SCALE * (1.0 - translucency) / SEP_WIDTH_MM * np.asarray(thickness_mm, dtype=np.float64)


def transmittance(d: ArrayLike, gaussians: Iterable[tuple[float, ArrayLike]], form: str = "printed") -> FloatArray:
    """eq. 3.18: T(d) = sum_i w_i exp(-d^2 / v_i) ("printed", [SEP]) or exp(-d^2 / (2 v_i))
    ("exact", the 2-D Gaussian's integral, erratum E10). gaussians: (variance mm^2, RGB). (..., 3)."""
    da = np.asarray(d, dtype=np.float64)[..., None]
    div = 1.0 if form == "printed" else 2.0
    out = np.zeros(da.shape[:-1] + (3,))
    for v, w in gaussians:
        wa = np.asarray(w, dtype=np.float64)
        if v > 0:
            out = out + wa * np.exp(-da * da / (div * v))
        else:
            out = out + wa * (da == 0)
    return out


def backlit(d: ArrayLike, gaussians: Iterable[tuple[float, ArrayLike]], l_dot_minus_n: ArrayLike, wrap: float = 0.3, form: str = "printed") -> FloatArray:
    """spec §6.2 step 5: T(d) saturate(wrap + L.(-N))."""
    return transmittance(d, gaussians, form) * np.clip(wrap + np.asarray(l_dot_minus_n, np.float64), 0.0, 1.0)[..., None]
