"""Environment lighting in plain numpy (issue 32): equirectangular radiance maps, the three built-in
environments, spherical-harmonic irradiance (Ramamoorthi & Hanrahan 2001), the pre-filtered
specular environment (split-sum: radiance convolved with the Kelemen/Szirmay-Kalos Beckmann lobe,
times the specular albedo 1 - rho_dt, seed 000 eq. 14-16, 30), per-vertex ambient occlusion and
bent normals by ray casting on Embree, and the Monte Carlo estimates the ground truth uses.

Conventions (shared with shaders/lib/environment.glsl): +y is up, the face looks along +z and the
default camera looks along -z. An equirect image (H, W, 3) is a panorama as seen from the head: row 0
at the zenith (theta = 0), its centre column the direction -z (what the default camera sees behind the
head), turning right (+x) as u grows: column u is at phi = 2 pi ((u + 0.5) / W) - pi, direction
(sin theta sin phi, cos theta, -sin theta cos phi). ``yaw`` (degrees) turns the environment about +y:
the radiance arriving from direction w is L(R_y(-yaw) w).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import BoolArray, Float32Array, FloatArray, IndexArray


class RayCaster(Protocol):
    """What the visibility bake and the truth need of a ray intersector (trimesh's Embree one)."""
    def intersects_any(self, ray_origins: FloatArray, ray_directions: FloatArray) -> BoolArray: ...


# weight(mu (n, T), rows) of the environment's terms (rho_dt for the truth; None: 1)
EnvWeight = Callable[[FloatArray, slice], ArrayLike]

# SH orders the irradiance supports (R&H 2001: order 2, 9 coefficients, is within 3 % of the
# exact irradiance for any environment; A_3 = 0, so order 3 adds nothing)
MAX_SH_ORDER = 2
SH_COUNT = 9
# R&H 2001 eq. 8: the clamped-cosine kernel's coefficients A_l
A_HAT = (math.pi, 2.0 * math.pi / 3.0, math.pi / 4.0)
BUILTIN_ENVIRONMENTS = ("studio", "overcast", "window")
THICK_MISS = 1e6  # bake_thickness where -N meets no surface: far beyond any profile (no transmission)
BUILTIN_SIZE = (256, 128)  # (W, H) of the generated environments
# the pre-filtered specular environment: Beckmann m of each level, one equirect level each, stacked
SPEC_LEVELS_M = (0.08, 0.15, 0.25, 0.35, 0.5, 0.7, 1.0)
SPEC_SIZE = (64, 32)  # (W, H) of each level
# the cosine-weighted mean of rho_dt over the hemisphere (eq. 32 for a whole environment):
# Gauss-Legendre nodes of int_0^1 rho_dt(mu) 2 mu d mu
_GL_X, _GL_W = np.polynomial.legendre.leggauss(3)
RHO_MU = tuple(float(x) for x in np.sqrt(0.5 * (_GL_X + 1.0)))  # mu = sqrt(t): 2 mu d mu = dt
RHO_W = tuple(float(w) for w in 0.5 * _GL_W)


# -- directions ---------------------------------------------------------------------------------

def equirect_directions(w: int, h: int) -> FloatArray:
    """(h, w, 3) unit directions of the texel centres."""
    theta = (np.arange(h) + 0.5) / h * math.pi
    phi = (np.arange(w) + 0.5) / w * 2.0 * math.pi - math.pi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    return np.stack(np.broadcast_arrays(st * np.sin(phi)[None], ct, -st * np.cos(phi)[None]), -1)


def equirect_solid_angles(w: int, h: int) -> FloatArray:
    """(h, w) exact solid angle of each texel: (2 pi / w)(cos theta_0 - cos theta_1); sums to 4 pi."""
    edges = np.cos(np.arange(h + 1) / h * math.pi)
    out: FloatArray = np.broadcast_to(((edges[:-1] - edges[1:]) * 2.0 * math.pi / w)[:, None], (h, w)).copy()
    return out


def rotate_yaw(d: FloatArray, yaw_deg: float) -> FloatArray:
    """Directions ``d`` (..., 3) turned by ``yaw_deg`` about +y (x towards -z for a positive yaw)."""
    a = math.radians(yaw_deg)
    c, s = math.cos(a), math.sin(a)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([c * x + s * z, y, -s * x + c * z], -1)


def direction_to_uv(d: FloatArray) -> FloatArray:
    """(..., 2) equirect coordinates (u, v in [0, 1], v = 0 at the zenith) of unit directions."""
    phi = np.arctan2(d[..., 0], -d[..., 2])
    theta = np.arccos(np.clip(d[..., 1], -1.0, 1.0))
    return np.stack([(phi + math.pi) / (2.0 * math.pi), theta / math.pi], -1)


def sample_equirect(img: FloatArray, d: FloatArray, yaw_deg: float = 0.0) -> FloatArray:
    """Bilinear radiance of ``img`` (H, W, 3) arriving from directions ``d`` (N, 3) (wraps in u)."""
    h, w = img.shape[:2]
    uv = direction_to_uv(rotate_yaw(d, -yaw_deg))
    x = uv[:, 0] * w - 0.5
    y = np.clip(uv[:, 1] * h - 0.5, 0.0, h - 1.0)
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0 %= w
    x1, y1 = (x0 + 1) % w, np.minimum(y0 + 1, h - 1)
    out: FloatArray = ((img[y0, x0] * (1 - fx) + img[y0, x1] * fx) * (1 - fy)
                       + (img[y1, x0] * (1 - fx) + img[y1, x1] * fx) * fy)
    return out


def downsample(img: FloatArray, max_w: int) -> FloatArray:
    """Box-filter an equirect (H, W, C) by whole factors of 2 until W <= max_w (keeps the mean)."""
    img = np.asarray(img, np.float64)
    while img.shape[1] > max_w and img.shape[0] % 2 == 0 and img.shape[1] % 2 == 0:
        img = 0.25 * (img[0::2, 0::2] + img[1::2, 0::2] + img[0::2, 1::2] + img[1::2, 1::2])
    return img


# -- built-in environments --------------------------------------------------------------------------

def _smooth_box(d: FloatArray, centre_az: float, centre_el: float, half_w: float, half_h: float,
                soft: float) -> FloatArray:
    """A soft-edged rectangle on the sphere (degrees; azimuth from +z, the face's front, towards +x):
    1 inside, a smoothstep edge ``soft`` wide."""
    az = np.degrees(np.arctan2(d[..., 0], d[..., 2]))
    el = np.degrees(np.arcsin(np.clip(d[..., 1], -1.0, 1.0)))
    daz = np.abs((az - centre_az + 180.0) % 360.0 - 180.0)
    del_ = np.abs(el - centre_el)

    def edge(x: FloatArray, half: float) -> FloatArray:
        t = np.clip((half + soft * 0.5 - x) / soft, 0.0, 1.0)
        return t * t * (3.0 - 2.0 * t)
    return edge(daz, half_w) * edge(del_, half_h)


def builtin_environment(name: str, size: tuple[int, int] = BUILTIN_SIZE) -> FloatArray:
    """One of BUILTIN_ENVIRONMENTS as linear radiance (H, W, 3) float32, made by this code:

    - ``studio``: a dark grey room, a large soft box high in front on the camera's left (the key side,
      as the three-light rig's key) and a tall strip box behind on the camera's right (a rim), a
      slightly lighter floor;
    - ``overcast``: a CIE overcast sky (luminance (1 + 2 cos theta) / 3 of the zenith's) with the sun's
      glow through the clouds high on the camera's right, over grey-green ground;
    - ``window``: a warm interior (walls and a wooden floor) with one daylit window on the camera's right.
    """
    w, h = size
    d = equirect_directions(w, h)
    y = d[..., 1]
    if name == "studio":
        L = np.empty((h, w, 3))
        L[:] = np.array([0.035, 0.035, 0.037])
        L[y < 0] = np.array([0.06, 0.055, 0.05])
        key = _smooth_box(d, -40.0, 30.0, 22.0, 18.0, 10.0)
        rim = _smooth_box(d, 140.0, 10.0, 8.0, 30.0, 6.0)
        L += key[..., None] * np.array([6.0, 5.8, 5.5]) + rim[..., None] * np.array([3.6, 3.7, 4.0])
    elif name == "overcast":
        sky = (1.0 + 2.0 * np.maximum(y, 0.0)) / 3.0
        # the sun behind the cloud deck: a soft glow high on the camera's right
        sun = np.array([math.sin(math.radians(30)) * math.cos(math.radians(50)), math.sin(math.radians(50)),
                        math.cos(math.radians(30)) * math.cos(math.radians(50))])
        ang = np.degrees(np.arccos(np.clip(d @ sun, -1.0, 1.0)))
        sky = sky + 3.0 * np.exp(-0.5 * (ang / 10.0) ** 2)
        L = sky[..., None] * np.array([0.95, 1.0, 1.08]) * 1.2
        ground = np.array([0.20, 0.21, 0.17]) * 1.2 * (7.0 / 9.0)  # 20 % of the sky's irradiance / pi
        horizon = np.clip(-y / 0.03, 0.0, 1.0)[..., None]
        L = np.where((y < 0)[..., None], L * (1 - horizon) + ground * horizon, L)
    elif name == "window":
        wall = np.array([0.085, 0.07, 0.055])  # warm, not orange: a backlit face still reads as skin
        floor = np.array([0.07, 0.052, 0.036])
        L = np.where((y < -0.05)[..., None], floor, wall) * np.ones((h, w, 3))
        win = _smooth_box(d, 70.0, 12.0, 24.0, 26.0, 5.0)
        sky = np.array([5.0, 5.2, 5.6]) + np.array([1.5, 1.0, 0.4]) * np.clip(1.0 - (d[..., 1] + 0.3) * 2, 0, 1)[..., None]
        L = L * (1 - win[..., None]) + win[..., None] * sky
        # the sunlit floor patch under the window warms the room's bounce light
        L += _smooth_box(d, 55.0, -40.0, 20.0, 10.0, 12.0)[..., None] * np.array([0.8, 0.62, 0.42])
    else:
        raise KeyError(f"unknown built-in environment {name!r} (have: {', '.join(BUILTIN_ENVIRONMENTS)})")
    return np.ascontiguousarray(L, np.float32)


# -- spherical harmonics (Ramamoorthi & Hanrahan 2001) ---------------------------------------------

def sh_basis(d: FloatArray) -> FloatArray:
    """(..., 9) the real SH basis Y_lm (l <= 2) at unit directions (R&H 2001 eq. 3 constants),
    ordered (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2) with (x, y, z) = d."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        np.full_like(x, 0.282095),
        0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3.0 * z * z - 1.0),
        1.092548 * x * z, 0.546274 * (x * x - y * y)], -1)


# -- SH transfer vectors (Sloan, Kautz & Snyder 2002, "Precomputed radiance transfer") ----------------
# Real SH of bands 0..TRANSFER_ORDER in the order of sh_basis (bands 3 and 4 appended, m = -l..l), the
# constants of Sloan's "Stupid spherical harmonics tricks" (2008) appendix; lib/sh.glsl sh25 is the twin.
TRANSFER_ORDER = 4  # bands 0..4: 25 coefficients per vertex
TRANSFER_COUNT = (TRANSFER_ORDER + 1) ** 2
# R&H 2001 eq. 8 extended: the clamped cosine's A_l (A_3 = 0, A_4 = -pi / 24)
A_HAT_4 = (math.pi, 2.0 * math.pi / 3.0, math.pi / 4.0, 0.0, -math.pi / 24.0)
TRANSFER_BAND = np.repeat(np.arange(TRANSFER_ORDER + 1), 2 * np.arange(TRANSFER_ORDER + 1) + 1)


def sh_basis25(d: np.ndarray) -> np.ndarray:
    """(..., 25) real SH Y_lm, l <= 4, at unit directions: sh_basis's 9, then bands 3 and 4 (m = -l..l)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    x2, y2, z2 = x * x, y * y, z * z
    b3 = [0.590044 * y * (3.0 * x2 - y2), 2.890611 * x * y * z, 0.457046 * y * (5.0 * z2 - 1.0),
          0.373176 * z * (5.0 * z2 - 3.0), 0.457046 * x * (5.0 * z2 - 1.0), 1.445306 * z * (x2 - y2),
          0.590044 * x * (x2 - 3.0 * y2)]
    b4 = [2.503343 * x * y * (x2 - y2), 1.770131 * y * z * (3.0 * x2 - y2), 0.946175 * x * y * (7.0 * z2 - 1.0),
          0.669047 * y * z * (7.0 * z2 - 3.0), 0.105786 * (35.0 * z2 * z2 - 30.0 * z2 + 3.0),
          0.669047 * x * z * (7.0 * z2 - 3.0), 0.473087 * (x2 - y2) * (7.0 * z2 - 1.0),
          1.770131 * x * z * (x2 - 3.0 * y2), 0.625836 * (x2 * (x2 - 3.0 * y2) - y2 * (3.0 * x2 - y2))]
    return np.concatenate([sh_basis(d), np.stack(b3 + b4, -1)], -1)


def sh_project25(img: np.ndarray, yaw_deg: float = 0.0, max_w: int = 256) -> np.ndarray:
    """(25, 3) radiance coefficients L_lm, l <= 4 (sh_project's sum with sh_basis25)."""
    img = downsample(img, max_w)
    h, w = img.shape[:2]
    d = rotate_yaw(equirect_directions(w, h), yaw_deg)
    y = sh_basis25(d) * equirect_solid_angles(w, h)[..., None]
    out: np.ndarray = np.einsum("hwk,hwc->kc", y, img)
    return out


def transfer_unoccluded(n: np.ndarray) -> np.ndarray:
    """(N, 25) the transfer vector of an unoccluded point with normal n: the clamped cosine's
    coefficients A_l Y_lm(n) (R&H 2001 eq. 8 with A_3 = 0, A_4 = -pi/24)."""
    out: np.ndarray = sh_basis25(n) * np.asarray(A_HAT_4)[TRANSFER_BAND]
    return out


def transfer_irradiance(T: np.ndarray, L_lm: np.ndarray, order: int = TRANSFER_ORDER) -> np.ndarray:
    """(N, C) the environment's irradiance through transfer vectors T (N, 25): sum_lm L_lm T_lm
    (Sloan et al. 2002 eq. 4, diffuse shadowed transfer) over bands <= ``order``, clamped at 0
    (lib/sh.glsl env_transfer)."""
    k = (order + 1) ** 2
    return np.maximum(np.asarray(T, np.float64)[:, :k] @ np.asarray(L_lm, np.float64)[:k], 0.0)


def transfer_ao(T: np.ndarray) -> np.ndarray:
    """(N,) the ambient occlusion a transfer vector holds: T_00 / (pi Y_00) (T_00 = int V cos Y_00)."""
    return np.clip(np.asarray(T, np.float64)[:, 0] / (math.pi * 0.282095), 0.0, 1.0)


def transfer_bent_normal(T: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """(N, 3) the bent normal a transfer vector holds: the direction of (T_11, T_1-1, T_10), i.e. of
    int V cos w dw; ``fallback`` where every ray is blocked."""
    T = np.asarray(T, np.float64)
    b = np.stack([T[:, 3], T[:, 1], T[:, 2]], 1)
    bl = np.linalg.norm(b, axis=1, keepdims=True)
    return np.where(bl > 1e-9, b / np.maximum(bl, 1e-300), fallback)


def sh_project(img: np.ndarray, yaw_deg: float = 0.0, max_w: int = 256) -> np.ndarray:
    """(9, 3) radiance coefficients L_lm = int L(w) Y_lm(w) dw of an equirect image turned by ``yaw``
    (R&H 2001 eq. 6), summed over texels with their exact solid angles."""
    img = downsample(img, max_w)
    h, w = img.shape[:2]
    d = rotate_yaw(equirect_directions(w, h), yaw_deg)
    y = sh_basis(d) * equirect_solid_angles(w, h)[..., None]
    out: FloatArray = np.einsum("hwk,hwc->kc", y, img)
    return out


def sh_irradiance_coefficients(L_lm: FloatArray, order: int = MAX_SH_ORDER) -> FloatArray:
    """(9, 3) A_l L_lm (R&H 2001 eq. 7): the irradiance's coefficients; bands above ``order`` zeroed."""
    out = np.array(L_lm, np.float64, copy=True)
    band = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2])
    for k, l in enumerate(band):
        out[k] *= A_HAT[l] if l <= order else 0.0
    return out


def sh_irradiance(E_lm: FloatArray, n: FloatArray) -> FloatArray:
    """(N, 3) irradiance E(n) = sum_lm A_l L_lm Y_lm(n) (R&H 2001 eq. 7) for irradiance
    coefficients ``E_lm`` (sh_irradiance_coefficients) at unit normals ``n`` (N, 3); clamped at 0
    (the truncated series rings below zero opposite a bright source)."""
    return np.maximum(sh_basis(n) @ E_lm, 0.0)


def sh_irradiance_scattered(E_lm: np.ndarray, n: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(N, 3) the SH irradiance with band l scaled by w (N or 1, 3 bands, 3 RGB): pre-integrated skin's
    environment term, sum_lm w_l A_l L_lm Y_lm(n) clamped at 0 (physics/penner.env_band_factors;
    lib/environment.glsl env_irradiance_scattered)."""
    Y = sh_basis(n)  # (N, 9)
    band = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2])
    w = np.broadcast_to(np.asarray(w, np.float64), (len(Y), 3, 3))
    out: np.ndarray = np.maximum(np.einsum("nk,kc,nkc->nc", Y, np.asarray(E_lm, np.float64), w[:, band]), 0.0)
    return out


def irradiance_exact(img: np.ndarray, n: np.ndarray, yaw_deg: float = 0.0, max_w: int = 128) -> np.ndarray:
    """(N, 3) the unoccluded irradiance int L(w) max(n.w, 0) dw by summing every texel (the test's
    judge of the SH series: no truncation)."""
    img = downsample(img, max_w)
    h, w = img.shape[:2]
    d = rotate_yaw(equirect_directions(w, h), yaw_deg).reshape(-1, 3)
    rad = (img.reshape(-1, img.shape[2]) * equirect_solid_angles(w, h).reshape(-1, 1))
    out: FloatArray = np.maximum(np.asarray(n, np.float64) @ d.T, 0.0) @ rad
    return out


# -- visibility: ambient occlusion and bent normals (baked per mesh) ---------------------------------

def stratified_cosine_directions(n: int, rng: np.random.Generator) -> FloatArray:
    """(n, 3) cosine-weighted directions about +z, one per cell of a sqrt(n) x sqrt(n) grid
    (n rounded down to a square), jittered: stratified sampling of the projected disc."""
    k = max(math.isqrt(n), 1)
    i, j = np.meshgrid(np.arange(k), np.arange(k))
    u1 = (i.ravel() + rng.random(k * k)) / k
    u2 = (j.ravel() + rng.random(k * k)) / k
    r, phi = np.sqrt(u1), 2.0 * math.pi * u2
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(1.0 - u1, 0.0))], -1)


def tangent_frames(n: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(t, b) unit tangents completing the unit normals ``n`` (N, 3) to right-handed frames."""
    a = np.where(np.abs(n[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    t = np.cross(n, a)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return t, np.cross(n, t)


def ray_caster(positions: FloatArray, indices: IndexArray) -> RayCaster:
    """An Embree intersector (trimesh + embreex) over the triangles."""
    import trimesh
    from trimesh.ray.ray_pyembree import RayMeshIntersector
    caster: RayCaster = RayMeshIntersector(trimesh.Trimesh(np.asarray(positions, np.float64),
                                                           np.asarray(indices, np.int64), process=False))
    return caster


def _unit_normals(positions: ArrayLike, normals: ArrayLike) -> tuple[FloatArray, FloatArray, BoolArray]:
    """(P, N, good) float64: the normals made unit length, +z where a normal is unusable (``good`` False)."""
    P = np.asarray(positions, np.float64)
    N = np.asarray(normals, np.float64)
    nl = np.linalg.norm(N, axis=1)
    good = np.isfinite(nl) & (nl > 1e-12)
    N = np.where(good[:, None], N / np.where(good, nl, 1.0)[:, None], np.array([[0.0, 0.0, 1.0]]))
    return P, N, good


def _cosine_rays(P: FloatArray, N: FloatArray, good: BoolArray, indices: ArrayLike, rays: int, seed: int,
                 caster: RayCaster | None, chunk: int) -> Iterator[tuple[IndexArray, FloatArray, BoolArray]]:
    """The bakes' rays, chunk by chunk of the vertices with a usable normal: (vertices v, directions
    d (len(v), rays, 3), hit (len(v), rays)) -- ``rays`` cosine-weighted stratified directions, one
    pattern per chunk turned by a random angle per vertex, from a hair above the vertex along N."""
    caster = caster or ray_caster(P, np.asarray(indices))
    extent = float(np.ptp(P, axis=0).max())
    eps = 1e-4 * extent + 1e-9
    rng = np.random.default_rng(seed)
    idx = np.nonzero(good)[0]
    for s0 in range(0, len(idx), chunk):
        v = idx[s0:s0 + chunk]
        local = stratified_cosine_directions(rays, rng)  # one pattern per chunk, turned per vertex
        k = len(local)
        t, b = tangent_frames(N[v])
        ang = rng.random(len(v)) * 2.0 * math.pi
        c, s = np.cos(ang)[:, None], np.sin(ang)[:, None]
        t, b = c * t + s * b, -s * t + c * b
        d = (local[None, :, :1] * t[:, None] + local[None, :, 1:2] * b[:, None] + local[None, :, 2:] * N[v][:, None])
        o = np.repeat(P[v] + N[v] * eps, k, axis=0)
        hit = caster.intersects_any(o, np.ascontiguousarray(d.reshape(-1, 3))).reshape(len(v), k)
        yield v, d, hit


def bake_visibility(positions: FloatArray, normals: FloatArray, indices: IndexArray, rays: int = 64,
                    seed: int = 0, caster: RayCaster | None = None, chunk: int = 2048) -> Float32Array:
    """(N, 4) float32 per vertex: the bent normal (xyz: the mean unoccluded direction, normalised;
    the vertex normal where every ray is blocked) and the ambient occlusion (w: the fraction of
    ``rays`` cosine-weighted, stratified rays that leave the mesh = the share of a uniform
    environment's irradiance that reaches the vertex). Rays start a hair above the vertex along
    its normal; a vertex without a usable normal gets (normal, 1)."""
    P, N, good = _unit_normals(positions, normals)
    out = np.concatenate([N, np.ones((len(P), 1))], 1)
    if len(P) == 0 or len(indices) == 0:
        return out.astype(np.float32)
    for v, d, hit in _cosine_rays(P, N, good, indices, rays, seed, caster, chunk):
        free = ~hit
        ao = free.mean(1)
        bent = (d * free[..., None]).sum(1)
        bl = np.linalg.norm(bent, axis=1)
        ok = bl > 1e-9
        out[v, :3] = np.where(ok[:, None], bent / np.where(ok, bl, 1.0)[:, None], N[v])
        out[v, 3] = ao
    return out.astype(np.float32)


def bake_transfer(positions: np.ndarray, normals: np.ndarray, indices: np.ndarray, rays: int = 256,
                  seed: int = 0, caster: Any = None, chunk: int = 1024,
                  progress: Callable[[float], None] | None = None) -> np.ndarray:
    """(N, 25) float32 per vertex: the shadowed diffuse transfer vector T_lm = int V(w) max(N.w, 0)
    Y_lm(w) dw, l <= 4 (Sloan et al. 2002 eq. 4's transfer, without interreflection), by ``rays``
    cosine-weighted stratified Embree rays (pdf cos / pi) with the unoccluded transfer as a control
    variate: T_lm = A_l Y_lm(N) - pi / n sum_i (1 - V(w_i)) Y_lm(w_i).
    T_00 / (pi Y_00) is the ambient occlusion and (T_11, T_1-1, T_10) the bent normal's direction
    (transfer_ao, transfer_bent_normal). Rays start a hair above the vertex along its normal; a
    vertex without a usable normal gets the unoccluded transfer of +z. ``progress(fraction)`` is
    called after each chunk (a background bake's status line; it may raise to cancel the bake)."""
    P, N, good = _unit_normals(positions, normals)
    out = transfer_unoccluded(N)
    if len(P) == 0 or len(indices) == 0:
        return out.astype(np.float32)
    n_good, done = max(int(good.sum()), 1), 0
    for v, d, hit in _cosine_rays(P, N, good, indices, rays, seed, caster, chunk):
        if progress is not None:
            progress(done / n_good)
        done += len(v)
        k = hit.shape[1]
        # the unoccluded transfer exactly, less the blocked rays' share: a control variate, unbiased
        # (E[pi/n sum Y(w_i)] = A_l Y_lm(N)), exact where nothing blocks and noisy only in the blocked part
        out[v] -= math.pi / k * np.einsum("vr,vrk->vk", hit.astype(np.float64), sh_basis25(d))
    return out.astype(np.float32)


def bake_thickness(positions: np.ndarray, normals: np.ndarray, indices: np.ndarray,
                   transfer: np.ndarray | None = None) -> np.ndarray:
    """(N,) float32 per vertex: the distance (mesh units) from the vertex along -N to the next surface,
    the thickness light crosses to reach it from behind (issue 32's translucency from the environment;
    one Embree ray from a hair inside the surface). No surface within reach (an open sheet's edge, a
    flipped normal): THICK_MISS, i.e. no transmission. With ``transfer`` (N, 25, bake_transfer):
    (N, 2), the thickness and the back point's ambient occlusion (transfer_ao of the hit triangle's
    vertices, barycentric), which shadows the back side's light (an ear's back faces the skull)."""
    P, N, good = _unit_normals(positions, normals)
    out = np.full(len(P), THICK_MISS, np.float64)
    back_ao = np.ones(len(P))
    idx = np.nonzero(good)[0]
    if len(idx) and len(indices):
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector
        tris = np.asarray(indices, np.int64)
        mesh = trimesh.Trimesh(np.asarray(P, np.float64), tris, process=False)
        eps = 1e-4 * float(np.ptp(P, axis=0).max()) + 1e-9
        o = P[idx] - N[idx] * eps
        tri, ray, loc = RayMeshIntersector(mesh).intersects_id(o, -N[idx], multiple_hits=False,
                                                               return_locations=True)
        out[idx[ray]] = np.linalg.norm(loc - o[ray], axis=1) + eps
        if transfer is not None and len(tri):
            bary = trimesh.triangles.points_to_barycentric(P[tris[tri]], loc)
            ao = transfer_ao(transfer)
            back_ao[idx[ray]] = np.clip((np.clip(bary, 0.0, 1.0) * ao[tris[tri]]).sum(1), 0.0, 1.0)
    if transfer is None:
        return out.astype(np.float32)
    return np.stack([out, back_ao], 1).astype(np.float32)


def env_transmitted(E_lm: np.ndarray, Ng: np.ndarray, thickness_mm: np.ndarray,
                    profile: Callable[[np.ndarray], np.ndarray], back_ao: np.ndarray | None = None) -> np.ndarray:
    """(N, 3) translucency from the environment (issue 32; lib/environment.glsl env_back_irradiance and
    ss_lighting.frag / tsm_transmit.glsl): the irradiance the back side receives, the unoccluded SH
    irradiance at -Ng x the back point's ambient occlusion ``back_ao`` (bake_thickness), times the
    transmittance profile T(d) (N, 3) at the thickness along -N. The approximation: all of the back's light crosses the one thickness along -N (seed 001 eq. 3.15-3.18
    with the environment's back irradiance for E(-N) and the baked thickness for the shadow map's)."""
    d = np.asarray(thickness_mm, np.float64)
    out: np.ndarray = sh_irradiance(E_lm, -np.asarray(Ng, np.float64)) * np.asarray(profile(d), np.float64)
    if back_ao is not None:
        out = out * np.asarray(back_ao, np.float64).reshape(-1, 1)
    return out


def bent_shading_normal(N: np.ndarray, Nv: np.ndarray, bent: np.ndarray) -> np.ndarray:
    """The normal the environment's irradiance is looked up with: the shading normal N (normal map)
    turned as the bent normal turns the vertex normal, normalize(N + bent - Nv)
    (lib/environment.glsl env_normal)."""
    v = np.asarray(N, np.float64) + np.asarray(bent, np.float64) - np.asarray(Nv, np.float64)
    vl = np.linalg.norm(v, axis=1, keepdims=True)
    return np.where(vl > 1e-9, v / np.maximum(vl, 1e-300), N)


def env_diffuse(E_lm: FloatArray, N: FloatArray, Nv: FloatArray, vis: FloatArray | None) -> FloatArray:
    """(N, 3) the environment's irradiance at shading normals N: AO x E_SH(bent normal)
    (lib/environment.glsl env_irradiance); ``vis`` (N, 4) the baked bent normal + AO, None: unoccluded."""
    if vis is None:
        return sh_irradiance(E_lm, N)
    vis = np.asarray(vis, np.float64)
    return vis[:, 3:4] * sh_irradiance(E_lm, bent_shading_normal(N, Nv, vis[:, :3]))


def env_diffuse_transfer(E_lm: np.ndarray, L_lm: np.ndarray, N: np.ndarray, Nv: np.ndarray, T: np.ndarray,
                         order: int = TRANSFER_ORDER) -> np.ndarray:
    """(N, 3) the environment's irradiance at shading normals N through the vertex's transfer vector T
    (N, 25) (lib/mesh_vs.glsl env_vertex_light + lib/environment.glsl env_irradiance): the shadowed
    sum_lm L_lm T_lm (bands <= ``order``; 0: AO x E_SH(bent normal)) plus the normal map's change of
    the unoccluded SH irradiance, AO x (E_SH(N) - E_SH(Nv)), clamped at 0. ``E_lm`` (9, 3) the SH
    irradiance coefficients, ``L_lm`` (25, 3) the radiance coefficients (sh_project25)."""
    ao = transfer_ao(T)[:, None]
    Nv = np.asarray(Nv, np.float64) / np.linalg.norm(Nv, axis=1, keepdims=True)
    if order > 0:
        e = transfer_irradiance(T, L_lm, order)
    else:
        e = ao * sh_irradiance(E_lm, transfer_bent_normal(T, Nv))
    return np.maximum(e + ao * (sh_irradiance(E_lm, N) - sh_irradiance(E_lm, Nv)), 0.0)


def specular_occlusion(n_dot_v: np.ndarray, ao: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Lagarde & de Rousiers 2014 (Moving Frostbite to PBR, eq. 9): the share of the specular
    environment a point with ambient occlusion ``ao`` sees, clamp((N.V + ao)^exp2(-16 m - 1) - 1 + ao)."""
    nv = np.clip(np.asarray(n_dot_v, np.float64), 0.0, 1.0)
    out: np.ndarray = np.clip(np.power(nv + ao, np.exp2(-16.0 * np.asarray(m, np.float64) - 1.0)) - 1.0 + ao, 0.0, 1.0)
    return out


def rho_dt_mean(rho_dt_of_mu: Callable[[float], ArrayLike]) -> FloatArray:
    """The cosine-weighted hemispherical mean of rho_dt (eq. 30-32 for an environment):
    sum_k w_k rho_dt(mu_k) on RHO_MU/RHO_W; ``rho_dt_of_mu(mu)`` -> array."""
    out: FloatArray = np.sum([w * np.asarray(rho_dt_of_mu(mu), np.float64) for mu, w in zip(RHO_MU, RHO_W)], axis=0)
    return out


# -- the pre-filtered specular environment (split sum) ---------------------------------------------

def beckmann_lobe(cos_angle: FloatArray, m: float) -> FloatArray:
    """Beckmann D of the half-vector between R and L for the split sum's N = V = R
    (the half-angle is half the angle between R and L), times N.L = R.L."""
    c = np.clip(cos_angle, -1.0, 1.0)
    ch = np.sqrt(np.clip(0.5 * (1.0 + c), 1e-12, 1.0))  # cos of the half-angle
    t2 = (1.0 - ch * ch) / (ch * ch)
    return np.where(c > 0.0, np.exp(-t2 / (m * m)) / (m * m * ch ** 4) * c, 0.0)


def prefilter_specular(img: FloatArray, levels_m: Sequence[float] = SPEC_LEVELS_M,
                       size: tuple[int, int] = SPEC_SIZE, src_w: int = 64) -> Float32Array:
    """(len(levels_m) * H, W, 3) float32: for each Beckmann m the radiance averaged over the lobe
    around each texel's direction R (split-sum first factor), levels stacked top to bottom
    (lib/environment.glsl env_prefiltered). Weights include each source texel's solid angle."""
    src = downsample(img, src_w)
    sh, sw = src.shape[:2]
    sd = equirect_directions(sw, sh).reshape(-1, 3)
    srad = src.reshape(-1, src.shape[2])
    sa = equirect_solid_angles(sw, sh).reshape(-1)
    w, h = size
    od = equirect_directions(w, h).reshape(-1, 3)
    cos = od @ sd.T
    out = []
    for m in levels_m:
        k = beckmann_lobe(cos, m) * sa[None]
        ks = k.sum(1, keepdims=True)
        out.append(((k @ srad) / np.maximum(ks, 1e-300)).reshape(h, w, -1))
    return np.ascontiguousarray(np.concatenate(out, 0), np.float32)


def specular_level(m: ArrayLike, levels_m: Sequence[float] = SPEC_LEVELS_M) -> FloatArray:
    """The fractional level index of Beckmann ``m`` (linear between the levels' m, clamped)."""
    lv = np.asarray(levels_m, np.float64)
    return np.interp(np.asarray(m, np.float64), lv, np.arange(len(lv)))


def sample_prefiltered(pre: FloatArray, R: FloatArray, m: FloatArray, yaw_deg: float = 0.0,
                       levels: int = len(SPEC_LEVELS_M)) -> FloatArray:
    """(N, 3) the pre-filtered radiance at reflection directions R for Beckmann m (bilinear in each
    level, linear between levels) as lib/environment.glsl env_prefiltered reads it."""
    h = pre.shape[0] // levels
    f = specular_level(m)
    l0 = np.clip(np.floor(f).astype(np.int64), 0, levels - 1)
    l1 = np.minimum(l0 + 1, levels - 1)
    t = (f - l0)[:, None]
    out = np.zeros((len(R), pre.shape[2]))
    for lv in np.unique(np.r_[l0, l1]):
        img = pre[lv * h:(lv + 1) * h]
        val = sample_equirect(img, R, yaw_deg)
        out += val * (np.where(l0 == lv, 1.0 - t[:, 0], 0.0) + np.where(l1 == lv, t[:, 0], 0.0))[:, None]
    return out


def env_specular(pre: FloatArray, N: FloatArray, V: FloatArray, m: FloatArray, spec_albedo: FloatArray,
                 occlusion: FloatArray | None = None, yaw_deg: float = 0.0) -> FloatArray:
    """(N, 3) split-sum specular: prefiltered(R, m) x the KS specular albedo (1 - rho_dt(N.V), eq. 30)
    x specular occlusion (lib/environment.glsl env_specular)."""
    R = 2.0 * (N * V).sum(1, keepdims=True) * N - V
    R /= np.maximum(np.linalg.norm(R, axis=1, keepdims=True), 1e-300)
    s = sample_prefiltered(pre, R, m, yaw_deg) * np.asarray(spec_albedo, np.float64)[:, None]
    return s if occlusion is None else s * np.asarray(occlusion, np.float64)[:, None]


def phong_beckmann_m(shininess: float) -> float:
    """The Beckmann m of a Blinn-Phong exponent n, sqrt(2 / (n + 2)) (Walter et al. 2007 eq. 32 read
    backwards): the pre-filtered level Phong's environment specular reads."""
    return math.sqrt(2.0 / (float(shininess) + 2.0))


def phong_env_albedo(shininess: float) -> float:
    """int (N.H)^n (N.L) dw_L over the hemisphere at V = N (the Blinn-Phong lobe's directional albedo
    before phong.specular), exactly: with c = cos theta_h, dw_L = 4 (V.H) dw_H and N.L = 2c^2 - 1,
    8 pi int_{1/sqrt2}^1 c^(n+1) (2c^2 - 1) dc (lib/environment.glsl env_phong_albedo)."""
    n = float(shininess)
    return float(8.0 * math.pi * (2.0 * (1.0 - 2.0 ** (-(n + 4.0) / 2.0)) / (n + 4.0)
                                  - (1.0 - 2.0 ** (-(n + 2.0) / 2.0)) / (n + 2.0)))


def env_phong_specular(pre: np.ndarray, N: np.ndarray, V: np.ndarray, shininess: float, specular: float,
                       ao: np.ndarray | None = None, yaw_deg: float = 0.0) -> np.ndarray:
    """(N, 3) Phong's environment specular (split sum): the radiance pre-filtered at R for the lobe's
    Beckmann m (phong_beckmann_m) x phong.specular x the lobe's albedo (phong_env_albedo) x specular
    occlusion from ``ao`` (lib/environment.glsl env_phong_specular)."""
    R = 2.0 * (N * V).sum(1, keepdims=True) * N - V
    R /= np.maximum(np.linalg.norm(R, axis=1, keepdims=True), 1e-300)
    m = phong_beckmann_m(shininess)
    s = sample_prefiltered(pre, R, np.full(len(N), m), yaw_deg) * (specular * phong_env_albedo(shininess))
    if ao is not None:
        s = s * specular_occlusion(np.clip((N * V).sum(1), 0.0, 1.0), ao, np.full(len(N), m))[:, None]
    return s


# -- Monte Carlo (the ground truth's) ------------------------------------------------------------------

class EnvSampler:
    """A piecewise-constant environment (the equirect box-filtered to ``width`` texels) for the ground
    truth's irradiance: the exact unoccluded integral by summing texels, and directions drawn in
    proportion to each texel's luminance x solid angle (uniform in solid angle inside the texel)."""

    def __init__(self, img: FloatArray, yaw_deg: float = 0.0, width: int = 128):
        self.img = downsample(img, width)
        self.h, self.w = self.img.shape[:2]
        self.yaw = float(yaw_deg)
        self.rad = self.img.reshape(-1, self.img.shape[2])
        self.omega = equirect_solid_angles(self.w, self.h).reshape(-1)
        self.dirs = rotate_yaw(equirect_directions(self.w, self.h), self.yaw).reshape(-1, 3)
        lum = self.rad @ np.array([0.2126, 0.7152, 0.0722]) + 1e-6 * self.rad.mean()
        p = np.maximum(lum, 0.0) * self.omega
        self.p = p / p.sum()  # probability of each texel
        self.cdf = np.cumsum(self.p)
        self.cos_edges = np.cos(np.arange(self.h + 1) / self.h * math.pi)

    def lookup(self, d: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(radiance (N, C), texel index (N,)) of the texel holding each direction (nearest)."""
        uv = direction_to_uv(rotate_yaw(d, -self.yaw))
        x = np.clip((uv[:, 0] * self.w).astype(np.int64), 0, self.w - 1)
        y = np.clip((uv[:, 1] * self.h).astype(np.int64), 0, self.h - 1)
        t = y * self.w + x
        return self.rad[t], t

    def sample(self, u0: FloatArray, u1: FloatArray, u2: FloatArray) -> FloatArray:
        """Directions (..., 3) for uniforms u0 (the texel), u1, u2 (the point inside it)."""
        t = np.minimum(np.searchsorted(self.cdf, u0), len(self.cdf) - 1)
        y, x = t // self.w, t % self.w
        c = self.cos_edges[y] + (self.cos_edges[y + 1] - self.cos_edges[y]) * u1
        s = np.sqrt(np.maximum(1.0 - c * c, 0.0))
        phi = (x + u2) / self.w * 2.0 * math.pi - math.pi
        return rotate_yaw(np.stack([s * np.sin(phi), c, -s * np.cos(phi)], -1), self.yaw)

    def unoccluded(self, N: FloatArray, weight: EnvWeight | None = None, chunk: int = 2048) -> FloatArray:
        """(N, C) sum_t L_t max(N.w_t, 0) weight(N.w_t) Omega_t: the piecewise-constant environment's
        irradiance without occlusion (weight(mu (n, T), sl): rho_dt, None: 1)."""
        out = np.zeros((len(N), self.rad.shape[1]))
        ro = self.rad * self.omega[:, None]
        for s0 in range(0, len(N), chunk):
            sl = slice(s0, min(len(N), s0 + chunk))
            mu = np.maximum(N[sl] @ self.dirs.T, 0.0)
            if weight is not None:
                mu = mu * np.asarray(weight(mu, sl), np.float64)
            out[sl] = mu @ ro
        return out


def mc_irradiance_cv(sampler: EnvSampler, P: FloatArray, N: FloatArray, Ng: FloatArray, caster: RayCaster, samples: int,
                     rng: np.random.Generator, eps: float, weight: EnvWeight | None = None, batches: int = 4,

                     chunk: int = 2048) -> tuple[FloatArray, FloatArray]:
    """The occluded irradiance int L V max(N.w, 0) weight dw as E0 - O: E0 the exact unoccluded sum
    (EnvSampler.unoccluded, a control variate) and O = int L (1 - V) max(N.w, 0) weight dw the light
    the mesh blocks, by Monte Carlo with multiple importance sampling (balance heuristic, Veach 1997)
    of cosine-weighted and environment-proportional directions, half each, both stratified; a
    direction below the geometric surface Ng is blocked. ``batches`` independent estimates give the
    standard error. Returns (estimate (N, C), standard error (N, C))."""
    P = np.asarray(P, np.float64)
    E0 = sampler.unoccluded(N, weight)
    per = max(samples // (2 * batches), 1)
    k = max(math.isqrt(per), 1)
    n_cos = k * k
    n_env = per
    occl = np.zeros((batches,) + E0.shape)
    for s0 in range(0, len(P), chunk):
        sl = slice(s0, min(len(P), s0 + chunk))
        n, ng, cnt = N[sl], Ng[sl], len(N[sl])
        t, b = tangent_frames(n)
        for bi in range(batches):
            loc = stratified_cosine_directions(n_cos, rng)
            ang = rng.random(cnt) * 2.0 * math.pi
            c, s = np.cos(ang)[:, None], np.sin(ang)[:, None]
            tt, bb = c * t + s * b, -s * t + c * b
            d_cos = loc[None, :, :1] * tt[:, None] + loc[None, :, 1:2] * bb[:, None] + loc[None, :, 2:] * n[:, None]
            u0 = (np.arange(n_env)[None] + rng.random((cnt, n_env))) / n_env
            d_env = sampler.sample(u0, rng.random((cnt, n_env)), rng.random((cnt, n_env)))
            d = np.concatenate([d_cos, d_env], 1)  # (cnt, n_cos + n_env, 3)
            m = d.shape[1]
            mu = (d * n[:, None]).sum(2)
            L, tex = sampler.lookup(d.reshape(-1, 3))
            L = L.reshape(cnt, m, -1)
            p_cos = np.maximum(mu, 0.0) / math.pi
            p_env = (sampler.p / sampler.omega)[tex].reshape(cnt, m)
            front = mu > 0.0
            above = (d * ng[:, None]).sum(2) > 0.0
            blocked = np.ones((cnt, m), bool)
            test = (front & above).reshape(-1)
            if test.any():
                o = np.repeat(P[sl] + ng * eps, m, axis=0)
                dd = np.ascontiguousarray(d.reshape(-1, 3))
                blocked.reshape(-1)[test] = caster.intersects_any(o[test], dd[test])
            g = np.where(front & blocked, mu, 0.0)
            if weight is not None:
                g = g * np.asarray(weight(np.maximum(mu, 0.0), sl), np.float64)
            f = L * (g / np.maximum(n_cos * p_cos + n_env * p_env, 1e-300))[..., None]
            occl[bi, sl] = f.sum(1)  # balance heuristic: sum_j f / (n1 p1 + n2 p2)
    est = E0[None] - occl
    return est.mean(0), est.std(0, ddof=1) / math.sqrt(batches)
