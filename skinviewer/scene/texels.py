"""Texels as surface samples (issue 10, seam-aware diffusion), plain numpy:

* :func:`texel_surface` rasterises a mesh in texture space at texel centres (the unwrap of seed 000
  eq. 8): per texel the triangle, the 3D position and the surface area (mm^2) the texel stands for.
* :func:`seam_indirection` — for each gutter texel near a UV seam, the UV of the surface point it
  stands for on the island adjacent across the seam (3D adjacency: triangles sharing a 3D edge but
  not a UV edge), so blur taps that leave an island continue on the surface.
* :func:`surface_diffusion_reference` — the brute-force 3D-distance reference of a texture-space
  diffusion: D(x) = sum_y E(y) A(y) R(|x - y|) over covered texels (R a sum of Gaussians, mm).
* :class:`SurfacePaths` — which texel pairs are joined along the surface (mesh-graph Dijkstra), so the
  reference can leave out shortcuts through air or thin tissue that no texture-space blur takes.
"""
from __future__ import annotations

import math

import numpy as np

from skinviewer.scene.mesh import WELD_TOL, border_half_edges, position_ids, weld_ids


def texel_surface(positions, uvs, indices, n: int, mm_per_unit: float = 1.0):
    """Rasterise at texel centres (GL convention: texel (i, j) at uv = ((i + .5)/n, (j + .5)/n), row
    j = v). Returns (tri (n, n) int, -1 outside), pos (n, n, 3) in mm, area (n, n) mm^2 per texel."""
    P = np.asarray(positions, np.float64) * mm_per_unit
    UV = np.asarray(uvs, np.float64) * n - 0.5
    F = np.asarray(indices, np.int64)
    tri = np.full((n, n), -1, np.int64)
    pos = np.zeros((n, n, 3))
    area = np.zeros((n, n))
    for t, (a, b, c) in enumerate(F):
        ua, ub, uc = UV[a], UV[b], UV[c]
        lo = np.floor(np.minimum(np.minimum(ua, ub), uc)).astype(int)
        hi = np.ceil(np.maximum(np.maximum(ua, ub), uc)).astype(int)
        lo = np.maximum(lo, 0)
        hi = np.minimum(hi, n - 1)
        if np.any(hi < lo):
            continue
        e1, e2 = ub - ua, uc - ua
        det = e1[0] * e2[1] - e1[1] * e2[0]
        if abs(det) < 1e-14:
            continue
        xs, ys = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
        dx, dy = xs - ua[0], ys - ua[1]
        l1 = (dx * e2[1] - dy * e2[0]) / det
        l2 = (e1[0] * dy - e1[1] * dx) / det
        l0 = 1.0 - l1 - l2
        inside = (l0 >= -1e-9) & (l1 >= -1e-9) & (l2 >= -1e-9)
        if not inside.any():
            continue
        X, Y = xs[inside], ys[inside]
        tri[Y, X] = t
        pos[Y, X] = l0[inside, None] * P[a] + l1[inside, None] * P[b] + l2[inside, None] * P[c]
        # mm^2 per texel: 3D triangle area / its texel-space area
        a3 = 0.5 * np.linalg.norm(np.cross(P[b] - P[a], P[c] - P[a]))
        area[Y, X] = a3 / (0.5 * abs(det))
    return tri, pos, area


def surface_diffusion_reference(E, pos, area, covered, variances, weights, cutoff_sigmas: float = 3.5,
                                block: int = 8192, normals=None, air_sin: float = 0.5,
                                surface_paths: SurfacePaths | None = None, shortcuts_add: bool = False) -> np.ndarray:
    """D(x) = sum_i w_i [sum_y E(y) A(y) G(v_i, |x - y|)] / [sum_y A(y) G(v_i, |x - y|)] over covered
    texels x, y (3D distance in mm). The normalisation makes each Gaussian a weighted mean of E, so a
    Gaussian narrower than a texel (skin's first, sigma 0.08 mm) is the identity instead of a
    point-sampled spike, and equals the plain sum on flat, closed, well-sampled surfaces. E (n, n, 3);
    returns (n, n, 3), 0 outside ``covered``.
    ``normals`` (n, n, 3) outward unit normals: pairs whose straight path crosses air do not couple
    (tissue paths only): the other point in front of x's tangent plane while the normals face each other
    (opposite walls: lips or eyelids touching, a nostril), or more than ``air_sin`` x r in front of either
    tangent plane (a deep cavity). Mild concavities and thin parts (the other point behind) still couple.
    ``surface_paths`` (SurfacePaths of the same texels): only pairs joined by a path along the surface
    not much longer than their 3D distance couple: what a texture-space blur computes, without the
    shortcuts through air or through thin tissue (lips, lids, ears: the TSM's part, eq. 32-33).
    ``shortcuts_add`` (with ``surface_paths``): the other pairs still add their light, but only the
    pairs joined along the surface normalise: the normalisation corrects the sampling of x's own
    sheet, and light reaching it across a contact or a fold adds to it as in the ground truth's sum
    over the whole surface (eq. 21), instead of being averaged with it."""
    from scipy.spatial import cKDTree  # here, not at import: scipy costs the viewer's start (issue 34)
    v = np.asarray(variances, np.float64)
    w = np.asarray(weights, np.float64).reshape(len(v), 3)
    idx = np.flatnonzero(covered.ravel())
    X = pos.reshape(-1, 3)[idx]
    a = area.ravel()[idx]
    src = np.asarray(E, np.float64).reshape(-1, 3)[idx] * a[:, None]
    Nrm = None if normals is None else np.asarray(normals, np.float64).reshape(-1, 3)[idx]
    tree = cKDTree(X)
    out = np.zeros((len(idx), 3))
    for vi, wi in zip(v, w):
        if not (vi > 0) or not np.any(wi != 0):
            continue
        rmax = cutoff_sigmas * float(np.sqrt(vi))
        for s in range(0, len(idx), block):
            m = min(block, len(idx) - s)
            pairs = cKDTree(X[s:s + m]).sparse_distance_matrix(tree, rmax, output_type="ndarray")
            i, j, r = pairs["i"], pairs["j"], pairs["v"]  # self pairs (r = 0) included
            if Nrm is not None:
                d = X[j] - X[s + i]
                up_i, up_j = (d * Nrm[s + i]).sum(1), (-d * Nrm[j]).sum(1)  # height above each tangent plane
                facing = (Nrm[s + i] * Nrm[j]).sum(1) < 0.0  # opposite walls of a gap
                air = ((up_i > 0.0) & facing) | (up_i > air_sin * r) | (up_j > air_sin * r)
                i, j, r = i[~air], j[~air], r[~air]
            along = np.ones(len(i), bool)
            if surface_paths is not None:
                along = surface_paths.connected(idx[s + i], idx[j], r)
                if not shortcuts_add:
                    i, j, r, along = i[along], j[along], r[along], along[along]
            k = np.exp(-r * r / (2 * vi))
            den = np.bincount(i, k * a[j] * along, minlength=m)
            for c in range(3):
                if wi[c] != 0:
                    out[s:s + m, c] += wi[c] * np.bincount(i, k * src[j, c], minlength=m) / np.maximum(den, 1e-300)
    D = np.zeros(E.shape[:2] + (3,))
    D.reshape(-1, 3)[idx] = out
    return D


JUDGE_LEVEL = 4   # supersampling level of the converged judge (see supersampled_diffusion_reference)


def judge_factors(variances, texel_mm: float, level: int) -> list[int]:
    """Samples per texel side for each Gaussian at a judge ``level``: about ``level`` samples per
    texel or per sigma, whichever is finer, at least 2 (never the texel grid itself), at most 2 level."""
    return [int(min(2 * level, max(2, math.ceil(level * texel_mm / math.sqrt(max(v, 1e-12))))))
            for v in np.asarray(variances, np.float64).ravel()]


def covered_bilinear(E: np.ndarray, covered: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """E (n, n, C) at the centres of a k-times finer grid (nk, nk): bilinear between the texel centres,
    over covered texels only (weights renormalised; nothing from outside an island). Returns (values,
    has any covered neighbour)."""
    n = E.shape[0]
    c = (np.arange(n * k) + 0.5) / k - 0.5
    i0 = np.floor(c).astype(np.int64)
    f = c - i0
    num = np.zeros((n * k, n * k, E.shape[2]))
    den = np.zeros((n * k, n * k))
    cov = covered.astype(np.float64)
    for dy in (0, 1):
        wy = (f if dy else 1 - f)[:, None]
        iy = np.clip(i0 + dy, 0, n - 1)
        for dx in (0, 1):
            wx = (f if dx else 1 - f)[None, :]
            ix = np.clip(i0 + dx, 0, n - 1)
            w = wy * wx * cov[np.ix_(iy, ix)]
            num += w[..., None] * E[np.ix_(iy, ix)]
            den += w
    return num / np.maximum(den, 1e-300)[..., None], den > 0


def covered_bilinear_at(E: np.ndarray, covered: np.ndarray, py: np.ndarray, px: np.ndarray):
    """E (n, n, C) bilinear at fractional texel coordinates (py, px) (texel centres at integers), over
    covered texels only (weights renormalised). Returns (values (..., C), has a covered neighbour)."""
    n = E.shape[0]
    y0, x0 = np.floor(py).astype(np.int64), np.floor(px).astype(np.int64)
    fy, fx = py - y0, px - x0
    num = np.zeros(py.shape + (E.shape[2],))
    den = np.zeros(py.shape)
    for dy in (0, 1):
        for dx in (0, 1):
            yy, xx = y0 + dy, x0 + dx
            inside = (yy >= 0) & (yy < n) & (xx >= 0) & (xx < n)
            yc, xc = np.clip(yy, 0, n - 1), np.clip(xx, 0, n - 1)
            w = (fy if dy else 1 - fy) * (fx if dx else 1 - fx) * (inside & covered[yc, xc])
            num += w[..., None] * E[yc, xc]
            den += w
    return num / np.maximum(den, 1e-300)[..., None], den > 1e-12


class MapIrradiance:
    """E from the technique's own map: bilinear between its texel centres over covered texels (the
    seam judge's E until issue 30 item 4; it shares the technique's shadow and its texel sampling)."""

    def __init__(self, E: np.ndarray, covered: np.ndarray):
        self.E, self.cov = E, covered

    def at(self, py: np.ndarray, px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return covered_bilinear_at(self.E, self.cov, py, px)

    def grid(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        return covered_bilinear(self.E, self.cov, k)


def uv_locate(uvs, indices, n: int, py: np.ndarray, px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The triangle and barycentrics of the surface point at fractional texel coordinates (py, px) of
    an n^2 map (texel centres at integers, texel_surface's convention): (tri (...,) int, -1 off the
    islands; bary (..., 3)). Candidates per texel cell from the triangles' UV bounding boxes."""
    UV = np.asarray(uvs, np.float64) * n - 0.5
    F = np.asarray(indices, np.int64).reshape(-1, 3)
    ua, ub, uc = UV[F[:, 0]], UV[F[:, 1]], UV[F[:, 2]]
    e1, e2 = ub - ua, uc - ua
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    good = np.abs(det) > 1e-14
    lo = np.clip(np.floor(np.minimum(np.minimum(ua, ub), uc) + 0.5).astype(np.int64), 0, n - 1)
    hi = np.clip(np.floor(np.maximum(np.maximum(ua, ub), uc) + 0.5).astype(np.int64), 0, n - 1)
    tris, cells = [], []
    for t in np.flatnonzero(good & np.all(hi >= lo, axis=1)):
        ys, xs = np.meshgrid(np.arange(lo[t, 1], hi[t, 1] + 1), np.arange(lo[t, 0], hi[t, 0] + 1), indexing="ij")
        cells.append((ys * n + xs).ravel())
        tris.append(np.full(ys.size, t))
    shape = np.shape(py)
    qy, qx = np.asarray(py, np.float64).ravel(), np.asarray(px, np.float64).ravel()
    tri = np.full(qy.size, -1, np.int64)
    bary = np.zeros((qy.size, 3))
    if not tris:
        return tri.reshape(shape), bary.reshape(shape + (3,))
    cell_of, tri_of = np.concatenate(cells), np.concatenate(tris)
    order = np.argsort(cell_of, kind="stable")
    cell_of, tri_of = cell_of[order], tri_of[order]
    start = np.searchsorted(cell_of, np.arange(n * n))
    count = np.searchsorted(cell_of, np.arange(n * n), side="right") - start
    cy = np.clip(np.floor(qy + 0.5).astype(np.int64), 0, n - 1)
    cx = np.clip(np.floor(qx + 0.5).astype(np.int64), 0, n - 1)
    c = cy * n + cx
    s0, cnt = start[c], count[c]
    for j in range(int(cnt.max(initial=0))):
        q = np.flatnonzero((tri < 0) & (cnt > j))
        if len(q) == 0:
            break
        t = tri_of[s0[q] + j]
        dx, dy = qx[q] - ua[t, 0], qy[q] - ua[t, 1]
        l1 = (dx * e2[t, 1] - dy * e2[t, 0]) / det[t]
        l2 = (e1[t, 0] * dy - e1[t, 1] * dx) / det[t]
        l0 = 1.0 - l1 - l2
        inside = (l0 >= -1e-9) & (l1 >= -1e-9) & (l2 >= -1e-9)
        tri[q[inside]] = t[inside]
        bary[q[inside]] = np.stack([l0, l1, l2], 1)[inside]
    return tri.reshape(shape), bary.reshape(shape + (3,))


RAY_LEVEL = 5   # RayCastIrradiance's level (ray_resolution): visibility every 3 sigma_min / RAY_LEVEL, nodes twice that


def ray_resolution(level: int, texel_mm: float, sigma_mm: float) -> tuple[int, int]:
    """(k_u, k_v) of RayCastIrradiance, samples per texel side: the visibility in the band every
    3 sigma / level (sigma the narrowest Gaussian's: its edge is what the judge must resolve), the nodes
    (unshadowed E, and the visibility that finds the band) every 6 sigma / level, at least ``level``."""
    kv = max(2 * level, int(math.ceil(level * texel_mm / (3.0 * sigma_mm))))
    return max(level, int(math.ceil(kv / 2))), kv


class RayCastIrradiance:
    """E(y) for the seam judge that shares no shadow with the technique (issue 30 item 4):
    E(y) = sum over lights of U_l(y) V_l(y), U the unshadowed irradiance (Lc (N.L)+ rho_dt C^mix with the
    surface's own normal map: eq. 28, 32) and V the ray-cast visibility at the surface point y itself,
    both from the caller's ``parts(tri, bary) -> (U (L, N, 3), V (L, N) bool)`` and ``visible(tri, bary)
    -> V (L, N)`` (engine.reference.Surface: Embree). Nothing is read from the technique's maps.

    Rays where visibility can change only: U and V at k_u points per texel side (the nodes; U bilinear
    between them over the nodes on the surface); a texel whose nodes or their neighbours disagree on V
    (a shadow boundary passes), and ``band`` texels around it, gets V at k_v points per side (bilinear
    between them), every other texel the value its nodes agree on. (k_u, k_v) = ray_resolution(level,
    texel_mm, sigma_mm): set by the narrowest Gaussian, not by the map. Converged when one level finer
    moves the judge's figures by < 10 % of themselves (tests/test_fidelity.py,
    benchmarks/bench_fidelity.py --parts seams --seams-ray-cast)."""

    def __init__(self, uvs, indices, n: int, covered: np.ndarray, parts, visible, texel_mm: float,
                 sigma_mm: float, level: int = RAY_LEVEL, band: int = 1, chunk: int = 262144):
        from scipy import ndimage  # here, not at import: scipy costs the viewer's start (issue 34)
        self.n = n
        self.ku, self.kv = ray_resolution(level, texel_mm, sigma_mm)
        ku, kv = self.ku, self.kv
        m = n * ku
        near_cov = ndimage.binary_dilation(covered, iterations=2)
        c = (np.arange(m) + 0.5) / ku - 0.5  # node coordinates in texels
        ny, nx = np.nonzero(np.repeat(np.repeat(near_cov, ku, 0), ku, 1))
        tri, bary = uv_locate(uvs, indices, n, c[ny], c[nx])
        on = tri >= 0
        ny, nx, tri, bary = ny[on], nx[on], tri[on], bary[on]
        self.node_ok = np.zeros((m, m), bool)
        self.node_ok[ny, nx] = True
        U_parts, V_parts = [], []
        for s in range(0, len(tri), chunk):
            u, v = parts(tri[s:s + chunk], bary[s:s + chunk])
            U_parts.append(np.asarray(u, np.float32))
            V_parts.append(np.asarray(v, bool))
        nl = U_parts[0].shape[0] if U_parts else 0
        self.U = np.zeros((nl, m, m, 3), np.float32)
        self.V = np.ones((nl, m, m), bool)
        if nl:
            self.U[:, ny, nx] = np.concatenate(U_parts, 1)
            self.V[:, ny, nx] = np.concatenate(V_parts, 1)
        self.rays = len(tri) * nl
        # texels a shadow boundary may cross: their nodes, or a neighbour node, disagree on V
        mixed = np.zeros((m, m), bool)
        for li in range(nl):
            hi = ndimage.maximum_filter(np.where(self.node_ok, self.V[li], False), 3)
            lo = ndimage.minimum_filter(np.where(self.node_ok, self.V[li], True), 3)
            mixed |= self.node_ok & (hi != lo)
        mixed_t = mixed.reshape(n, ku, n, ku).any((1, 3))
        self.band = ndimage.binary_dilation(mixed_t, iterations=band) & near_cov if mixed_t.any() else mixed_t
        by, bx = np.nonzero(self.band)
        self.block_of = np.full((n, n), -1, np.int64)
        self.block_of[by, bx] = np.arange(len(by))
        sub = (np.arange(kv) + 0.5) / kv - 0.5
        qy = (by[:, None, None] + sub[None, :, None] + 0.0 * sub[None, None, :]).ravel()
        qx = (bx[:, None, None] + 0.0 * sub[None, :, None] + sub[None, None, :]).ravel()
        tri, bary = uv_locate(uvs, indices, n, qy, qx)
        on = tri >= 0
        Vb = self._nearest_node_v(qy, qx)  # off the surface: the nearest node's (U is 0 there anyway)
        idx = np.flatnonzero(on)
        for s in range(0, len(idx), chunk):
            q = idx[s:s + chunk]
            Vb[:, q] = np.asarray(visible(tri[q], bary[q]), bool)
        self.rays += len(idx) * nl
        self.Vb = Vb.reshape(nl, len(by), kv, kv)

    def _nearest_node_v(self, py: np.ndarray, px: np.ndarray) -> np.ndarray:
        m = self.n * self.ku
        iy = np.clip(np.floor((py + 0.5) * self.ku).astype(np.int64), 0, m - 1)
        ix = np.clip(np.floor((px + 0.5) * self.ku).astype(np.int64), 0, m - 1)
        return self.V[:, iy, ix]

    def _fine_v(self, fy: np.ndarray, fx: np.ndarray) -> np.ndarray:
        """V (L, ...) at the fine sample (fy, fx) of the (n kv)^2 grid: ray-cast in a band texel, else
        the value the texel's nodes agree on."""
        n, kv = self.n, self.kv
        fy, fx = np.clip(fy, 0, n * kv - 1), np.clip(fx, 0, n * kv - 1)
        ty, tx = fy // kv, fx // kv
        b = self.block_of[ty, tx]
        inb = b >= 0
        V = self._nearest_node_v((fy + 0.5) / kv - 0.5, (fx + 0.5) / kv - 0.5).astype(np.float64)
        if inb.any():
            V[:, inb] = self.Vb[:, b[inb], fy[inb] - ty[inb] * kv, fx[inb] - tx[inb] * kv]
        return V

    def visibility(self, py: np.ndarray, px: np.ndarray) -> np.ndarray:
        """V (L, ...) at fractional texel coordinates: bilinear between the fine samples (a hard edge
        becomes a ramp one fine sample wide, whose mean under a Gaussian is the step's to second order)."""
        kv = self.kv
        fy, fx = (np.asarray(py, np.float64) + 0.5) * kv - 0.5, (np.asarray(px, np.float64) + 0.5) * kv - 0.5
        y0, x0 = np.floor(fy).astype(np.int64), np.floor(fx).astype(np.int64)
        wy, wx = fy - y0, fx - x0
        V = np.zeros((len(self.U),) + np.shape(fy))
        for dy in (0, 1):
            for dx in (0, 1):
                V += ((wy if dy else 1 - wy) * (wx if dx else 1 - wx))[None] * self._fine_v(y0 + dy, x0 + dx)
        return V

    def at(self, py: np.ndarray, px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """E at fractional texel coordinates (texel centres at integers): (values (..., 3), on the surface)."""
        py, px = np.asarray(py, np.float64), np.asarray(px, np.float64)
        ku = self.ku
        V = self.visibility(py, px)
        qy, qx = (py + 0.5) * ku - 0.5, (px + 0.5) * ku - 0.5  # node coordinates
        out = np.zeros(py.shape + (3,))
        near = np.zeros(py.shape, bool)
        for li in range(len(self.U)):
            u, near = covered_bilinear_at(self.U[li], self.node_ok, qy, qx)
            out += u * V[li][..., None]
        return out, near

    def grid(self, k: int, rows: int = 256) -> tuple[np.ndarray, np.ndarray]:
        """E at the centres of a k-times finer grid (nk, nk), as covered_bilinear."""
        m = self.n * k
        c = (np.arange(m) + 0.5) / k - 0.5
        out = np.zeros((m, m, 3))
        near = np.zeros((m, m), bool)
        for r0 in range(0, m, rows):
            py, px = np.meshgrid(c[r0:r0 + rows], c, indexing="ij")
            out[r0:r0 + rows], near[r0:r0 + rows] = self.at(py, px)
        return out, near


def _texel_jacobian(pos: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dP/d(column), dP/d(row) per texel (mm per texel): central differences over covered
    neighbours, one-sided where one side is not covered."""
    out = []
    for ax in (1, 0):
        f = np.roll(pos, -1, axis=ax)
        b = np.roll(pos, 1, axis=ax)
        cf = np.roll(cov, -1, axis=ax)
        cb = np.roll(cov, 1, axis=ax)
        if ax == 1:
            cf[:, -1] = False
            cb[:, 0] = False
        else:
            cf[-1, :] = False
            cb[0, :] = False
        d = np.where((cf & cb)[..., None], 0.5 * (f - b), np.where(cf[..., None], f - pos,
                                                                   np.where(cb[..., None], pos - b, 0.0)))
        out.append(d)
    return out[0], out[1]


def _narrow_local(irr, cov, pos, ridx, v: float, level: int, cutoff_sigmas: float, block: int = 1024):
    """A Gaussian narrower than half a texel: the normalised mean of E (``irr.at``: the map bilinear over
    covered texels, or RayCastIrradiance) over x's tangent plane, sum G(|t|) E(x + t) / sum G(|t|), by a
    square grid of spacing sigma / level out to cutoff_sigmas sigma, mapped to texel offsets through the
    texel's Jacobian (exact inside a triangle). Points off the islands are left out."""
    n = cov.shape[0]
    Ju, Jv = _texel_jacobian(pos, cov)
    Ju, Jv = Ju.reshape(-1, 3)[ridx], Jv.reshape(-1, 3)[ridx]
    s = math.sqrt(v)
    m = int(math.ceil(cutoff_sigmas * level))
    a = np.arange(-m, m + 1) * (s / level)
    T1, T2 = np.meshgrid(a, a)
    T1, T2 = T1.ravel(), T2.ravel()
    g = np.exp(-(T1 * T1 + T2 * T2) / (2 * v))
    keep = T1 * T1 + T2 * T2 <= (cutoff_sigmas * s) ** 2
    T1, T2, g = T1[keep], T2[keep], g[keep]
    out = np.zeros((len(ridx), 3))
    rows, cols = np.divmod(ridx, n)
    for s0 in range(0, len(ridx), block):
        sl = slice(s0, s0 + block)
        ju, jv = Ju[sl], Jv[sl]
        nu = np.linalg.norm(ju, axis=1)
        ok = (nu > 0) & (np.linalg.norm(jv, axis=1) > 0)
        e1 = ju / np.where(nu > 0, nu, 1.0)[:, None]
        nrm = np.cross(ju, jv)
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1), 1e-300)[:, None]
        e2 = np.cross(nrm, e1)
        # t = M d: the tangent-plane offset of a texel offset d = (d_col, d_row); d = M^-1 t
        m11, m12 = (e1 * ju).sum(1), (e1 * jv).sum(1)
        m21, m22 = (e2 * ju).sum(1), (e2 * jv).sum(1)
        det = m11 * m22 - m12 * m21
        ok &= np.abs(det) > 1e-12
        det = np.where(ok, det, 1.0)
        dcol = (m22[:, None] * T1[None] - m12[:, None] * T2[None]) / det[:, None]
        drow = (-m21[:, None] * T1[None] + m11[:, None] * T2[None]) / det[:, None]
        val, near = irr.at(rows[sl, None] + drow, cols[sl, None] + dcol)
        w = g[None] * near
        res = (w[..., None] * val).sum(1) / np.maximum(w.sum(1), 1e-300)[:, None]
        out[sl] = np.where(ok[:, None], res, irr.at(rows[sl].astype(np.float64), cols[sl].astype(np.float64))[0])
    return out


def supersampled_diffusion_reference(E, covered, positions, uvs, indices, n: int, mm_per_unit: float,
                                     variances, weights, level: int = JUDGE_LEVEL, receivers=None,
                                     cutoff_sigmas: float = 3.5, block: int = 2048,
                                     irradiance: MapIrradiance | RayCastIrradiance | None = None) -> np.ndarray:
    """The 3D-distance judge of a texture-space diffusion that shares no texel grid with it: D(x) at
    the covered texel centres x (or where ``receivers`` (n, n) bool) = sum_i w_i [sum_y E(y) A(y)
    G(v_i, |x - y|)] / [sum_y A(y) G(v_i, |x - y|)] with y on a grid k_i times finer than the map
    (judge_factors: k_i samples per texel side, more for the narrow Gaussians), each sample at its
    own surface point (texel_surface of the finer grid) with its own area, E bilinear between the
    map's texel centres (covered_bilinear). The normalised form as surface_diffusion_reference: each
    Gaussian is a weighted mean of E. A Gaussian narrower than half a mean texel (the finer grid would
    need more than 2 level samples per texel side) is instead integrated over x's tangent plane on a
    grid of sigma / level (_narrow_local). Converged when ``level`` + 2 changes a figure by < 10 % of
    it (tests/test_fidelity.py).
    ``irradiance``: where E(y) comes from (default MapIrradiance(E, covered): the technique's own map,
    bilinear). RayCastIrradiance: the unshadowed irradiance times ray-cast visibility at y itself, a
    judge that shares no shadow with the technique (issue 30 item 4); ``E`` is then unused."""
    from scipy.spatial import cKDTree  # here, not at import: scipy costs the viewer's start (issue 34)
    v = np.asarray(variances, np.float64).ravel()
    w = np.asarray(weights, np.float64).reshape(len(v), 3)
    tri, pos, area = texel_surface(positions, uvs, indices, n, mm_per_unit)
    cov = covered & (tri >= 0)
    irr = irradiance if irradiance is not None else MapIrradiance(np.asarray(E, np.float64)[..., :3], cov)
    rec = cov if receivers is None else (receivers & cov)
    ridx = np.flatnonzero(rec.ravel())
    X = pos.reshape(-1, 3)[ridx]
    texel_mm = float(np.sqrt(np.mean(area[cov]))) if cov.any() else 1.0
    out = np.zeros((len(ridx), 3))
    grid: tuple = (None, None)  # (k, (tree, A, src)): one finer grid held at a time (memory)
    for vi, wi, k in zip(v, w, judge_factors(v, texel_mm, level)):
        if not (vi > 0) or not np.any(wi != 0):
            continue
        if math.sqrt(vi) < 0.5 * texel_mm:
            out += wi[None] * _narrow_local(irr, cov, pos, ridx, float(vi), level, cutoff_sigmas)
            continue
        if grid[0] != k:
            grid = (None, None)
            ftri, fpos, farea = texel_surface(positions, uvs, indices, n * k, mm_per_unit)
            Ef, near = irr.grid(k)
            sel = np.flatnonzero(((ftri >= 0) & near).ravel())
            del ftri, near
            Y = fpos.reshape(-1, 3)[sel]
            A = farea.ravel()[sel]
            del fpos, farea
            grid = (k, (cKDTree(Y), A, Ef.reshape(-1, 3)[sel] * A[:, None]))
            del Ef, Y
        tree, A, src = grid[1]
        rmax = cutoff_sigmas * float(np.sqrt(vi))
        for s in range(0, len(ridx), block):
            m = min(block, len(ridx) - s)
            pairs = cKDTree(X[s:s + m]).sparse_distance_matrix(tree, rmax, output_type="ndarray")
            i, j, r = pairs["i"], pairs["j"], pairs["v"]
            g = np.exp(-r * r / (2 * vi))
            den = np.bincount(i, g * A[j], minlength=m)
            for c in range(3):
                if wi[c] != 0:
                    out[s:s + m, c] += wi[c] * np.bincount(i, g * src[j, c], minlength=m) / np.maximum(den, 1e-300)
    D = np.zeros((n, n, 3))
    D.reshape(-1, 3)[ridx] = out
    return D


class SurfacePaths:
    """Surface (geodesic) distances between texels, from Dijkstra on the mesh's edge graph (vertices
    welded by position, so paths cross UV seams), to tell a pair joined along the surface from one joined
    only through air or thin tissue. A texel reaches the graph through its triangle's corners; the path
    x -> corner a -> ... -> corner b -> y over-estimates the surface distance by up to the two triangles'
    sizes, so a pair couples when  path <= stretch * r + e_x + e_y  (e: the longest edge of the texel's
    triangle), or when their triangles share a corner."""

    def __init__(self, positions, indices, tri, pos, mm_per_unit: float, reach_mm: float, stretch: float = 1.5):
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import dijkstra
        P = np.asarray(positions, np.float64) * mm_per_unit
        F = np.asarray(indices, np.int64)
        wid = position_ids(P)
        nv = int(wid.max()) + 1
        Pw = np.zeros((nv, 3))
        Pw[wid] = P
        Fw = wid[F]
        a, b = Fw[:, [0, 1, 2]].ravel(), Fw[:, [1, 2, 0]].ravel()
        ln = np.linalg.norm(Pw[a] - Pw[b], axis=1)
        graph = coo_matrix((np.r_[ln, ln], (np.r_[a, b], np.r_[b, a])), shape=(nv, nv)).tocsr()
        self.stretch = float(stretch)
        self.limit = self.stretch * reach_mm + 2.0 * float(ln.max(initial=0.0))
        rows: list[np.ndarray] = []
        cols: list[np.ndarray] = []
        vals: list[np.ndarray] = []
        chunk = max(1, 20_000_000 // nv)  # rows of the dense distance block at a time (<= 160 MB)
        for s0 in range(0, nv, chunk):
            d = dijkstra(graph, indices=np.arange(s0, min(nv, s0 + chunk)), limit=self.limit)
            rr, cc = np.nonzero(np.isfinite(d))
            rows.append(rr + s0)
            cols.append(cc)
            vals.append(d[rr, cc])
        row, col, val = np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)
        self._key = row * nv + col
        order = np.argsort(self._key)
        self._key, self._val, self._nv = self._key[order], val[order], nv
        t = np.asarray(tri).ravel()
        covered = t >= 0
        corners = np.full((t.size, 3), -1, np.int64)
        corners[covered] = Fw[t[covered]]
        x = np.asarray(pos, np.float64).reshape(-1, 3)
        self._corner = corners
        self._leg = np.where(covered[:, None], np.linalg.norm(x[:, None, :] - Pw[np.maximum(corners, 0)], axis=2), np.inf)
        edges = np.linalg.norm(Pw[Fw] - Pw[np.roll(Fw, 1, axis=1)], axis=2).max(1)
        self._edge = np.where(covered, edges[np.maximum(t, 0)], 0.0)

    def _graph(self, a, b) -> np.ndarray:
        key = a * self._nv + b
        if not len(self._key):
            return np.full(key.shape, np.inf)
        k = np.minimum(np.searchsorted(self._key, key), len(self._key) - 1)
        return np.where(self._key[k] == key, self._val[k], np.inf)

    def connected(self, x, y, r) -> np.ndarray:
        """For texel indices x, y (flat) at 3D distance r (mm): joined along the surface?"""
        best = np.full(len(x), np.inf)
        for p in range(3):
            for q in range(3):
                a, b = self._corner[x, p], self._corner[y, q]
                best = np.minimum(best, self._leg[x, p] + self._graph(a, b) + self._leg[y, q])
        shared = (self._corner[x][:, :, None] == self._corner[y][:, None, :]).any((1, 2))
        return shared | (best <= self.stretch * r + self._edge[x] + self._edge[y])


def _edge_samples(ua: np.ndarray, ub: np.ndarray, step: float = 0.25):
    """Points every ``step`` (texels) along the edges ua -> ub (ends included): (points, the index
    of the edge each point lies on)."""
    seg = np.maximum(np.ceil(np.linalg.norm(ub - ua, axis=1) / step).astype(int), 1)
    rep = np.repeat(np.arange(len(ua)), seg + 1)
    tt = np.concatenate([np.linspace(0, 1, k + 1) for k in seg]) if len(seg) else np.zeros(0)
    return ua[rep] + tt[:, None] * (ub[rep] - ua[rep]), rep


def seam_edges(positions, uvs, indices):
    """Half-edges on UV seams: triangle edges whose 3D edge is shared by exactly two triangles that
    do not share it in UV. Returns (tri, corner k: the edge is (k, k+1), twin tri, twin corner) arrays."""
    P = np.asarray(positions, np.float64)
    F = np.asarray(indices, np.int64)
    scale = max(float(np.ptp(P, axis=0).max()), 1e-12)
    pid = position_ids(P)
    uid = weld_ids(np.hstack([P / scale, np.asarray(uvs, np.float64)]), WELD_TOL)
    a = F[:, [0, 1, 2]].ravel()
    b = F[:, [1, 2, 0]].ravel()
    pa, pb = pid[a], pid[b]
    key3 = np.stack([np.minimum(pa, pb), np.maximum(pa, pb)], 1)
    ua, ub = uid[a], uid[b]
    keyuv = np.stack([np.minimum(ua, ub), np.maximum(ua, ub)], 1)
    _, inv3, cnt3 = np.unique(key3, axis=0, return_inverse=True, return_counts=True)
    inv3 = inv3.ravel()
    he = np.flatnonzero(cnt3[inv3] == 2)
    order = he[np.argsort(inv3[he], kind="stable")]
    h0, h1 = order[0::2], order[1::2]
    seam = np.any(keyuv[h0] != keyuv[h1], axis=1)
    h0, h1 = h0[seam], h1[seam]
    hs = np.concatenate([h0, h1])
    tw = np.concatenate([h1, h0])
    return hs // 3, hs % 3, tw // 3, tw % 3, pid


def border_gutters(positions, uvs, indices, covered: np.ndarray, reach: float):
    """(mask, dist): ``mask`` (n, n) bool, texels within ``reach`` texels of an island's edge (inside
    or outside it) whose nearest island edge is a mesh border (a 3D edge of one triangle only); ``dist``
    (n, n) their distance to that border in texels (inf elsewhere). Beyond a border there is no
    surface, so a blur tap there should read nothing (the ground truth's integral over the surface has
    no light from there) rather than the island's edge texel repeated."""
    from scipy import ndimage  # here, not at import: scipy costs the viewer's start (issue 34)
    from scipy.spatial import cKDTree  # here, not at import: scipy costs the viewer's start (issue 34)
    n = covered.shape[0]
    out = np.zeros((n, n), bool)
    dist = np.full((n, n), np.inf)
    he = border_half_edges(positions, indices)
    if len(he) == 0 or not covered.any():
        return out, dist
    F = np.asarray(indices, np.int64).reshape(-1, 3)
    UV = np.asarray(uvs, np.float64) * n - 0.5  # texel coordinates
    pts, _ = _edge_samples(UV[F[he // 3, he % 3]], UV[F[he // 3, (he % 3 + 1) % 3]])
    # distance to the nearest island edge: from outside to an island texel, from inside to a gutter
    to_edge = np.where(covered, ndimage.distance_transform_edt(covered), ndimage.distance_transform_edt(~covered))
    gy, gx = np.nonzero(to_edge <= reach)
    if len(gx) == 0:
        return out, dist
    d, _ = cKDTree(pts).query(np.stack([gx, gy], 1).astype(np.float64), distance_upper_bound=reach + 1.0)
    near = np.isfinite(d) & (d <= to_edge[gy, gx] + 1.0)  # the nearest island edge is a border
    out[gy[near], gx[near]] = True
    dist[gy[near], gx[near]] = d[near]
    return out, dist


def seam_indirection(positions, uvs, indices, covered: np.ndarray, reach: float, mm_per_unit: float = 1.0,
                     texel_pos: np.ndarray | None = None, texel_mm: float = 1.0):
    """For every texel outside the islands within ``reach`` texels of a UV seam edge: the texel
    coordinate (x, y, float, texel centres at integers) of the surface point it stands for across
    the seam. The triangle T on this side is unfolded with its twin T' (sharing the 3D edge) into
    T's UV chart; the gutter texel's barycentrics in the unfolded T' give its UV in T''s island.
    ``texel_pos`` (texel_surface's positions, mm) enables a check that the point found lies where
    the unfolded surface says (within 1.5 texels + 25 % of the distance from the edge): the 8
    nearest seam edges are tried in turn. Returns (mapped (n, n) bool, coords (n, n, 2)); unmapped
    texels keep their nearest island texel (gutter_table)."""
    from scipy import ndimage  # here, not at import: scipy costs the viewer's start (issue 34)
    from scipy.spatial import cKDTree  # here, not at import: scipy costs the viewer's start (issue 34)
    n = covered.shape[0]
    P = np.asarray(positions, np.float64) * mm_per_unit
    UV = np.asarray(uvs, np.float64) * n - 0.5  # texel coordinates
    F = np.asarray(indices, np.int64)
    mapped = np.zeros((n, n), bool)
    coords = np.zeros((n, n, 2))
    t, k, t2, k2, pid = seam_edges(positions, uvs, indices)
    if len(t) == 0:
        return mapped, coords
    ia, ib, ic = F[t, k], F[t, (k + 1) % 3], F[t, (k + 2) % 3]
    # twin corners: the twin's vertices at the same 3D points as ia, ib, and its third vertex
    ja, jb = F[t2, k2], F[t2, (k2 + 1) % 3]
    swap = pid[ja] != pid[ia]
    ja, jb = np.where(swap, jb, ja), np.where(swap, ja, jb)
    jc = F[t2, (k2 + 2) % 3]
    Pa, Pb, Pc, Pc2 = P[ia], P[ib], P[ic], P[jc]
    e = Pb - Pa
    el = np.linalg.norm(e, axis=1)
    ok = el > 1e-12
    e = e / np.maximum(el, 1e-300)[:, None]
    # unfold c' into T's plane, on the far side of the edge from c
    along = np.einsum("ij,ij->i", Pc2 - Pa, e)
    perp = np.linalg.norm(Pc2 - Pa - along[:, None] * e, axis=1)
    wc = Pc - Pa - np.einsum("ij,ij->i", Pc - Pa, e)[:, None] * e
    wl = np.linalg.norm(wc, axis=1)
    ok &= wl > 1e-12
    # T's chart: 3D (in T's plane, coordinates along e and d) -> texel coordinates, affine
    ua, ub, uc = UV[ia], UV[ib], UV[ic]
    # local 2D coordinates of T's vertices: a = (0, 0), b = (el, 0), c = (ce, -wl)
    ce = np.einsum("ij,ij->i", Pc - Pa, e)
    L = np.stack([np.stack([el, np.zeros_like(el)], 1), np.stack([ce, -wl], 1)], 2)  # columns b-a, c-a
    U = np.stack([ub - ua, uc - ua], 2)
    det = L[:, 0, 0] * L[:, 1, 1] - L[:, 0, 1] * L[:, 1, 0]
    ok &= np.abs(det) > 1e-20
    Linv = np.stack([np.stack([L[:, 1, 1], -L[:, 0, 1]], 1), np.stack([-L[:, 1, 0], L[:, 0, 0]], 1)], 1) / \
        np.where(ok, det, 1.0)[:, None, None]
    M = np.einsum("nij,njk->nik", U, Linv)  # texel = ua + M @ local
    uc2 = ua + np.einsum("nij,nj->ni", M, np.stack([along, perp], 1))  # unfolded c' in T's chart
    # affine map T's chart -> T''s island: (ua, ub, uc2) -> (UV[ja], UV[jb], UV[jc])
    S = np.stack([ub - ua, uc2 - ua], 2)
    sdet = S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
    ok &= np.abs(sdet) > 1e-12
    Sinv = np.stack([np.stack([S[:, 1, 1], -S[:, 0, 1]], 1), np.stack([-S[:, 1, 0], S[:, 0, 0]], 1)], 1) / \
        np.where(ok, sdet, 1.0)[:, None, None]
    D2 = np.stack([UV[jb] - UV[ja], UV[jc] - UV[ja]], 2)
    A2 = np.einsum("nij,njk->nik", D2, Sinv)
    idx = np.flatnonzero(ok)
    if len(idx) == 0:
        return mapped, coords
    # sample the seam edges every 0.25 texel; each gutter texel takes its nearest seam edge
    pts, rep = _edge_samples(ua[idx], ub[idx])
    rep = idx[rep]
    dist_island, (near_y, near_x) = ndimage.distance_transform_edt(~covered, return_indices=True)
    gy, gx = np.nonzero((~covered) & (dist_island <= reach))
    if len(gx) == 0:
        return mapped, coords
    q = np.stack([gx, gy], 1).astype(np.float64)
    # in-plane direction of T' away from the edge (towards c'), for the 3D consistency check
    dprime = (Pc2 - Pa - along[:, None] * e) / np.maximum(perp, 1e-300)[:, None]
    Minv = np.linalg.pinv(M)  # texel offset -> local (along e, along d) in mm
    done = np.zeros(len(q), bool)
    tgt_all = np.zeros((len(q), 2))
    dd, nn = cKDTree(pts).query(q, k=8, distance_upper_bound=reach + 1.0)
    for c in range(dd.shape[1]):
        cand = ~done & np.isfinite(dd[:, c])
        # the nearest island boundary must be a seam edge, not an open boundary closer by
        cand &= dd[:, c] <= dist_island[gy, gx] + 1.0
        h = rep[np.minimum(nn[:, c], len(rep) - 1)]
        rel = q - ua[h]
        # beyond the edge from c (outside T), not beside it
        cross_c = (ub[h, 0] - ua[h, 0]) * (uc[h, 1] - ua[h, 1]) - (ub[h, 1] - ua[h, 1]) * (uc[h, 0] - ua[h, 0])
        cross_g = (ub[h, 0] - ua[h, 0]) * rel[:, 1] - (ub[h, 1] - ua[h, 1]) * rel[:, 0]
        cand &= np.sign(cross_g) != np.sign(cross_c)
        tgt = UV[ja][h] + np.einsum("nij,nj->ni", A2[h], rel)
        cand &= np.all((tgt >= -0.5) & (tgt <= n - 0.5), axis=1)
        ti = np.clip(np.round(tgt).astype(int), 0, n - 1)
        # landed on the other island, or within 2 texels of it (its outline is not T''s edge
        # exactly): then its nearest covered texel
        cand &= dist_island[ti[:, 1], ti[:, 0]] <= 2.0
        snap = ~covered[ti[:, 1], ti[:, 0]]
        sy, sx = near_y[ti[:, 1], ti[:, 0]], near_x[ti[:, 1], ti[:, 0]]
        tgt = np.where(snap[:, None], np.stack([sx, sy], 1).astype(np.float64), tgt)
        ti = np.where(snap[:, None], np.stack([sx, sy], 1), ti)
        if texel_pos is not None:
            loc = np.einsum("nij,nj->ni", Minv[h], rel)
            expect = Pa[h] + loc[:, :1] * e[h] + loc[:, 1:] * dprime[h]
            got = texel_pos[ti[:, 1], ti[:, 0]]
            tol = 1.5 * texel_mm + 0.25 * np.abs(loc[:, 1])
            cand &= np.linalg.norm(got - expect, axis=1) <= tol
        tgt_all[cand] = tgt[cand]
        done |= cand
    have = done
    tgt = tgt_all
    mapped[gy[have], gx[have]] = True
    coords[gy[have], gx[have]] = tgt[have]
    return mapped, coords


def border_frame(positions, uvs, indices, covered: np.ndarray, reach: float) -> np.ndarray:
    """(n, n, 4) float32, for every texel within ``reach`` texels of a mesh border of its own UV island
    (the island nearest to it, 8-connected texels): R the signed distance (texels) from the texel's
    centre to that border edge's line, > 0 inside the island, < 0 past the border; GB the edge's unit
    normal in texel coordinates pointing into the island; A 1 there, 0 elsewhere (R = 65504, no border
    near). Locally the border is a straight line s = 0 and a point of the texture at s < 0 is past the
    surface's end: what the open-border extension of the d'Eon blurs (issue 30 item 5,
    physics/open_border.py) reflects across it."""
    from scipy import ndimage  # here, not at import: scipy costs start-up (issue 34)
    n = covered.shape[0]
    out = np.zeros((n, n, 4), np.float32)
    out[..., 0] = 65504.0
    he = border_half_edges(positions, indices)
    if len(he) == 0 or not covered.any():
        return out
    F = np.asarray(indices, np.int64).reshape(-1, 3)
    UV = np.asarray(uvs, np.float64) * n - 0.5  # texel coordinates, centres at integers
    ua, ub, uc = UV[F[he // 3, he % 3]], UV[F[he // 3, (he % 3 + 1) % 3]], UV[F[he // 3, (he % 3 + 2) % 3]]
    e = ub - ua
    el = np.linalg.norm(e, axis=1)
    ok = el > 1e-9
    nrm = np.stack([-e[:, 1], e[:, 0]], 1) / np.maximum(el, 1e-300)[:, None]
    nrm *= np.where(((uc - ua) * nrm).sum(1) < 0.0, -1.0, 1.0)[:, None]  # towards the triangle's third corner
    ua, ub, nrm = ua[ok], ub[ok], nrm[ok]
    if len(ua) == 0:
        return out
    pts, rep = _edge_samples(ua, ub)
    # the island of each edge and of each texel: the 8-connected covered components (gutter_table's)
    _, (iy, ix) = ndimage.distance_transform_edt(~covered, return_indices=True)
    label, _ = ndimage.label(covered, structure=np.ones((3, 3), bool))
    zone = label[iy, ix]
    mid = np.clip(np.round((ua + ub) / 2.0).astype(int), 0, n - 1)
    edge_zone = zone[mid[:, 1], mid[:, 0]]
    pi = np.clip(np.round(pts).astype(int), 0, n - 1)
    keep_pt = edge_zone[rep] == zone[pi[:, 1], pi[:, 0]]
    pi, rep = pi[keep_pt], rep[keep_pt]
    owner = np.full((n, n), -1, np.int64)  # the border edge a texel the border passes through belongs to
    owner[pi[:, 1], pi[:, 0]] = rep
    r = int(np.ceil(reach)) + 1
    gys, gxs, hs = [], [], []
    for z in np.unique(edge_zone[rep]):  # per island: its texels' nearest border texel of its own edges
        on = owner >= 0
        on &= zone == z
        ys, xs = np.nonzero(on)
        y0, y1, x0, x1 = max(ys.min() - r, 0), min(ys.max() + r + 1, n), max(xs.min() - r, 0), min(xs.max() + r + 1, n)
        d, (ny, nx) = ndimage.distance_transform_edt(~on[y0:y1, x0:x1], return_indices=True)
        gy, gx = np.nonzero((d <= reach) & (zone[y0:y1, x0:x1] == z))
        gys.append(gy + y0)
        gxs.append(gx + x0)
        hs.append(owner[ny[gy, gx] + y0, nx[gy, gx] + x0])
    if not gys:
        return out
    gy, gx, h = np.concatenate(gys), np.concatenate(gxs), np.concatenate(hs)
    q = np.stack([gx, gy], 1).astype(np.float64)
    s = ((q - ua[h]) * nrm[h]).sum(1)
    # the texel's foot on that line must lie in its own island's zone (past a corner it may not)
    foot = np.clip(np.round(q - s[:, None] * nrm[h]).astype(int), 0, n - 1)
    have = zone[foot[:, 1], foot[:, 0]] == zone[gy, gx]
    out[gy[have], gx[have], 0] = s[have]
    out[gy[have], gx[have], 1:3] = nrm[h[have]]
    out[gy[have], gx[have], 3] = 1.0
    return out
