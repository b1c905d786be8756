"""Radially weighted plots r*R(r) vs r (seed 002 section 14.4.6): the area under each curve is
R_d/(2 pi), so poor fits show where light is lost or gained. ``plot_arrays`` returns the data for an
ImGui/implot panel; ``save_plot`` writes a PNG headlessly (matplotlib Agg), atomically."""
from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np

from skinviewer.ground.files import atomic_path
from skinviewer.physics.fitting import FitResult

CHANNELS = (("red", "#d62728"), ("green", "#2ca02c"), ("blue", "#1f77b4"))


def plot_range(profile: Callable[[np.ndarray], np.ndarray], fraction: float = 0.98) -> float:
    """Largest radius (mm) needed to show ``fraction`` of int r R dr in every channel (capped 100 mm)."""
    r = np.geomspace(1e-4, 100.0, 600)
    R = np.asarray(profile(r), dtype=float).reshape(r.size, -1)
    dens = r[:, None] ** 2 * np.abs(R)  # r R dr = r^2 R dlog r
    tot = dens.sum(axis=0)
    live = tot > 0
    if not np.any(live):
        return 1.0
    cum = np.cumsum(dens[:, live], axis=0) / tot[live]
    return float(r[min(r.size - 1, int(np.max(np.argmax(cum >= fraction, axis=0))))])


def plot_arrays(profile: Callable[[np.ndarray], np.ndarray], fit: FitResult | None = None,
                r_max: float | None = None, n: int = 400) -> dict[str, np.ndarray]:
    """{"r": (n,) mm, "rR": (n, 3) r*R(r), "rG": (n, 3) r*G_sum(r) or absent}, r from 0 to r_max."""
    r_max = plot_range(profile) if r_max is None else float(r_max)
    r = np.linspace(0.0, r_max, n)
    # r R(r) is continuous at 0 but R may be singular there (Burley ~ 1/r): evaluate the first sample
    # at a radius far below the plot's resolution instead of 0 * inf
    re = np.maximum(r, 1e-9 * r_max)
    out = {"r": r, "rR": re[:, None] * np.nan_to_num(np.asarray(profile(re), dtype=float), posinf=0.0)}
    if fit is not None:
        out["rG"] = r[:, None] * fit(r)
    return out


def save_plot(path: str | os.PathLike, profile: Callable[[np.ndarray], np.ndarray], fit: FitResult | None = None,
              title: str = "", r_max: float | None = None) -> None:
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    data = plot_arrays(profile, fit, r_max)
    fig, ax = plt.subplots(figsize=(7.0, 4.5), dpi=110)
    try:
        for c, (name, color) in enumerate(CHANNELS):
            ax.plot(data["r"], data["rR"][:, c], color=color, lw=1.8, label=f"{name} profile")
            if "rG" in data and fit is not None:
                err = f" (E = {100 * fit.errors[c]:.3g} %)"
                ax.plot(data["r"], data["rG"][:, c], color=color, lw=1.4, ls="--",
                        label=f"{name} {fit.k}-Gaussian fit{err}")
        ax.set_xlabel("r (mm)")
        ax.set_ylabel("r · R(r)  (1/mm)")
        ax.set_xlim(0.0, data["r"][-1])
        ax.set_ylim(bottom=0.0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        if title:
            ax.set_title(title)
        fig.tight_layout()
        with atomic_path(path, suffix=".png") as tmp:
            fig.savefig(tmp, format="png")
    finally:
        plt.close(fig)
