"""The ground truth's bookkeeping that its convolution tests cannot see (issue 36: physics/ground_truth.py's
mutation sample): the receiver's own element takes the receiver's own E A, one source is a source, an empty
subdivision stays an index array, a cancel stops the work. Against brute-force quadrature."""
from __future__ import annotations

import math

import numpy as np
import pytest

from skinviewer.physics import ground_truth as gt

TRI = np.array([[[-1.0, -1.0, 0.0], [2.0, -1.0, 0.0], [-1.0, 2.0, 0.0]]])  # one element, centroid at 0


def _mass(x, corners, v, n=300):
    """int_triangle G(v, |x - y|) dA (eq. 20) by a fine midpoint rule over an n x n subdivision."""
    b, t = gt.subdivision_pattern(n)
    sub = (b @ corners)[t]
    c = sub.mean(1)
    area = 0.5 * np.linalg.norm(np.cross(sub[:, 1] - sub[:, 0], sub[:, 2] - sub[:, 0]), axis=1)
    return float((area * np.exp(-((c - x) ** 2).sum(1) / (2 * v)) / (2 * math.pi * v)).sum())


def test_the_receivers_own_element_uses_its_own_e_a():
    """An element's E A is its mean; under the receiver itself the receiver's own value is used (``ea_here``):
    an element lit unevenly would otherwise spread its mean onto its own bright or dark point. Not for a
    receiver farther than an element radius from the element, nor for a piece cut along a shadow edge."""
    el = gt.Elements(TRI, np.ones((1, 3)))
    v = 0.05
    d = gt.Diffusion(el, [v], [(1.0, 1.0, 1.0)], 1.0)
    assert d.method(v)[0] == "exact"
    x = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 5.0], [8.0, 0.0, 0.0]])
    here = np.array([[3.0, 3.0, 3.0], [3.0, 3.0, 3.0], [3.0, 3.0, 3.0]])
    M = d.exitance(x, here)
    assert M[0, 0] == pytest.approx(3.0 * _mass(x[0], TRI[0], v), rel=1e-4)  # own: 3, not the mean 1
    assert M[2, 0] == pytest.approx(_mass(x[2], TRI[0], v), rel=1e-3, abs=1e-30)  # 8 mm away: the mean
    assert M[1, 0] == pytest.approx(_mass(x[1], TRI[0], v), abs=1e-30)  # 5 mm off the plane: the mean (~0)
    cut = gt.Elements(TRI, np.ones((1, 3)), split=np.array([True]))
    Mc = gt.Diffusion(cut, [v], [(1.0, 1.0, 1.0)], 1.0).exitance(x[:1], here[:1])
    assert Mc[0, 0] == pytest.approx(_mass(x[0], TRI[0], v), rel=1e-4)


def test_one_source_is_binned_and_an_empty_subdivision_stays_an_index_array():
    x = np.array([[0.0, 0.0, 0.0], [0.3, 0.4, 0.0], [50.0, 0.0, 0.0]])
    src = np.array([[0.6, 0.8, 0.0]])
    got = {}
    for ri, sj, d2 in gt.blocks(x, src, 1.0):
        for a, i in enumerate(ri):
            for b, j in enumerate(sj):
                got[(int(i), int(j))] = float(d2[a, b])
    assert got[(0, 0)] == pytest.approx(1.0) and got[(1, 0)] == pytest.approx(0.25)
    assert (2, 0) not in got  # 50 mm away: not in the 27 cells around
    assert list(gt.blocks(x, src[:0], 1.0)) == [] and list(gt.blocks(x[:0], src, 1.0)) == []
    vpar, vbary, elems = gt.subdivide(TRI, 0.5, keep=np.array([False]))
    assert vpar.shape == (0,) and vbary.shape == (0, 3) and elems.shape == (0, 3)
    assert vpar.dtype.kind == "i" and elems.dtype.kind == "i"
    assert TRI[vpar].shape == (0, 3, 3)  # usable as an index, as the non-empty case is


def test_a_cancel_stops_the_exitance_and_progress_reaches_one():
    el = gt.Elements(TRI, np.ones((1, 3)))
    d = gt.Diffusion(el, [0.05, 0.8, 30.0], np.ones((3, 3)), 1.0)
    seen = []
    d.exitance(np.zeros((2, 3)), progress=seen.append)
    assert seen[-1] == pytest.approx(1.0) and seen == sorted(seen)
    with pytest.raises(InterruptedError, match="^cancelled$"):
        d.exitance(np.zeros((2, 3)), cancelled=lambda: True)


def test_triangle_mass_of_float32_corners_is_computed_in_float64():
    """Mesh positions are often float32: the element integral of the same corners is the float64 one."""
    q = np.float32([[0.3, -0.2], [1.7, 0.4], [-0.6, 1.1]])
    want = gt.gaussian_triangle_mass(*q.astype(np.float64))
    assert gt.gaussian_triangle_mass(*q) == pytest.approx(want, rel=1e-13)
