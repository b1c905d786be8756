"""Triangles of the default head: the band grid (finer over the face), finer eye windows along
the lid margins, the crown cap, the two-sheet ears and the eyeballs, with their atlas UVs."""
from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial import Delaunay

from skinviewer.scene.head.atlas import THETA_CAP, Atlas, RadiusTable
from skinviewer.scene.head.geometry import (
    EYE_C,
    EYE_R,
    RAY_ORIGIN,
    Ear,
    aperture,
    cast,
    direction,
    eye_coords,
    eye_radius,
    head_sdf,
    limbus_alpha,
    surface_point,
)
from skinviewer.scene.head.shapes import smoothstep
from skinviewer.scene.mesh import vertex_normals

EYE_SEGMENTS = {0: (16, 10), 1: (28, 15), 2: (48, 24)}   # detail -> (segments, rings) per eyeball
EYE_WINDOW: dict[str, Any] = dict(x=(14.0, 50.0), y=(-3.0, 27.0), z_min=50.0)   # band cells re-meshed around an eye


def _warp(lo, hi, n, density):
    """n samples in [lo, hi] spaced inversely to density(x) (finer where density is high)."""
    xs = np.linspace(lo, hi, 4097)
    g = density(xs)
    c = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(xs))])
    return np.interp(np.linspace(0.0, c[-1], n), c, xs)


def _warp_count(lo, hi, density, spacing_mm, mm_per_unit):
    xs = np.linspace(lo, hi, 1025)
    g = density(xs)
    integral = float(np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(xs)))
    return int(np.ceil(integral * mm_per_unit / spacing_mm)) + 1


def _disk_points(radius, spacing, with_rim=True):
    """Concentric rings of roughly `spacing` filling a disk of `radius` (centre included); the
    outermost ring is omitted when the caller supplies its own boundary."""
    pts = [np.zeros((1, 2))]
    rings = max(int(round(radius / spacing)), 1)
    for j in range(1, rings + with_rim):
        r = radius * j / rings
        n = max(int(round(2 * np.pi * r / spacing)), 6)
        a = (np.arange(n) + 0.5 * (j % 2)) * 2 * np.pi / n
        pts.append(np.stack([r * np.cos(a), r * np.sin(a)], axis=1))
    return np.concatenate(pts)


def _orient(tris, positions, outward):
    """Flip triangles whose geometric normal disagrees with the outward reference vectors."""
    p = positions[tris]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flip = np.sum(n * outward, axis=1) < 0
    tris = tris.copy()
    tris[flip] = tris[flip][:, ::-1]
    return tris


class _Parts:
    """Vertex/UV/triangle lists appended island by island (triangles in global indices)."""

    def __init__(self):
        self.positions, self.uvs, self.tris, self.base = [], [], [], 0

    def add(self, p, uv, tris_global):
        self.positions.append(p)
        self.uvs.append(uv)
        self.tris.append(tris_global)
        self.base += len(p)


def _face_rows(th):
    return 1.0 + 0.7 * smoothstep(1.0, 1.25, th) * (1 - smoothstep(2.45, 2.65, th))


def _face_cols(ph):
    return 1.0 + 0.8 * np.exp(-(ph / 0.85) ** 2)


def _band(atlas: Atlas, spacing: float):
    """The band's (θ, φ) grid: rows uniform in arc length (warped towards the face), so neck rows
    are not stretched; columns finer over the face. Also casts the cap rows of the radius table."""
    th_max = atlas.th_c[-1]
    mm_per_rad_row = atlas.band_height / (th_max - THETA_CAP)
    n_th = _warp_count(THETA_CAP, th_max, _face_rows, spacing, mm_per_rad_row)
    n_ph = _warp_count(-np.pi, np.pi, _face_cols, spacing, atlas.band_width / (2 * np.pi))
    s_rows = _warp(atlas.s_cap, atlas.s_of_theta[-1], n_th, lambda s: _face_rows(atlas.theta_of_s(s)))
    theta_b = atlas.theta_of_s(s_rows)
    phi_b = _warp(-np.pi, np.pi, n_ph, _face_cols)
    theta_top = np.linspace(0.0, THETA_CAP, max(int(np.ceil(atlas.s_cap / spacing)), 4) + 1)[:-1]
    theta_t = np.concatenate([theta_top, theta_b])
    tt, pp = np.meshgrid(theta_t, phi_b, indexing="ij")
    radius = cast(tt, pp)
    n_top = len(theta_top)
    band_p = RAY_ORIGIN + direction(tt[n_top:], pp[n_top:]) * radius[n_top:, :, None]
    band_p[-1] = band_p[-1, 0]  # the pole row: one 3D point (exactly, so normals weld there)
    return s_rows, theta_b, phi_b, band_p, atlas.band_uv(tt[n_top:], pp[n_top:]), RadiusTable(theta_t, phi_b, radius, [])


def _eye_window(atlas, side, band_p, s_rows, theta_b, phi_b, ii, spacing):
    """Re-triangulate the band cells around one eye (Delaunay in the band's (φ, s) parameters)
    over finer points, finest along the lid margins. Returns the replaced cell rectangle, the
    window's (θ, φ) box, new points, their uvs and the triangles (local: rim vertices by grid index)."""
    cell = 0.25 * (band_p[:-1, :-1] + band_p[:-1, 1:] + band_p[1:, :-1] + band_p[1:, 1:])
    (x0, x1), (y0, y1) = EYE_WINDOW["x"], EYE_WINDOW["y"]
    box = ((side * cell[..., 0] > x0) & (side * cell[..., 0] < x1) & (cell[..., 1] > y0)
           & (cell[..., 1] < y1) & (cell[..., 2] > EYE_WINDOW["z_min"]))
    ci, cj = np.nonzero(box)
    i0, i1, j0, j1 = ci.min(), ci.max() + 1, cj.min(), cj.max() + 1   # vertex index rectangle
    # local metric: mm per radian of φ and per mm of s at the window
    win = band_p[i0:i1 + 1, j0:j1 + 1]
    sx = np.linalg.norm(np.diff(win, axis=1), axis=2).mean() / np.diff(phi_b[j0:j1 + 1]).mean()
    sy = np.linalg.norm(np.diff(win, axis=0), axis=2).mean() / np.diff(s_rows[i0:i1 + 1]).mean()
    bi, bj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="ij")
    rim = (bi == i0) | (bi == i1) | (bj == j0) | (bj == j1)
    rim_xy = np.stack([phi_b[bj[rim]] * sx, s_rows[bi[rim]] * sy], axis=1)
    h = spacing * 0.2
    h_grid = min(np.diff(phi_b[j0:j1 + 1]).min() * sx, np.diff(s_rows[i0:i1 + 1]).min() * sy)
    xs = np.arange(phi_b[j0] * sx + 0.6 * h_grid, phi_b[j1] * sx - 0.6 * h_grid, h)
    ys = np.arange(s_rows[i0] * sy + 0.6 * h_grid, s_rows[i1] * sy - 0.6 * h_grid, h)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    coarse = (np.arange(len(xs))[:, None] % 3 == 0) & (np.arange(len(ys))[None, :] % 3 == 0)
    f_phi, f_s = gx.ravel() / sx, gy.ravel() / sy
    f_th = atlas.theta_of_s(f_s)
    f_p = surface_point(f_th, f_phi)
    rho, lon, lat, alpha = eye_coords(np.abs(f_p[:, 0]), f_p[:, 1], f_p[:, 2])
    near = (np.abs(aperture(rho, lon, lat)) < 1.6) & (rho < eye_radius(alpha) + 4.0)
    sel = coarse.ravel() | near
    pts = np.concatenate([rim_xy, np.stack([f_phi[sel] * sx, f_s[sel] * sy], axis=1)])
    simp = Delaunay(pts).simplices
    e1, e2 = pts[simp[:, 1]] - pts[simp[:, 0]], pts[simp[:, 2]] - pts[simp[:, 0]]
    simp = simp[np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) > 1e-6 * h * h]
    rim_ids = ii[bi[rim], bj[rim]]
    return ((i0, i1, j0, j1), (theta_b[i0], theta_b[i1], phi_b[j0], phi_b[j1]), f_p[sel],
            atlas.band_uv(f_th[sel], f_phi[sel]), simp, rim_ids)


def _head_skin(atlas: Atlas, spacing: float, parts: _Parts) -> RadiusTable:
    """Band (with its eye windows) and crown cap: one closed, outward-facing skin."""
    s_rows, theta_b, phi_b, band_p, band_uvs, table = _band(atlas, spacing)
    n_th, n_ph = band_p.shape[:2]
    ii = np.arange(n_th * n_ph).reshape(n_th, n_ph)
    q0, q1, q2, q3 = ii[:-1, :-1], ii[:-1, 1:], ii[1:, 1:], ii[1:, :-1]
    # each quad is split along its shorter 3D diagonal (long thin quads where rays graze would
    # otherwise shade as a sawtooth); the last row always along q0-q2: its (q0, q2, q3) triangles
    # have two corners on the pole (zero area) and are dropped
    flat = band_p.reshape(-1, 3)
    alt = (np.linalg.norm(flat[q1] - flat[q3], axis=-1) < np.linalg.norm(flat[q0] - flat[q2], axis=-1))
    alt[-1] = False
    a_tri = np.where(alt[..., None], np.stack([q0, q1, q3], -1), np.stack([q0, q1, q2], -1))
    b_tri = np.where(alt[..., None], np.stack([q1, q2, q3], -1), np.stack([q0, q2, q3], -1))
    band_tris = np.concatenate([a_tri.reshape(-1, 3), b_tri[:-1].reshape(-1, 3)])
    quad_i = np.concatenate([np.repeat(np.arange(n_th - 1), n_ph - 1),
                             np.repeat(np.arange(n_th - 1), n_ph - 1)[:-(n_ph - 1)]])
    quad_j = np.concatenate([np.tile(np.arange(n_ph - 1), n_th - 1), np.tile(np.arange(n_ph - 1), n_th - 2)])
    keep = np.ones(len(band_tris), bool)
    start = parts.base
    parts.positions.append(band_p.reshape(-1, 3))
    parts.uvs.append(band_uvs.reshape(-1, 2))
    parts.base += n_th * n_ph
    tris = []
    for side in (1.0, -1.0):
        (i0, i1, j0, j1), box, p, uv, simp, rim_ids = _eye_window(atlas, side, band_p, s_rows, theta_b,
                                                                 phi_b, ii, spacing)
        table.eye_windows.append(box)
        keep &= ~((quad_i >= i0) & (quad_i < i1) & (quad_j >= j0) & (quad_j < j1))
        local = np.concatenate([start + rim_ids, parts.base + np.arange(len(p))])
        tris.append(local[simp])
        parts.positions.append(p)
        parts.uvs.append(uv)
        parts.base += len(p)
    tris.insert(0, band_tris[keep] + start)

    # cap: top band row as its boundary (same 3D points), rings inside, pole in the middle
    ring_phi = phi_b[:-1]
    inner = _disk_points(atlas.s_cap, spacing, with_rim=False)
    in_phi = np.arctan2(inner[:, 0], -inner[:, 1])
    in_theta = atlas.theta_of_s(np.linalg.norm(inner, axis=1))
    cap_p = np.concatenate([band_p[0, :-1], surface_point(in_theta, in_phi)])
    cap_uvs = np.concatenate([atlas.cap_uv(np.full(len(ring_phi), THETA_CAP), ring_phi),
                              atlas.cap_uv(in_theta, in_phi)])
    tris.append(Delaunay(cap_uvs).simplices + parts.base)
    parts.positions.append(cap_p)
    parts.uvs.append(cap_uvs)
    parts.base += len(cap_p)
    all_p = np.concatenate(parts.positions)
    head_tris = np.concatenate(tris)
    parts.tris.append(_orient(head_tris, all_p, all_p[head_tris].mean(axis=1) - RAY_ORIGIN))
    return table


def _ears(atlas: Atlas, spacing: float, parts: _Parts) -> None:
    """Unit-disk rings, two sheets sharing the outermost ring. Rings from OUTER_RING outwards (the
    helix, scapha and antihelix run along them) all have the rim's point count, staggered by half a
    step ring to ring, so each band between them is one regular strip and the ridges shade smoothly
    (rings of differing counts joined by a Delaunay triangulation zig-zag across them); inner rings
    have counts proportional to their radius. Bands are zipped ring to ring, never across a ring."""
    ear_spacing = spacing * 0.54 / Ear.HEIGHT  # ears are small and curled: finer
    n_rim = max(int(round(2 * np.pi / ear_spacing)), 24)
    inner = 1.0 - Ear.RIM
    n_rings = max(int(round(inner / ear_spacing)), 1)
    radii = [inner * j / n_rings for j in range(1, n_rings + 1)]
    radii += [1.0 - Ear.RIM * (1 - f) for f in (0.45, 0.8, 0.95, 1.0)]  # dense towards the rim so it rounds
    rings = []
    for j, r in enumerate(radii):
        n = n_rim if r >= OUTER_RING else max(int(round(2 * np.pi * r / ear_spacing)), 6)
        rings.append((np.arange(n) + 0.5 * (j % 2)) * 2 * np.pi / n)
    disk_parts = [np.zeros((1, 2))]
    for r, ang in zip(radii, rings):
        disk_parts.append(np.stack([r * np.cos(ang), r * np.sin(ang)], axis=1))
    first = np.cumsum([1] + [len(a) for a in rings])
    tris = [np.stack([np.zeros(len(rings[0]), int), first[0] + np.arange(len(rings[0])),
                      first[0] + (np.arange(len(rings[0])) + 1) % len(rings[0])], axis=1)]
    for k in range(len(rings) - 1):
        tris.append(_zip_rings(rings[k], rings[k + 1], first[k], first[k + 1]))
    disk, disk_tris = np.concatenate(disk_parts), np.concatenate(tris)
    for isl in atlas.ear_islands:
        p = isl.ear.sheet(disk[:, 0], disk[:, 1], isl.front)
        ref = isl.ear.normal if isl.front else -isl.ear.normal
        t = _orient(disk_tris + parts.base, np.concatenate(parts.positions + [p]),
                    np.broadcast_to(ref, (len(disk_tris), 3)))
        parts.add(p, atlas.ear_uv(isl, disk[:, 0], disk[:, 1]), t)


OUTER_RING = 0.55  # unit-disk radius from which ear rings share the rim's point count


def _zip_rings(a: np.ndarray, b: np.ndarray, ia: int, ib: int) -> np.ndarray:
    """Triangles of the band between two closed rings of increasing angles ``a`` and ``b`` (radians,
    first vertex indices ``ia``, ``ib``): walk both rings once by angle, each step closing a triangle
    on the ring whose next point comes first. Every triangle has its corners on both rings."""
    na, nb = len(a), len(b)
    aa = np.append(a, a[0] + 2 * np.pi)
    j0 = int(np.argmin(np.abs(np.angle(np.exp(1j * (b - a[0]))))))
    bb = np.unwrap(np.append(np.roll(b, -j0), b[j0]))
    bb += 2 * np.pi * np.round((aa[0] - bb[0]) / (2 * np.pi))
    i = j = 0
    out = []
    while i < na or j < nb:
        if j >= nb or (i < na and aa[i + 1] <= bb[j + 1]):
            out.append((ia + i % na, ib + (j + j0) % nb, ia + (i + 1) % na))
            i += 1
        else:
            out.append((ia + i % na, ib + (j + j0) % nb, ib + (j + 1 + j0) % nb))
            j += 1
    return np.asarray(out, np.int64)


def _eyeballs(atlas: Atlas, detail: int, parts: _Parts) -> None:
    """Closed globes with a corneal bulge; one azimuthal UV disk each (front pole in the middle,
    the back compressed towards the rim, the back pole's ring collapsed in 3D)."""
    n_seg, n_ring = EYE_SEGMENTS[detail]
    alpha_l = limbus_alpha()
    rings = _warp(0.0, np.pi, n_ring + 1,
                  lambda al: 1.0 + 2.0 * np.exp(-((al - alpha_l) / 0.15) ** 2) + 1.5 * (al < 1.4))
    beta = np.arange(n_seg) * 2 * np.pi / n_seg
    ring_a, ring_b = np.meshgrid(rings[1:], beta, indexing="ij")
    eye_alpha = np.concatenate([[0.0], ring_a.ravel()])
    eye_beta = np.concatenate([[0.0], ring_b.ravel()])
    rr = eye_radius(eye_alpha)
    eye_dir = np.stack([np.sin(eye_alpha) * np.cos(eye_beta), np.sin(eye_alpha) * np.sin(eye_beta),
                        np.cos(eye_alpha)], axis=1)
    eye_dir[-n_seg:] = (0.0, 0.0, -1.0)  # the back pole: one 3D point
    rj = np.arange(n_seg)
    fan = np.stack([np.zeros(n_seg, int), 1 + rj, 1 + (rj + 1) % n_seg], axis=1)
    quads = []
    for r in range(n_ring - 1):
        a0, a1 = 1 + r * n_seg, 1 + (r + 1) * n_seg
        quads.append(np.stack([a0 + rj, a0 + (rj + 1) % n_seg, a1 + (rj + 1) % n_seg], axis=1))
        if r < n_ring - 2:  # the last row's other half has two corners on the back pole
            quads.append(np.stack([a0 + rj, a1 + (rj + 1) % n_seg, a1 + rj], axis=1))
    eye_tris = np.concatenate([fan] + quads)
    for index, side in enumerate((1.0, -1.0)):
        centre = EYE_C * np.array([side, 1.0, 1.0])
        p = centre + rr[:, None] * eye_dir * np.array([side, 1.0, 1.0])
        p[-n_seg:] = centre + np.array([0.0, 0.0, -EYE_R])
        t = _orient(eye_tris + parts.base, np.concatenate(parts.positions + [p]), p[eye_tris].mean(axis=1) - centre)
        parts.add(p, atlas.eye_uv(index, eye_alpha, eye_beta), t)


def welded_normals(positions, indices):
    """Smooth normals across UV seams and the ear rims: coincident vertices share one normal."""
    _, canon = np.unique(positions, axis=0, return_inverse=True)
    canon = canon.ravel()
    first = np.zeros(canon.max() + 1, dtype=np.int64)
    first[canon[::-1]] = np.arange(len(canon))[::-1]
    welded = first[canon]
    return vertex_normals(positions, welded[indices])[welded]


def tessellate(atlas: Atlas, detail: int, spacing: float):
    """(positions, normals, uvs, indices) of the whole head and the radius table for painting."""
    parts = _Parts()
    table = _head_skin(atlas, spacing, parts)
    n_skin = parts.base
    _ears(atlas, spacing, parts)
    _eyeballs(atlas, detail, parts)
    positions = np.concatenate(parts.positions)
    uvs = np.concatenate(parts.uvs)
    indices = np.concatenate(parts.tris)
    # drop vertices no triangle uses (one pole-row vertex of the band)
    used = np.zeros(len(positions), dtype=bool)
    used[indices.ravel()] = True
    remap = np.cumsum(used) - 1
    positions, uvs, indices = positions[used], uvs[used], remap[indices]
    normals = welded_normals(positions, indices)
    # the skin's normals from the implicit surface's gradient: exact where rays graze and the
    # mesh's triangles are long and thin (their averaged normals shade as streaks there)
    skin = np.arange(int(used[:n_skin].sum()))   # the skin's vertices come first (after the remap too)
    normals[skin] = _sdf_normals(positions[skin], normals[skin])
    return positions, normals, uvs, indices, table


def _sdf_normals(p, fallback, eps=0.05):
    """Normalised central-difference gradient of head_sdf at points p (fallback where degenerate)."""
    g = np.stack([head_sdf(*(p + eps * axis).T) - head_sdf(*(p - eps * axis).T) for axis in np.eye(3)], axis=-1)
    norm = np.linalg.norm(g, axis=-1, keepdims=True)
    ok = (norm[:, 0] > 1e-6) & (np.sum(g * fallback, axis=-1) > 0)
    return np.where(ok[:, None], g / np.maximum(norm, 1e-12), fallback)
