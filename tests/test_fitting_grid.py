"""The fitting's grid and report (physics/fitting.py) against closed forms (issue 36: its mutation sample
found them unpinned; test_fitting.py's fits take minutes and check the fits, not the grid)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from skinviewer.physics import fitting as F


def _gauss(v):
    return lambda r: np.exp(-np.asarray(r) ** 2 / (2 * v)) / (2 * math.pi * v)


def test_grid_range_quadrature_and_total_by_closed_forms():
    # a plain function (no total_reflectance): R_d = 2 pi int r R dr = 1 for eq. 20's Gaussian
    g = F.make_grid(_gauss(0.7))
    np.testing.assert_allclose(g.total, 1.0, rtol=1e-6)
    # the quadrature: int_0^inf r R^2 dr = 1 / (8 pi^2 v) (v = 0.7); norms are its square root
    np.testing.assert_allclose(g.norms, math.sqrt(1 / (8 * math.pi ** 2 * 0.7)), rtol=1e-4)

    def ring(r):  # nothing inside 1 mm: the grid starts just below 1 mm, not at the probe's 1e-5 mm
        r = np.asarray(r, np.float64)
        return np.where(r > 1.0, np.exp(-r), 0.0)
    g = F.make_grid(ring)
    assert 0.8 < g.r[0] <= 1.0 and g.r[-1] > 10.0
    # a profile that is zero everywhere: nothing to bound, the whole probe range
    g = F.make_grid(lambda r: np.zeros_like(np.asarray(r, np.float64)))
    assert g.r[0] == pytest.approx(1e-5) and g.r[-1] == pytest.approx(1e4)


def test_grid_from_one_channel_of_samples_and_the_fit_report():
    r = np.linspace(0.01, 30.0, 3000)
    f = np.exp(-r)
    g1, g3 = F.FitGrid.from_samples(r, f), F.FitGrid.from_samples(r, np.repeat(f[:, None], 3, 1))
    np.testing.assert_array_equal(g1.target, g3.target)
    np.testing.assert_allclose(g1.norms, 0.5, rtol=1e-3)  # sqrt(int r e^(-2r) dr) = sqrt(1/4)
    res = F.FitResult(np.array([0.1, 1.0]), np.array([[0.2, 0.3, 0.4], [0.8, 0.7, 0.6]]), np.array([0.1, 0.2, 0.3]),
                      True, np.array([1.0, 1.0, 1.0]), g3)
    d = res.to_dict()
    assert d["k"] == 2 and d["shared_variances"] is True and list(d["channels"]) == ["r", "g", "b"]
    assert d["channels"]["g"]["weights"] == [0.3, 0.7] and d["channels"]["b"]["variances"] == [0.1, 1.0]
    assert d["channels"]["b"]["error"] == 0.3 and d["channels"]["r"]["target_total"] == 1.0


def test_fixed_variances_that_are_not_positive_numbers_are_refused():
    for bad in ([0.1, math.nan], [0.2, math.inf], [0.1, 0.0], [], [[0.1, 0.2]]):
        with pytest.raises(ValueError, match="^fixed variances must be positive numbers$"):
            F.fit_gaussians(_gauss(0.5), fixed_variances=bad)
