"""Brute-force subsurface diffusion over a triangle mesh: the ground truth every technique is
measured against (Jensen et al. 2001; seed 002 §14.4.2; seed 000 eq. 21):

    M(x) = sum_i w_i  integral_S  G(v_i, |x - y|) E(y) A(y) dA(y)

with 3D distances |x - y| over the whole surface S (so seams do not exist, and a thin flap's lit
back surface reaches its front through its thickness), for a sum of 2D Gaussians G(v, r) =
exp(-r^2 / 2v) / (2 pi v) (eq. 20).

Integrated, not point-sampled. The surface is cut into small flat source elements (sub-triangles
of edge <= h) whose E A is the mean of their corners. For each Gaussian of variance v:

- v < OWEN_RATIO s^2 (s^2: the elements' in-plane per-axis variance; on 0.5 mm elements the
  0.0064 and 0.0484 mm^2 skin Gaussians): the exact integral of the Gaussian over each flat
  triangle in closed form with Owen's T function, times exp(-z^2 / 2v) for the height z of x over
  the element's plane (G(v, sqrt(r^2 + z^2)) = G(v, r) exp(-z^2 / 2v), the separability behind
  eq. 33). Every Gaussian keeps its exact total weight however narrow it is.
- wider: elements, or clusters of elements (voxels <= sigma / CLUSTER_RATIO, split by normal octant
  so the two sides of a thin flap never merge), each a Gaussian moment-matched in its own plane,
  a G(v + s^2, r_parallel) exp(-z^2 / 2v) (exact to second order in s / sigma; the height exact).
- the element under x takes E A evaluated at x itself (the best estimate of the local mean a narrow
  Gaussian averages), so sub-element irradiance detail (normal map, albedo) is kept; Gaussians with
  v < DELTA_V are E A(x).
- thin beams (the laser) are point sources: K rays of the beam, each carrying its power.

Everything is float64 numpy + scipy (KD-trees and cell blocks for the neighbours, owens_t); no GL.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from scipy.special import owens_t

from skinviewer.physics.arrays import FloatArray, IntArray

CLUSTER_RATIO = 1.25  # a cluster level is used for a Gaussian when its voxel <= sigma / 1.25
TRUNCATE = 4.5        # kernel support in standard deviations (weight beyond: exp(-10.1) = 4e-5)


# -- the exact Gaussian integral over a triangle ----------------------------------------------

def _wedge(h: FloatArray, t: FloatArray) -> FloatArray:
    """Standard 2D normal mass of the right triangle (0, (h, 0), (h, t)), h > 0, signed by t:
    atan(t/h) / 2pi - T(h, t/h) (Owen's T: T(h, a) = P(X > h, 0 < Y < aX))."""
    a = t / h
    out: FloatArray = np.arctan(a) / (2.0 * np.pi) - owens_t(h, a)
    return out


def gaussian_triangle_mass(q0: FloatArray, q1: FloatArray, q2: FloatArray) -> FloatArray:
    """Mass of the standard 2D normal (sigma = 1, centred at the origin) inside triangles (q0, q1,
    q2) given as (..., 2) arrays in units of sigma; any orientation (the result is >= 0)."""
    q = [np.asarray(x, np.float64) for x in (q0, q1, q2)]
    cross = (q[1][..., 0] - q[0][..., 0]) * (q[2][..., 1] - q[0][..., 1]) \
        - (q[1][..., 1] - q[0][..., 1]) * (q[2][..., 0] - q[0][..., 0])
    orient = np.where(cross >= 0, 1.0, -1.0)
    total = np.zeros(q[0].shape[:-1])
    for k in range(3):
        A, B = q[k], q[(k + 1) % 3]
        d = B - A
        ln = np.hypot(d[..., 0], d[..., 1])
        ok = ln > 1e-300
        ux = np.where(ok, d[..., 0] / np.where(ok, ln, 1.0), 1.0)
        uy = np.where(ok, d[..., 1] / np.where(ok, ln, 1.0), 0.0)
        # right-hand normal (uy, -ux): the origin lies on its negative side for a CCW edge around it
        hs = A[..., 0] * uy - A[..., 1] * ux
        h = np.abs(hs)
        good = ok & (h > 1e-12)
        hh = np.where(good, h, 1.0)
        tA = A[..., 0] * ux + A[..., 1] * uy
        tB = B[..., 0] * ux + B[..., 1] * uy
        part = _wedge(hh, tB) - _wedge(hh, tA)
        total += np.where(good, np.sign(hs) * part, 0.0)
    return np.maximum(orient * total, 0.0)


# -- source elements -----------------------------------------------------------------------------

def subdivision_pattern(n: int) -> tuple[FloatArray, FloatArray]:
    """The n x n regular subdivision of a triangle: barycentric grid vertices ((n+1)(n+2)/2, 3)
    and sub-triangles as vertex indices (n*n, 3), wound like the parent."""
    ij = [(i, j) for i in range(n + 1) for j in range(n + 1 - i)]
    index = {v: k for k, v in enumerate(ij)}
    tris = []
    for i in range(n):
        for j in range(n - i):
            tris.append([index[(i, j)], index[(i + 1, j)], index[(i, j + 1)]])
            if i + j < n - 1:
                tris.append([index[(i + 1, j)], index[(i + 1, j + 1)], index[(i, j + 1)]])
    g = np.asarray(ij, np.float64) / n
    bary = np.stack([1.0 - g[:, 0] - g[:, 1], g[:, 0], g[:, 1]], 1)
    return bary, np.asarray(tris, np.int64)


def subdivide(tri_mm: FloatArray, h: float, keep: NDArray[np.bool_] | None = None
              ) -> tuple[IntArray, FloatArray, IntArray]:
    """Cut triangles (T, 3, 3) (mm) into sub-triangles of edge <= h. Returns (vertex parent (V,),
    vertex barycentrics in the parent (V, 3), element corners as vertex indices (E, 3))."""
    edges = np.linalg.norm(tri_mm[:, [1, 2, 0]] - tri_mm, axis=2).max(axis=1)
    n = np.maximum(np.ceil(edges / max(h, 1e-9)), 1).astype(np.int64)
    if keep is not None:
        n = np.where(keep, n, 0)
    vpar, vbary, elems, offset = [], [], [], 0
    for k in np.unique(n[n > 0]):
        idx = np.nonzero(n == k)[0]
        b, t = subdivision_pattern(int(k))
        vpar.append(np.repeat(idx, len(b)))
        vbary.append(np.broadcast_to(b, (len(idx),) + b.shape).reshape(-1, 3))
        base = offset + np.arange(len(idx)) * len(b)
        elems.append((base[:, None, None] + t[None]).reshape(-1, 3))
        offset += len(idx) * len(b)
    if not vpar:
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    return np.concatenate(vpar), np.concatenate(vbary), np.concatenate(elems)


class SurfaceField:
    """A field on a triangle mesh sampled on each triangle's regular n x n lattice (n = ceil(longest
    edge / h), ``subdivision_pattern``), evaluated where asked and kept: ``locate`` gives the lattice
    vertices around surface points (triangle, barycentrics) and their linear weights; ``missing`` the
    ones not evaluated yet, ``vertex_points`` where they are, ``store`` their values, ``interpolate``
    the field at the points. Lattice vertices are per triangle (those on a shared edge sit at the same
    place in both triangles, so the interpolant is continuous across edges). The truth session keeps
    the diffusion's wide part in one (issue 34): an orbit evaluates it at new lattice vertices only."""

    def __init__(self, tri_mm: FloatArray, h: float, channels: int = 3) -> None:
        tri_mm = np.asarray(tri_mm, np.float64)
        edges = np.linalg.norm(tri_mm[:, [1, 2, 0]] - tri_mm, axis=2).max(axis=1) if len(tri_mm) else np.zeros(0)
        self.h = float(h)
        self.n = np.maximum(np.ceil(edges / max(self.h, 1e-9)), 1).astype(np.int64)
        counts = (self.n + 1) * (self.n + 2) // 2
        self.offset = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        # a vertex on an edge or corner shared by triangles is one point: welded (positions equal to
        # 1e-6 of the lattice spacing), evaluated once; ``canon`` maps a lattice id to its point
        tri_id, bary = self.vertex_points(np.arange(int(self.offset[-1])))
        pos = np.einsum("nk,nkd->nd", bary, tri_mm[tri_id]) if len(tri_id) else np.zeros((0, 3))
        q = np.round(pos / max(self.h * 1e-6, 1e-12)).astype(np.int64)
        _, first, canon = np.unique(q, axis=0, return_index=True, return_inverse=True)
        self.canon = first[canon.ravel()].astype(np.int64)
        self.values = np.zeros((int(self.offset[-1]), channels))
        self.known = np.zeros(int(self.offset[-1]), bool)
        self.evaluated = 0  # points evaluated so far (welded: a shared vertex counts once)

    def __len__(self) -> int:
        return len(self.known)

    def _index(self, tri: IntArray, i: IntArray, j: IntArray) -> IntArray:
        n = self.n[tri]  # subdivision_pattern's order: (i, j) for i in 0..n, j in 0..n-i
        return self.offset[tri] + i * (n + 1) - i * (i - 1) // 2 + j

    def locate(self, tri: IntArray, bary: FloatArray) -> tuple[IntArray, FloatArray]:
        """Lattice vertex ids (N, 3) of the lattice triangle holding each point, and the point's
        barycentrics in it (N, 3): the linear interpolant's weights."""
        tri = np.asarray(tri, np.int64)
        b = np.clip(np.asarray(bary, np.float64), 0.0, None)
        b = b / np.maximum(b.sum(1, keepdims=True), 1e-300)
        n = self.n[tri]
        u, v = b[:, 1] * n, b[:, 2] * n
        i0 = np.minimum(np.floor(u), n - 1).astype(np.int64)
        j0 = np.clip(np.floor(v).astype(np.int64), 0, n - 1 - i0)
        fu, fv = u - i0, v - j0
        upper = fu + fv > 1.0
        ids = np.stack([self._index(tri, i0, j0), self._index(tri, i0 + 1, j0), self._index(tri, i0, j0 + 1)], 1)
        w = np.stack([1.0 - fu - fv, fu, fv], 1)
        if upper.any():  # the lattice triangle (i0+1, j0), (i0+1, j0+1), (i0, j0+1)
            t, a, c, e, f = tri[upper], i0[upper], j0[upper], fu[upper], fv[upper]
            ids[upper] = np.stack([self._index(t, a + 1, c), self._index(t, a + 1, c + 1), self._index(t, a, c + 1)], 1)
            w[upper] = np.stack([1.0 - f, e + f - 1.0, 1.0 - e], 1)
        return ids, np.clip(w, 0.0, 1.0)

    def missing(self, ids: IntArray) -> IntArray:
        """The points (welded lattice ids) under ``ids`` not evaluated yet."""
        u = np.unique(self.canon[np.asarray(ids).ravel()])
        return u[~self.known[u]]

    def vertex_points(self, ids: IntArray) -> tuple[IntArray, FloatArray]:
        """(triangle, barycentrics) of lattice vertices ``ids``."""
        ids = np.asarray(ids, np.int64)
        tri = np.searchsorted(self.offset, ids, side="right") - 1
        n, k = self.n[tri], ids - self.offset[tri]
        # invert k = i (n + 1) - i (i - 1) / 2 + j, 0 <= j <= n - i: the largest i with start(i) <= k
        i = np.zeros_like(k)
        for step in range(int(self.n.max(initial=1)).bit_length(), -1, -1):
            cand = i + (1 << step)
            ok = (cand <= n) & (cand * (n + 1) - cand * (cand - 1) // 2 <= k)
            i = np.where(ok, cand, i)
        j = k - (i * (n + 1) - i * (i - 1) // 2)
        g = np.stack([i, j], 1) / n[:, None]
        return tri, np.stack([1.0 - g[:, 0] - g[:, 1], g[:, 0], g[:, 1]], 1)

    def store(self, ids: IntArray, values: FloatArray) -> None:
        ids = np.asarray(ids, np.int64)
        self.values[ids] = values
        self.known[ids] = True
        self.evaluated += len(ids)

    def interpolate(self, ids: IntArray, w: FloatArray) -> FloatArray:
        c = self.canon[ids]
        if not np.all(self.known[c]):
            raise ValueError("SurfaceField.interpolate: lattice vertices not evaluated (store them first)")
        out: FloatArray = np.einsum("nk,nkc->nc", w, self.values[c])
        return out


@dataclass
class Elements:
    """Flat source elements in mm: corners (E, 3, 3), ea (E, 3) = E A (mean over the element), and
    per element centroid, unit normal, area, s2 (in-plane per-axis variance of the uniform
    triangle: trace(cov) / 2 = sum |p_k - g|^2 / 24)."""
    corners: FloatArray
    ea: FloatArray
    centroid: FloatArray = field(init=False)
    normal: FloatArray = field(init=False)
    area: FloatArray = field(init=False)
    s2: FloatArray = field(init=False)
    radius: float = field(init=False)
    split: FloatArray | None = None  # (E,) bool: a piece of an element cut along a shadow edge

    def __post_init__(self) -> None:
        c = np.asarray(self.corners, np.float64)
        self.corners = c
        self.ea = np.asarray(self.ea, np.float64).reshape(len(c), 3)
        self.split = np.zeros(len(c), bool) if self.split is None else np.asarray(self.split, bool)
        self.centroid = c.mean(axis=1)
        n = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
        ln = np.linalg.norm(n, axis=1)
        self.area = 0.5 * ln
        self.normal = n / np.maximum(ln, 1e-300)[:, None]
        d = c - self.centroid[:, None, :]
        self.s2 = (d * d).sum(axis=(1, 2)) / 24.0
        self.radius = float(np.linalg.norm(d, axis=2).max()) if len(c) else 0.0


# A triangle (a, b, c) cut by a straight line through p = a + tp (b - a) and q = a + tq (c - a):
# (a, p, q) on a's side, (p, b, c) and (p, c, q) on the other, each wound like the parent. Rows: the
# weights of a, b, c at each piece's 3 corners.
def cut_weights(tp: FloatArray, tq: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(W (M, 3 pieces, 3 corners, 3 weights of a, b, c), side (3,): 1 for a's side, 0 the other)."""
    m = len(tp)
    A = np.broadcast_to([1.0, 0.0, 0.0], (m, 3))
    B = np.broadcast_to([0.0, 1.0, 0.0], (m, 3))
    C = np.broadcast_to([0.0, 0.0, 1.0], (m, 3))
    P = np.stack([1.0 - tp, tp, np.zeros(m)], 1)
    Q = np.stack([1.0 - tq, np.zeros(m), tq], 1)
    W = np.stack([np.stack([A, P, Q], 1), np.stack([P, B, C], 1), np.stack([P, C, Q], 1)], 1)
    return W, np.array([1.0, 0.0, 0.0])


@dataclass
class Clusters:
    centroid: FloatArray
    area: FloatArray
    ea: FloatArray      # area-weighted mean E A
    s2: FloatArray      # per-axis in-plane variance
    size: float
    normal: FloatArray  # area-weighted mean unit normal


def cluster(el: Elements, voxel: float) -> Clusters:
    """Merge elements by voxel and normal octant (the two faces of a thin flap stay apart). The
    cluster's Gaussian is moment-matched to its *light* (weights area x (E A).r+g+b, as the surface
    gather's blocks): a voxel across a shadow edge puts its light where it is, not at its middle
    (an area-weighted centre moves the edge by up to a quarter voxel). Unlit clusters: by area."""
    v = np.floor(el.centroid / voxel).astype(np.int64)
    v -= v.min(axis=0)
    octant = (el.normal > 0).astype(np.int64) @ np.array([1, 2, 4])
    dims = v.max(axis=0) + 1
    key = ((v[:, 0] * dims[1] + v[:, 1]) * dims[2] + v[:, 2]) * 8 + octant
    _, inv = np.unique(key, return_inverse=True)
    n = int(inv.max()) + 1 if len(inv) else 0
    a = np.bincount(inv, el.area, n).astype(np.float64, copy=False)  # with weights: float64 already
    sa = np.maximum(a, 1e-300)
    ea = np.stack([np.bincount(inv, el.area * el.ea[:, k], n) for k in range(3)], 1) / sa[:, None]
    light = el.area * np.maximum(el.ea.sum(1), 0.0)
    lit = np.bincount(inv, light, n) > 1e-12 * np.maximum(a * np.abs(ea).sum(1), 1e-300)
    wt = np.where(lit[inv], light, el.area)
    sw = np.maximum(np.bincount(inv, wt, n), 1e-300)
    c = np.stack([np.bincount(inv, wt * el.centroid[:, k], n) for k in range(3)], 1) / sw[:, None]
    m2 = np.bincount(inv, wt * ((el.centroid ** 2).sum(1) + 2.0 * el.s2), n) / sw
    s2 = np.maximum(m2 - (c ** 2).sum(1), 0.0) / 2.0
    nrm = np.stack([np.bincount(inv, el.area * el.normal[:, k], n) for k in range(3)], 1)
    nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)[:, None]
    return Clusters(c, a, ea, s2, voxel, nrm)


@dataclass
class PointSources:
    """Infinitesimal sources (beam rays): positions (K, 3) mm and power (K, 3)."""
    position: FloatArray
    power: FloatArray


MIN_CELL = 2.0     # mm: cell of the receiver/source grid (at least the search radius)


GRID_MARGIN = 4  # cells of a kept source grid beyond the sources' far corner, for receivers there


class SourceGrid:
    """Sources binned in cells of ``cell`` mm, sorted by cell (what ``blocks`` does first): depends on
    the sources only, so a Diffusion keeps one per (sources, cell) for every receiver set it is asked
    about (stages, orbits). The cells are those ``blocks`` would make for receivers inside the
    sources' box (its origin is the sources' minimum less a cell), so the sums are the same, bit for bit."""

    def __init__(self, src: np.ndarray, cell: float):
        self.cell = float(cell)
        self.smin = src.min(0)
        self.lo = self.smin - self.cell
        ks = np.floor((src - self.lo) / self.cell).astype(np.int64)
        self.kmax = ks.max(0)
        self.dims = self.kmax + 2 + GRID_MARGIN
        skey = self.key(ks)
        self.sorder = np.argsort(skey, kind="stable")
        self.ssorted = skey[self.sorder]

    def key(self, k: np.ndarray) -> np.ndarray:
        out: np.ndarray = (k[:, 0] * self.dims[1] + k[:, 1]) * self.dims[2] + k[:, 2]
        return out

    def fits(self, x: np.ndarray) -> bool:
        """``blocks`` for receivers ``x`` makes the same cells: x is not below the sources' minimum
        (the origin would move) nor past the margin."""
        if not np.all(x.min(0) >= self.smin):
            return False
        return bool(np.all(np.floor((x.max(0) - self.lo) / self.cell) <= self.kmax + GRID_MARGIN))


def blocks(x: np.ndarray, src: np.ndarray, radius: float, normals: np.ndarray | None = None,
           grid: SourceGrid | None = None) -> Iterator[tuple[Any, ...]]:
    """Receivers and sources binned in cells of max(radius, MIN_CELL): yields, per occupied
    receiver cell, (receiver indices, source indices of the 27 cells around it, dense |x - s|^2)
    and, given source ``normals``, the dense heights (x - s).n over the sources' planes. ``grid``:
    the sources already binned (SourceGrid of ``src`` and that cell), used when it fits ``x``."""
    if len(x) == 0 or len(src) == 0:
        return
    cell = max(radius, MIN_CELL)
    if grid is not None and grid.cell == cell and grid.fits(x):
        lo, dims, sorder, ssorted, key = grid.lo, grid.dims, grid.sorder, grid.ssorted, grid.key
        kx = np.floor((x - lo) / cell).astype(np.int64)
    else:
        lo = np.minimum(x.min(0), src.min(0)) - cell
        kx = np.floor((x - lo) / cell).astype(np.int64)
        ks = np.floor((src - lo) / cell).astype(np.int64)
        dims = np.maximum(kx.max(0), ks.max(0)) + 2

        def key(k: np.ndarray) -> np.ndarray:
            out: np.ndarray = (k[:, 0] * dims[1] + k[:, 1]) * dims[2] + k[:, 2]
            return out

        skey = key(ks)
        sorder = np.argsort(skey, kind="stable")
        ssorted = skey[sorder]
    rkey = key(kx)
    rorder = np.argsort(rkey, kind="stable")
    cells, rstart = np.unique(rkey[rorder], return_index=True)
    rend = np.append(rstart[1:], len(rorder))
    offs = np.array([(dx * dims[1] + dy) * dims[2] + dz for dx in (-1, 0, 1) for dy in (-1, 0, 1)
                     for dz in (-1, 0, 1)], np.int64)
    nb = cells[:, None] + offs[None]
    st = np.searchsorted(ssorted, nb, "left")
    en = np.searchsorted(ssorted, nb, "right")
    for c in range(len(cells)):
        keep = en[c] > st[c]
        if not keep.any():
            continue
        ri = rorder[rstart[c]:rend[c]]
        sj = sorder[np.concatenate([np.arange(a, b) for a, b in zip(st[c][keep], en[c][keep])])]
        centre = x[ri[0]]
        xr = x[ri] - centre
        sr = src[sj] - centre
        d2 = np.maximum((xr * xr).sum(1)[:, None] + (sr * sr).sum(1)[None] - 2.0 * (xr @ sr.T), 0.0)
        if normals is None:
            yield ri, sj, d2
        else:
            ns = normals[sj]
            yield ri, sj, d2, xr @ ns.T - (sr * ns).sum(1)[None]


def _gauss(v: float, d2: FloatArray) -> FloatArray:
    return np.exp(-d2 / (2.0 * v)) / (2.0 * np.pi * v)


DELTA_V = 1e-4  # mm^2: a Gaussian with sigma < 0.01 mm is E A at x (it only differs within 0.05 mm of a step)
OWEN_RATIO = 8.0  # exact triangle integrals while v < 8 s^2 of the elements (moment-matching error > ~0.5 %)


class Diffusion:
    """M(x) for source elements and a sum-of-Gaussians profile (variances mm^2, weights (k, 3));
    ``h`` the element edge (mm). Receivers are surface points in mm."""

    def __init__(self, el: Elements, variances: Any, weights: Any, h: float, points: PointSources | None = None,
                 shared: dict[str, Any] | None = None) -> None:
        self.el = el
        self.h = float(h)
        self.v = np.asarray(variances, np.float64).ravel()
        self.w = np.asarray(weights, np.float64).reshape(len(self.v), 3)
        self.points = points
        self.s2max = float(el.s2.max()) if len(el.s2) else 0.0
        # what depends on the elements only (cluster levels, the KD-tree, edge frames, radii, source
        # grids), built on first use: ``shared`` lets Diffusions of the same elements with another
        # profile or other receivers (the viewer's truth session: an orbit, a profile edit) build it
        # once; ``shared["built"]`` counts what was built (tests: an orbit builds nothing)
        self._shared = {} if shared is None else shared
        self._shared.setdefault("built", {})
        self._levels: dict[float, Clusters] = self._shared.setdefault("levels", {})

    def _built(self, what: str) -> None:
        b = self._shared["built"]
        b[what] = b.get(what, 0) + 1

    def _grid(self, src: np.ndarray, cell: float) -> SourceGrid:
        grids = self._shared.setdefault("grids", {})
        k = (id(src), max(float(cell), MIN_CELL))
        g = grids.get(k)
        if g is None or g[0] is not src:
            g = grids[k] = (src, SourceGrid(src, k[1]))
            self._built("grid")
        grid: SourceGrid = g[1]
        return grid

    def method(self, v: float) -> tuple[str, float | None]:
        """('delta', None) | ('exact', None) | ('elements', None) | ('clusters', voxel)."""
        if v < DELTA_V:
            return "delta", None
        if v < OWEN_RATIO * self.s2max:
            return "exact", None
        voxel = self.h
        while voxel * 2 <= math.sqrt(v) / CLUSTER_RATIO:
            voxel *= 2
        if voxel > math.sqrt(v) / CLUSTER_RATIO:
            return "elements", None
        return "clusters", voxel

    def level(self, voxel: float) -> Clusters:
        if voxel not in self._levels:
            self._levels[voxel] = cluster(self.el, voxel)
            self._built("cluster")
        return self._levels[voxel]

    def plan(self) -> list[str]:
        out = []
        for v in self.v:
            kind, voxel = self.method(v)
            if kind == "delta":
                out.append(f"v={v:g} mm^2: delta (E A at x)")
            elif kind == "exact":
                out.append(f"v={v:g} mm^2: exact triangle integrals (Owen's T) over {len(self.el.area)} elements")
            elif kind == "elements":
                out.append(f"v={v:g} mm^2: moment-matched elements ({len(self.el.area)})")
            else:
                assert voxel is not None  # method(): "clusters" always comes with its voxel
                out.append(f"v={v:g} mm^2: moment-matched clusters of {voxel:g} mm ({len(self.level(voxel).area)})")
        return out

    def is_local(self, v: float) -> bool:
        """A Gaussian narrower than the elements ('delta', 'exact'): what it gives at x follows the
        light at x itself (E A at x, the element under x); the wider ones ('elements', 'clusters')
        blur the surface over sigma >= the element size (smooth there)."""
        return self.method(v)[0] in ("delta", "exact")

    def exitance(self, x: FloatArray, ea_here: FloatArray | None = None,
                 progress: Callable[[float], None] | None = None,
                 cancelled: Callable[[], bool] | None = None, only: Any = None) -> FloatArray:
        """M(x) (N, 3) at receivers x (N, 3) mm. ``ea_here`` (N, 3): E A at x itself, used for the
        element under x (the nearest element centroid within an element radius). ``only``: "local"
        or "wide" (``is_local``), or a collection of Gaussian indices: the sum over those Gaussians
        only (the parts of a partition add up to M)."""
        x = np.asarray(x, np.float64)
        out = np.zeros((len(x), 3))
        el = self.el
        own = None
        if ea_here is not None and len(el.area):
            ea_here = np.asarray(ea_here, np.float64)
            d, own = self.tree().query(x, k=1)
            # not a piece cut along a shadow edge: x's own value would spread to the other side
            assert el.split is not None  # Elements.__post_init__ sets it
            own = np.where((d <= el.radius * 1.01) & ~el.split[own], own, -1)
        def wanted(k: int, v: float) -> bool:
            if only is None:
                return True
            if isinstance(only, str):
                return self.is_local(v) == (only == "local")
            return k in only
        todo = [(v, w) for k, (v, w) in enumerate(zip(self.v, self.w)) if np.any(w > 0) and wanted(k, v)]
        cost = {"delta": 0.02, "exact": 1.0, "elements": 0.5, "clusters": 0.5}
        total = sum(cost[self.method(v)[0]] for v, _ in todo) or 1.0
        done = 0.0
        for v, w in todo:
            if cancelled is not None and cancelled():
                raise InterruptedError("cancelled")
            kind, voxel = self.method(v)
            m = np.zeros((len(x), 3))
            if kind == "delta":
                if ea_here is not None:
                    m += ea_here
                elif len(el.area):
                    m += el.ea[self.tree().query(x, k=1)[1]]
            elif kind == "exact":
                r = TRUNCATE * math.sqrt(v) + self._el_radius()
                for i, j in self._tree_pairs(x, r):
                    k = self._exact(x[i], j, v)
                    val = el.ea[j]
                    if own is not None and ea_here is not None:
                        val = np.where((own[i] == j)[:, None], ea_here[i], val)
                    m += _accumulate(i, k[:, None] * val, len(x))
                    if cancelled is not None and cancelled():
                        raise InterruptedError("cancelled")
            else:
                src: Elements | Clusters
                if kind == "elements":
                    src = el

                else:
                    assert voxel is not None  # method(): "clusters" always comes with its voxel
                    src = self.level(voxel)
                reach = TRUNCATE * math.sqrt(v + float(src.s2.max())) + (voxel or self.h) * 1.8
                for ri, sj, d2, z in blocks(x, src.centroid, reach, src.normal, self._grid(src.centroid, reach)):
                    # moment matching in the source's plane only; the height z over it enters
                    # exactly, exp(-z^2 / 2v) (eq. 20 is separable): a flap's far side stays right
                    ve = v + src.s2[sj]
                    z2 = z * z
                    k = np.exp(-np.maximum(d2 - z2, 0.0) / (2.0 * ve) - z2 / (2.0 * v)) \
                        * (src.area[sj] / (2.0 * np.pi * ve))
                    m[ri] += k @ src.ea[sj]
                    if cancelled is not None and cancelled():
                        raise InterruptedError("cancelled")
            if self.points is not None and len(self.points.position):
                for s0 in range(0, len(x), 4096):
                    xs = x[s0:s0 + 4096]
                    d2 = ((xs[:, None, :] - self.points.position[None]) ** 2).sum(-1)
                    m[s0:s0 + 4096] += _gauss(v, d2) @ self.points.power
            out += m * w
            done += cost[kind]
            if progress is not None:
                progress(done / total)
        return out

    def tree(self) -> cKDTree:
        if "tree" not in self._shared:
            self._shared["tree"] = cKDTree(self.el.centroid)
            self._built("tree")
        return self._shared["tree"]

    def _tree_pairs(self, x: FloatArray, radius: FloatArray, chunk: int = 8192) -> Iterator[tuple[IntArray, IntArray]]:
        """(receiver, element) pairs closer than the element's ``radius`` (KD-trees: for small radii)."""
        rmax = float(radius.max())
        for s0 in range(0, len(x), chunk):
            sm = cKDTree(x[s0:s0 + chunk]).sparse_distance_matrix(self.tree(), rmax, output_type="ndarray")
            keep = sm["v"] < radius[sm["j"]]
            yield sm["i"][keep].astype(np.int64) + s0, sm["j"][keep].astype(np.int64)

    def _el_radius(self) -> FloatArray:
        """Per element: the largest corner distance from its centroid."""
        if "radius" not in self._shared:
            d = self.el.corners - self.el.centroid[:, None]
            self._shared["radius"] = np.sqrt((d * d).sum(2).max(1))
            self._built("radius")
        radius: FloatArray = self._shared["radius"]
        return radius

    def _edge_data(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Per element: 2D frame (e1, e2), corners in it (relative to corner 0), and per edge the
        unit direction u and right-hand normal (u_y, -u_x)."""
        if "edges" not in self._shared:
            c = self.el.corners
            e1 = c[:, 1] - c[:, 0]
            e1 /= np.maximum(np.linalg.norm(e1, axis=1), 1e-300)[:, None]
            e2 = np.cross(self.el.normal, e1)
            rel = c - c[:, :1]
            q = np.stack([(rel * e1[:, None]).sum(2), (rel * e2[:, None]).sum(2)], 2)  # (E, 3, 2)
            d = q[:, [1, 2, 0]] - q
            ln = np.maximum(np.linalg.norm(d, axis=2), 1e-300)
            u = d / ln[..., None]
            self._shared["edges"] = (e1, e2, q, u)
            self._built("edges")
        edges: tuple[FloatArray, FloatArray, FloatArray, FloatArray] = self._shared["edges"]
        return edges

    def _exact(self, x: FloatArray, j: IntArray, v: float) -> FloatArray:
        """integral over element j of G(v, |x - y|) dA(y), exactly: Owen's T over the flat triangle
        (gaussian_triangle_mass, in units of sigma around x's foot point) times exp(-z^2 / 2v) for x's
        height z over its plane (eq. 20 is separable)."""
        e1, e2, q, _ = self._edge_data()
        s = math.sqrt(v)
        d = x - self.el.corners[j, 0]
        z = (d * self.el.normal[j]).sum(1)
        p = np.stack([(d * e1[j]).sum(1), (d * e2[j]).sum(1)], 1)
        qj = q[j]
        mass = gaussian_triangle_mass((qj[:, 0] - p) / s, (qj[:, 1] - p) / s, (qj[:, 2] - p) / s)
        out: FloatArray = mass * np.exp(-z * z / (2.0 * v))
        return out


def _accumulate(i: IntArray, vals: FloatArray, n: int) -> FloatArray:
    return np.stack([np.bincount(i, vals[:, c], n) for c in range(vals.shape[1])], 1)


def gaussian_disc_convolution(r: FloatArray, v: float, radius: float, n: int = 48) -> FloatArray:
    """(G(v) * disc)(r): the integral of G(v, |p - (r, 0)|) over the disc of ``radius`` at the
    origin (n x n polar Gauss-Legendre rule); the analytic reference of a laser beam."""
    t, wt = np.polynomial.legendre.leggauss(n)
    rho = 0.5 * radius * (t + 1.0)
    phi = np.pi * (t + 1.0)
    R, P = np.meshgrid(rho, phi, indexing="ij")
    W = ((0.5 * radius * wt)[:, None] * (np.pi * wt)[None, :]) * R
    px, py = (R * np.cos(P)).ravel(), (R * np.sin(P)).ravel()
    r = np.asarray(r, np.float64)
    flat = r.ravel()
    out = np.empty(flat.shape)
    for s0 in range(0, len(flat), 2048):
        rr = flat[s0:s0 + 2048, None]
        d2 = (rr - px[None]) ** 2 + py[None] ** 2
        out[s0:s0 + 2048] = (np.exp(-d2 / (2 * v)) / (2 * np.pi * v)) @ W.ravel()
    return out.reshape(r.shape)
