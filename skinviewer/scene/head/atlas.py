"""The default head's UV atlas: one texel density for every island, gutters between them.

* head band (everything below the crown cap, cut at the back of the head): u ∝ arc length around,
  v ∝ mean arc length down; it runs down to the south pole at the centre of the collar cut, so the
  mesh is closed there (its last row collapses onto one point);
* crown cap: an azimuthal-equidistant disk;
* each ear sheet: a planar island (the ear's outline plane);
* each eyeball: an azimuthal disk (cornea in the middle, the unseen back compressed to the rim).

Islands are separated by gutters that the maps fill by dilation (nearest island texel), so
bilinear filtering never reads outside skin. ``Atlas.texels`` inverts the layout: texel -> 3D.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from skinviewer.scene.head.geometry import (
    EYE_C,
    RAY_ORIGIN,
    Ear,
    cast,
    direction,
    eye_radius,
    surface_point,
)

THETA_CAP = np.radians(38.0)   # crown cap / head band boundary
POLE_CIRC = 40.0               # mm: floor of the band's UV width towards the cut's centre
UV_MARGIN = 0.012              # island distance from the atlas border
UV_GUTTER = 0.02               # between islands (20 texels at 1024²)
EYE_UV_MAX = 0.095             # largest eyeball disk radius (uv)
EYE_UV_KNEE, EYE_UV_BACK = 1.05, 0.15   # the front (α < knee) gets most of an eye's UV disk

ISLAND_GUTTER, ISLAND_BAND, ISLAND_CAP, ISLAND_EAR, ISLAND_EYE = 0, 1, 2, 3, 4


def eye_uv_radius(alpha):
    """UV disk radius (fraction of the island's) for angle alpha from the eye's axis."""
    g = lambda a: np.minimum(a, EYE_UV_KNEE) + EYE_UV_BACK * np.maximum(a - EYE_UV_KNEE, 0.0)
    return g(alpha) / g(np.pi)


def eye_uv_alpha(frac):
    """Inverse of eye_uv_radius."""
    g = frac * (EYE_UV_KNEE + EYE_UV_BACK * (np.pi - EYE_UV_KNEE))
    return np.where(g <= EYE_UV_KNEE, g, EYE_UV_KNEE + (g - EYE_UV_KNEE) / EYE_UV_BACK)


@dataclass
class EarIsland:
    ear: Ear
    front: bool
    origin: np.ndarray   # uv of the ear plane's origin
    mirror: float        # +1 / -1: u runs with or against the plane's a axis


@dataclass
class RadiusTable:
    """Skin radius along the mesh's rays (θ rows incl. the cap, φ columns), for texel lookups;
    eye windows are (θ0, θ1, φ0, φ1) boxes that are cast exactly (finer than the table)."""
    theta: np.ndarray
    phi: np.ndarray
    radius: np.ndarray
    eye_windows: list

    def point(self, theta, phi):
        ti = np.interp(theta, self.theta, np.arange(len(self.theta)))
        pj = np.interp(phi, self.phi, np.arange(len(self.phi)))
        r = ndimage.map_coordinates(self.radius, [ti, pj], order=1, mode="nearest")
        return RAY_ORIGIN + direction(theta, phi) * r[:, None]


class Atlas:
    """Layout from a coarse pass over the head: mean meridian arc length S(θ) and circumference C(θ)."""

    def __init__(self):
        th_max = np.pi   # the band runs to the south pole, closing over the collar cut
        self.th_c = np.linspace(0.0, th_max, 181)
        ph_c = np.linspace(-np.pi, np.pi, 73)
        tt, pp = np.meshgrid(self.th_c, ph_c, indexing="ij")
        pc = surface_point(tt, pp)
        # root-mean-square over the columns, so grazing columns (neck sides, nose) get more rows
        seg = np.sqrt(np.mean(np.linalg.norm(np.diff(pc, axis=0), axis=2) ** 2, axis=1))
        self.s_of_theta = np.concatenate([[0.0], np.cumsum(seg)])
        self.circumference = np.linalg.norm(np.diff(pc, axis=1), axis=2).sum(axis=1)
        # the band's UV width follows the circumference but never shrinks to nothing at the pole
        self.circ_uv = np.maximum(self.circumference, POLE_CIRC)

        # scale (uv per mm): band across the bottom, crown cap, four ear islands, two eyes on top
        self.s_cap = np.interp(THETA_CAP, self.th_c, self.s_of_theta)
        self.band_height = self.s_of_theta[-1] - self.s_cap
        self.ears = [Ear(+1.0), Ear(-1.0)]
        ear_w = 2 * (Ear.half_width(np.linspace(-1, 1, 201)).max() + 0.5)  # an ear island's width (mm)
        ear_h = 2 * Ear.HEIGHT
        self.band_width = self.circumference[self.th_c >= THETA_CAP].max()
        top_row = max(2 * self.s_cap, ear_h)
        k = min((1 - 2 * UV_MARGIN) / self.band_width,
                (1 - 2 * UV_MARGIN - UV_GUTTER) / (self.band_height + top_row),
                (1 - 2 * UV_MARGIN - 4 * UV_GUTTER) / (2 * self.s_cap + 4 * ear_w))
        self.k = k
        self.v_band_top = UV_MARGIN + k * self.band_height
        v_row = self.v_band_top + UV_GUTTER                 # bottom of the top row
        self.cap_centre = np.array([UV_MARGIN + k * self.s_cap, v_row + k * self.s_cap])

        self.ear_islands: list[EarIsland] = []
        u0 = self.cap_centre[0] + k * self.s_cap + UV_GUTTER
        for ear in self.ears:
            for front in (True, False):
                mirror = ear.side if front else -ear.side
                centre_u = u0 + 0.5 * k * ear_w
                self.ear_islands.append(EarIsland(ear, front, np.array([centre_u - mirror * k * Ear.A_C,
                                                                        v_row + 0.5 * k * ear_h]), mirror))
                u0 += k * ear_w + UV_GUTTER
        # the two eyeball disks to the right of the ears
        self.eye_uv_r = min(EYE_UV_MAX, (1 - UV_MARGIN - u0 - UV_GUTTER) / 4, (1 - UV_MARGIN - v_row) / 2)
        self.eye_centres = [np.array([u0 + self.eye_uv_r, v_row + self.eye_uv_r]),
                            np.array([u0 + 3 * self.eye_uv_r + UV_GUTTER, v_row + self.eye_uv_r])]

    # -- forward maps: 3D parameters -> uv ----------------------------------------------------
    def theta_of_s(self, s):
        return np.interp(s, self.s_of_theta, self.th_c)

    def band_uv(self, theta, phi):
        c = np.interp(theta, self.th_c, self.circ_uv)
        u = 0.5 + self.k * c * phi / (2 * np.pi)
        v = UV_MARGIN + self.k * (self.s_of_theta[-1] - np.interp(theta, self.th_c, self.s_of_theta))
        return np.stack([u, v], axis=-1)

    def cap_uv(self, theta, phi):
        rho = self.k * np.interp(theta, self.th_c, self.s_of_theta)
        return self.cap_centre + rho[..., None] * np.stack([np.sin(phi), -np.cos(phi)], axis=-1)

    def ear_uv(self, isl: EarIsland, x, y):
        a, b = isl.ear.plane(x, y)
        return isl.origin + self.k * np.stack([isl.mirror * a, b], axis=-1)

    def eye_uv(self, index: int, alpha, beta):
        return (self.eye_centres[index] + eye_uv_radius(alpha)[:, None] * self.eye_uv_r
                * np.stack([np.cos(beta), np.sin(beta)], axis=1))

    # -- inverse: texel centres -> 3D -----------------------------------------------------------
    def texels(self, res: int, table: RadiusTable):
        """Per texel: 3D point (res, res, 3), island id (ISLAND_*), (α, β) on the eyeball."""
        k = self.k
        uv = (np.stack(np.meshgrid(np.arange(res), np.arange(res), indexing="xy"), axis=-1) + 0.5) / res
        u, v = uv[..., 0], uv[..., 1]
        point = np.zeros((res, res, 3))
        island = np.zeros((res, res), dtype=np.int8)

        band = v <= self.v_band_top
        s = self.s_of_theta[-1] - (v[band] - UV_MARGIN) / k
        theta = self.theta_of_s(s)
        phi = (u[band] - 0.5) * 2 * np.pi / (k * np.interp(theta, self.th_c, self.circ_uv))
        ok = (np.abs(phi) <= np.pi) & (theta >= THETA_CAP)
        idx = np.flatnonzero(band)[ok]
        point.reshape(-1, 3)[idx] = table.point(theta[ok], phi[ok])
        # the eye windows are meshed finer than the radius table: cast their texels exactly
        th_ok, ph_ok = theta[ok], phi[ok]
        for th0, th1, ph0, ph1 in table.eye_windows:
            w = (th_ok >= th0) & (th_ok <= th1) & (ph_ok >= min(ph0, ph1)) & (ph_ok <= max(ph0, ph1))
            point.reshape(-1, 3)[idx[w]] = (RAY_ORIGIN + direction(th_ok[w], ph_ok[w])
                                            * cast(th_ok[w], ph_ok[w])[:, None])
        island.reshape(-1)[idx] = ISLAND_BAND

        d = uv - self.cap_centre
        rho = np.linalg.norm(d, axis=-1) / k
        cap = rho <= self.s_cap
        theta = self.theta_of_s(rho[cap])
        phi = np.arctan2(d[cap][:, 0], -d[cap][:, 1])
        point[cap] = table.point(theta, phi)
        island[cap] = ISLAND_CAP

        for isl in self.ear_islands:
            a = (u - isl.origin[0]) / (k * isl.mirror)
            b = (v - isl.origin[1]) / k
            x, y = isl.ear.from_plane(a, b)
            inside = (x * x + y * y <= 1.0) & (np.abs(y) <= 1.0)
            point[inside] = isl.ear.sheet(x[inside], y[inside], isl.front)
            island[inside] = ISLAND_EAR

        eye_polar = np.zeros((res, res, 2))
        for side, cuv in zip((1.0, -1.0), self.eye_centres):
            du, dv = u - cuv[0], v - cuv[1]
            frac = np.hypot(du, dv) / self.eye_uv_r
            inside = frac <= 1.0
            al = eye_uv_alpha(frac[inside])
            be = np.arctan2(dv[inside], du[inside])
            eye_polar[inside] = np.stack([al, be], axis=1)
            dirs = np.stack([side * np.sin(al) * np.cos(be), np.sin(al) * np.sin(be), np.cos(al)], axis=1)
            point[inside] = EYE_C * np.array([side, 1.0, 1.0]) + eye_radius(al)[:, None] * dirs
            island[inside] = ISLAND_EYE
        return point, island, eye_polar
