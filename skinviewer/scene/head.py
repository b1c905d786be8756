"""The project's own default head: a procedural adult head and neck with a UV atlas and skin maps.

Geometry, in millimetres, Y up, facing +Z, origin near the middle of the head:

* skull, face and neck are one implicit surface (smooth union / subtraction of ellipsoids and
  capsules), star-shaped about a point inside the head. Each vertex is found by casting a ray from
  that point along the spherical direction (θ from +Y, φ from +Z towards +X), so the surface is a
  radial function r(θ, φ) — no folds, and every texel maps straight back to a 3D point;
* the ears are separate closed thin shells (3 mm thick, rounded rim) pushed into the side of the
  head, so a back light passes through a real flap of tissue;
* the eyeballs are separate closed globes (24 mm, corneal bulge) in the orbits; the head surface's
  eyelids open around them (an almond fissure cut from a lid shell over the globe, its margin on
  the eyeball), and the band cells around each eye are re-triangulated finer along the lid margins.

UV atlas: the head band (everything below the crown cap, cut at the back of the head) is one island
with u ∝ arc length around and v ∝ mean arc length down; the crown is an azimuthal-equidistant disk;
each ear side is a planar island; each eyeball is an azimuthal disk (cornea in the middle,
the unseen back compressed towards the rim). The band runs down to the south pole at the centre of the flat
collar cut, so the mesh is closed there (its last row collapses onto one point). Islands share one
texel density and are separated by gutters that the maps fill by dilation (nearest island texel) so
bilinear filtering never reads outside skin.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from skinviewer.core.settings import REGIONS
from skinviewer.scene.mesh import MeshData, vertex_normals


class _LazyScipy:
    """scipy.ndimage / Delaunay on first use: only generating a head needs them, not loading it from
    the cache (issue 14: scipy was 0.27 s of a 0.42 s start-up)."""

    def __getattr__(self, name):
        from scipy import ndimage
        return getattr(ndimage, name)


ndimage = _LazyScipy()


def Delaunay(points):  # noqa: N802 (scipy's name)
    from scipy.spatial import Delaunay as _Delaunay
    return _Delaunay(points)

GENERATOR_VERSION = 4

# detail level -> (target edge length in mm, texture size)
_LEVELS = {0: (10.5, 512), 1: (4.0, 1024), 2: (2.0, 2048)}

_RAY_ORIGIN = np.array([0.0, -5.0, -12.0])   # inside the skull; the neck axis runs under it
_THETA_CAP = np.radians(38.0)                 # crown cap / head band boundary
_CUT_Y, _CUT_SLOPE = -180.0, 0.17           # collar cut plane: y at z = 40 mm, rise per mm forward
_POLE_CIRC = 40.0                             # mm: floor of the band's UV width towards the cut's centre
_EAR_THICKNESS = 3.0                          # mm, between the two sheets of each ear
_UV_MARGIN = 0.012                            # island distance from the atlas border
_UV_GUTTER = 0.02                             # between islands (20 texels at 1024²)
_REGION = {name: i for i, name in enumerate(REGIONS)}


# ---------------------------------------------------------------------------------------------
# public API

def default_head(detail: int = 1, seed: int = 7, cache_dir: str | Path | None = None) -> MeshData:
    """The built-in head (mm, Y up, facing +Z), generated once per (detail, seed) and cached.

    detail 0: ~9.5k triangles and 512² maps (tests); 1: ~58k triangles and 1024² maps;
    2: ~200k triangles and 2048² maps.
    The seed only changes the skin's noise (albedo mottling, pores), never the shape.
    """
    if detail not in _LEVELS:
        raise ValueError(f"head detail must be one of {sorted(_LEVELS)}, got {detail}")
    path = _cache_path(detail, seed, cache_dir)
    arrays = _load_cache(path)
    if arrays is None:
        arrays = _generate(detail, seed)
        _save_cache(path, arrays)
    return MeshData(
        positions=arrays["positions"], normals=arrays["normals"], uvs=arrays["uvs"],
        indices=arrays["indices"], mm_per_unit=1.0,
        albedo=arrays["albedo"].astype(np.float32),
        normal_map=arrays["normal_map"].astype(np.float32),
        specular_map=arrays["specular_map"].astype(np.float32),
        region_map=arrays["region_map"], name=f"default-head-d{detail}")


# ---------------------------------------------------------------------------------------------
# cache

_ARRAY_KEYS = ("positions", "normals", "uvs", "indices", "albedo", "normal_map", "specular_map", "region_map")


def _cache_path(detail: int, seed: int, cache_dir: str | Path | None) -> Path:
    root = cache_dir or os.environ.get("SKINVIEWER_CACHE") or Path.home() / ".cache" / "skinviewer"
    return Path(root) / f"head-v{GENERATOR_VERSION}-d{detail}-s{seed}.npz"


def _load_cache(path: Path) -> dict[str, np.ndarray] | None:
    """The cached arrays, or None when missing, unreadable or inconsistent (then regenerate)."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in _ARRAY_KEYS}
    except Exception:  # truncated zip, bad header, missing key...: all mean "regenerate"
        return None
    n = len(arrays["positions"])
    res = arrays["region_map"].shape
    ok = (arrays["positions"].shape == (n, 3) and arrays["normals"].shape == (n, 3)
          and arrays["uvs"].shape == (n, 2) and arrays["indices"].ndim == 2
          and arrays["indices"].shape[1] == 3 and int(arrays["indices"].max(initial=0)) < n
          and len(res) == 2 and arrays["albedo"].shape == (*res, 3)
          and arrays["normal_map"].shape == (*res, 3) and arrays["specular_map"].shape == (*res, 1)
          and all(np.all(np.isfinite(arrays[k])) for k in ("positions", "normals", "uvs")))
    return arrays if ok else None


def _save_cache(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Atomic write (temp file + os.replace); an unwritable cache only costs regeneration."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.stem, suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, path)
    except OSError:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)


# ---------------------------------------------------------------------------------------------
# implicit head: smooth CSG of ellipsoids and capsules (negative inside)

def _smin(a, b, k):
    """Polynomial smooth minimum (smooth union) with blend width k mm."""
    h = np.maximum(k - np.abs(a - b), 0.0) / k
    return np.minimum(a, b) - h * h * k * 0.25


def _smax(a, b, k):
    return -_smin(-a, -b, k)


def _ellipsoid(x, y, z, c, r):
    """Approximate signed distance to an ellipsoid (exact on the axes, good near the surface)."""
    qx, qy, qz = (x - c[0]) / r[0], (y - c[1]) / r[1], (z - c[2]) / r[2]
    k0 = np.sqrt(qx * qx + qy * qy + qz * qz)
    k1 = np.sqrt((qx / r[0]) ** 2 + (qy / r[1]) ** 2 + (qz / r[2]) ** 2)
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-9)


def _capsule(x, y, z, a, b, ra, rb):
    """Distance to a segment a-b with radius tapering from ra to rb."""
    ab = np.subtract(b, a, dtype=float)
    px, py, pz = x - a[0], y - a[1], z - a[2]
    t = np.clip((px * ab[0] + py * ab[1] + pz * ab[2]) / ab.dot(ab), 0.0, 1.0)
    dx, dy, dz = px - t * ab[0], py - t * ab[1], pz - t * ab[2]
    return np.sqrt(dx * dx + dy * dy + dz * dz) - (ra + (rb - ra) * t)


def _bilateral(f, x, y, z, c, *args):
    """A paired feature (left and right), mirrored in x."""
    return np.minimum(f(x, y, z, (c[0], c[1], c[2]), *args), f(x, y, z, (-c[0], c[1], c[2]), *args))


# ---------------------------------------------------------------------------------------------
# eyes: separate closed eyeballs in the orbits, eyelids of the head surface open around them

_EYE_C = np.array([32.0, 12.0, 70.0])   # right eyeball centre (mm); the left one mirrors x
_EYE_R = 12.0                           # sclera radius (24 mm globe)
_CORNEA_R, _CORNEA_H = 7.8, 1.5         # corneal curvature radius, protrusion beyond the sclera
_LON_C = np.radians(75.0)               # lateral canthus: horizontal angle from the eye's axis
_LON_M = np.radians(60.0)               # medial canthus (the nose side: kept shallow)
_LID_GAP = 0.5                          # hidden skin behind the eyeball inside the fissure (mm)


def _eye_radius(alpha):
    """Eyeball surface distance from its centre at angle alpha from the visual axis (+Z): the
    sclera sphere with the corneal cap (a smaller sphere) blended on."""
    d = _EYE_R + _CORNEA_H - _CORNEA_R
    sa = np.sin(alpha)
    cornea = d * np.cos(alpha) + np.sqrt(np.maximum(_CORNEA_R ** 2 - (d * sa) ** 2, 0.0))
    return _smax(np.full_like(cornea, _EYE_R), cornea, 0.6)


def _fissure(lon):
    """Upper and lower lid margins (latitude, rad) at horizontal angle lon about the eye centre
    (+ lateral): an almond between the canthi, the lateral canthus ~2 mm above the medial one,
    the upper lid over the top quarter of the iris, the lower lid at the iris's lower edge."""
    t = np.clip(lon / np.where(lon < 0, _LON_M, _LON_C), -1.0, 1.0)
    canth = np.radians(-2.3 + 4.7 * t)
    w = 1.0 - t * t
    up = canth + np.radians(13.5) * w ** 0.6 * (1.0 - 0.2 * t)
    lo = canth - np.radians(25.5) * w ** 0.8 * (1.0 + 0.1 * t)
    return up, lo


def _eye_coords(ax, y, z):
    """(rho, lon, lat, alpha) about the eye centre; ax = |x| so both eyes share it."""
    qx, qy, qz = ax - _EYE_C[0], y - _EYE_C[1], z - _EYE_C[2]
    rho = np.sqrt(qx * qx + qy * qy + qz * qz) + 1e-9
    lon = np.arctan2(qx, qz)
    lat = np.arcsin(np.clip(qy / rho, -1.0, 1.0))
    alpha = np.arccos(np.clip(qz / rho, -1.0, 1.0))
    return rho, lon, lat, alpha


def _limbus_alpha():
    """Angle from the visual axis where the cornea meets the sclera."""
    al = np.linspace(0.0, 1.2, 2401)
    d = _EYE_R + _CORNEA_H - _CORNEA_R
    cornea = d * np.cos(al) + np.sqrt(np.maximum(_CORNEA_R ** 2 - (d * np.sin(al)) ** 2, 0.0))
    return float(al[np.argmax(cornea < _EYE_R)])


_EYE_UV_KNEE, _EYE_UV_BACK = 1.05, 0.15   # the front (α < knee) gets most of an eye's UV disk


def _eye_uv_radius(alpha):
    """UV disk radius (fraction of the island's) for angle alpha from the eye's axis."""
    g = lambda a: np.minimum(a, _EYE_UV_KNEE) + _EYE_UV_BACK * np.maximum(a - _EYE_UV_KNEE, 0.0)
    return g(alpha) / g(np.pi)


def _eye_uv_alpha(frac):
    """Inverse of _eye_uv_radius."""
    g = frac * (_EYE_UV_KNEE + _EYE_UV_BACK * (np.pi - _EYE_UV_KNEE))
    return np.where(g <= _EYE_UV_KNEE, g, _EYE_UV_KNEE + (g - _EYE_UV_KNEE) / _EYE_UV_BACK)


def _aperture(rho, lon, lat):
    """Signed distance-like (mm) to the palpebral fissure's cone: negative inside the opening."""
    up, lo = _fissure(lon)
    return rho * np.maximum(np.maximum(lat - up, lo - lat), np.maximum(lon - _LON_C, -lon - _LON_M))


def _eyelids(d, ax, y, z):
    """Open eyelids: the orbit inside the fissure is emptied down to just behind the eyeball, the
    lids are a shell over the globe (following the corneal bulge) cut by the fissure with a
    rounded margin, and a thin layer of hidden conjunctiva sits just behind the eyeball."""
    rho, lon, lat, alpha = _eye_coords(ax, y, z)
    surf = _eye_radius(alpha)
    a = _aperture(rho, lon, lat)
    carve = np.maximum(a, np.maximum(surf - _LID_GAP - rho, rho - surf - 6.0))
    d = _smax(d, -carve, 0.5)
    thick = 1.4 + 0.6 * _smoothstep(-0.35, 0.15, lat)          # upper lid thicker than the lower
    lid = _smax(rho - surf - thick, -a, 1.2)
    d = _smin(d, lid, 2.0)
    return np.minimum(d, rho - surf + _LID_GAP)


def _head_sdf(x, y, z):
    e, cap = _ellipsoid, _capsule
    ax = np.abs(x)
    # neurocranium: braincase, the flatter more upright frontal bone, the occipital bulge behind
    d = e(x, y, z, (0, 22, -10), (75, 93, 97))
    d = _smin(d, e(x, y, z, (0, 40, 8), (66, 64, 85)), 20)
    d = _smin(d, e(x, y, z, (0, 2, -70), (50, 46, 40)), 22)
    # temples are flatter than the parietal bossing
    d = _smax(d, -e(ax, y, z, (97, 18, 38), (30, 40, 42)), 25)
    # midface (maxilla), zygomatic bones (cheekbones) and the arches running back to the ears
    d = _smin(d, e(x, y, z, (0, -22, 24), (54, 56, 68)), 18)
    d = _smin(d, e(ax, y, z, (42, -4, 52), (19, 16, 20)), 22)
    d = _smin(d, cap(ax, y, z, (52, -8, 36), (63, -10, 8), 1.5, 1.5), 20)
    # cheek fat above the nasolabial fold
    d = _smin(d, e(ax, y, z, (28, -42, 74), (13, 14, 11)), 14)
    # dental arch under the lips, and a mandible narrowing towards the chin (x shrinks with z)
    d = _smin(d, e(x, y, z, (0, -66, 46), (37, 40, 47)), 14)
    taper = 1.0 - 0.3 * _smoothstep(-5.0, 90.0, z)
    d = _smin(d, e(x / taper, y, z, (0, -70, 20), (45, 24, 60)), 14)
    # mandible: ramus up towards the ear, the angle, the body along the jawline to the chin
    # (thin capsules with a tight blend, so the jawline stays a firm edge over the neck)
    gonion, mental = (42.0, -80.0, 0.0), (14.0, -106.0, 72.0)
    d = _smin(d, cap(ax, y, z, gonion, mental, 7.0, 8.0), 12)
    d = _smin(d, cap(ax, y, z, (45.0, -30.0, -4.0), gonion, 6.5, 7.0), 14)
    # chin: a soft mental protuberance (wider than deep, flat in front), not a ball
    d = _smin(d, e(x, y, z, (0, -105, 80), (16, 11, 9)), 10)
    d = _smax(d, -e(x, y, z, (0, -84, 97), (15, 3.0, 6)), 6)          # mentolabial sulcus
    # brow ridges (supraorbital), deep orbits, closed eyelids over the eyeballs
    d = _smin(d, e(ax, y, z, (24, 30, 84), (23, 8, 11)), 10)
    d = _smin(d, e(x, y, z, (0, 27, 90), (12, 7, 6)), 8)                # glabella
    d = _smax(d, -e(ax, y, z, (32, 15, 95), (20, 15, 19)), 7)
    d = _eyelids(d, ax, y, z)
    # nose: slim bridge from the nasion to a rounded tip, alae (nostril wings), columella,
    # nostril openings under the tip
    d = _smin(d, cap(x * 1.15, y, z, (0, 17, 87), (0, -20, 106), 5.0, 7.5), 8)
    d = _smin(d, e(x, y, z, (0, -27, 107), (8.5, 8.0, 9.0)), 5)
    d = _smin(d, e(ax, y, z, (11.5, -33, 96), (6.5, 6.0, 7.5)), 4)
    d = _smin(d, e(x, y, z, (0, -37, 101), (3.2, 4.5, 9)), 3)          # columella
    d = _smax(d, -e(ax, y, z, (6.8, -38.5, 100), (3.0, 3.2, 5.0)), 1.5)
    d = _smax(d, -e(ax, y, z, (19.5, -33, 95), (2.0, 8, 4)), 3)     # alar crease
    # lips: upper lip with the cupid's bow, tubercle and philtrum; lower lip; mouth line; corners
    d = _smin(d, e(x, y, z, (0, -56.5, 88), (23, 7, 10)), 6)
    d = _smin(d, e(ax, y, z, (6, -57, 95), (6, 4, 3.5)), 3)
    d = _smin(d, e(x, y, z, (0, -61, 96.5), (4.5, 3, 3)), 2)
    d = _smin(d, e(x, y, z, (0, -70.5, 88), (20, 6.5, 10)), 6)
    d = _smax(d, -e(x, y, z, (0, -63.5 + 0.006 * x * x, 101), (25, 0.8, 13)), 1.5)
    d = _smax(d, -e(x, y, z, (0, -49, 99.5), (2.6, 6, 3)), 2)           # philtrum groove
    d = _smax(d, -e(ax, y, z, (25, -64, 82), (2.5, 2.5, 4)), 3)     # mouth corners
    d = _smax(d, -cap(ax, y, z, (20, -37, 93), (30, -63, 85), 0.6, 1.0), 3)  # nasolabial folds
    # neck: slightly forward-tilted, tapering up into the head; sternocleidomastoids from behind
    # the ears to the sternal notch, the larynx, and the trapezius slopes at the base
    d = _smin(d, e(x, y, z, (0, -55, -44), (52, 45, 52)), 20)
    k_neck = 8.0 + 16.0 * _smoothstep(10.0, -50.0, z)   # crisp under the jaw, soft at the nape
    d = _smin(d, cap(x * 1.04, y, z, (0, -240, -22), (0, -100, -16), 60.0, 52.0), k_neck)
    d = _smin(d, cap(ax, y, z, (44, -78, -30), (19, -194, 30), 9.0, 6.5), 16)
    d = _smin(d, e(x, y, z, (0, -135, 30.5), (9, 17, 8.5)), 14)          # thyroid cartilage
    d = _smax(d, -e(x, y, z, (0, -188, 48), (10, 9, 9)), 6)            # sternal notch
    d = _smin(d, cap(ax, y, z, (26, -120, -50), (50, -230, -38), 12.0, 14.0), 25)
    # clean collar cut, lower at the back than in front
    return _smax(d, _cut_y(z) - y, 3)


def _cut_y(z):
    return _CUT_Y + _CUT_SLOPE * (z - 40.0)


def _direction(theta, phi):
    st = np.sin(theta)
    return np.stack([st * np.sin(phi), np.cos(theta), st * np.cos(phi)], axis=-1)


def _cast(theta, phi):
    """Radius of the head surface along each ray from the origin (outermost sign change)."""
    d = _direction(np.ravel(theta), np.ravel(phi))
    o = _RAY_ORIGIN

    def f(r):
        p = o + d * r[:, None]
        return _head_sdf(p[:, 0], p[:, 1], p[:, 2])

    radii = np.linspace(10.0, 250.0, 25)  # the farthest skin (neck cut) is ~220 mm out
    inside = np.stack([f(np.full(len(d), r)) < 0 for r in radii])
    last = len(radii) - 1 - np.argmax(inside[::-1], axis=0)  # outermost inside sample
    lo, hi = radii[last], radii[np.minimum(last + 1, len(radii) - 1)]
    for _ in range(15):
        mid = 0.5 * (lo + hi)
        neg = f(mid) < 0
        lo, hi = np.where(neg, mid, lo), np.where(neg, hi, mid)
    return (0.5 * (lo + hi)).reshape(np.shape(theta))


def _theta_max():
    """Polar angle where the band stops: the south pole, so the band closes over the flat collar
    cut (its last row collapses onto the cut's centre point)."""
    return np.pi


# ---------------------------------------------------------------------------------------------
# ears: thin closed shells over a planar outline

class _Ear:
    """One ear. The outline is a unit disk (x, y) mapped to ear-plane mm (a back, b up):
    b = 31 y, a = A_C + W(y) x, wider at the helix than at the lobe. The mid-surface is displaced
    along the ear plane's normal (helix rim, scapha, antihelix, concha bowl); the two sheets sit
    ±T/2 along the mid-surface normal, closing with a rounded rim."""

    HEIGHT, A_C = 32.0, 9.0
    RIM = 0.09  # fraction of the unit disk over which the rim rounds off

    def __init__(self, side: float):
        self.side = side
        tilt, flare = np.radians(15.0), np.radians(30.0)
        up = np.array([0.0, np.cos(tilt), -np.sin(tilt)])
        back = np.array([side * np.sin(flare), 0.0, -np.cos(flare)])
        back -= up * back.dot(up)
        self.back = back / np.linalg.norm(back)
        self.up = up
        n = np.cross(self.up, self.back)
        self.normal = n * np.sign(n[0] * side)
        # attach the outline's front edge to the skin just in front of the tragus
        th, ph = np.radians(85.0), side * np.radians(88.0)
        r = float(_cast(np.array([th]), np.array([ph]))[0])
        self.origin = _RAY_ORIGIN + _direction(th, ph) * r

    @staticmethod
    def half_width(y):
        """Half the outline's width (mm): broad at the helix, narrowing to a rounded lobe."""
        return 15.0 + 3.5 * y - 2.0 * y * y

    def plane(self, x, y):
        return self.A_C + self.half_width(y) * x, self.HEIGHT * y

    def from_plane(self, a, b):
        y = b / self.HEIGHT
        return (a - self.A_C) / self.half_width(y), y

    @staticmethod
    def _ridge(x, y, p0, p1, width):
        """Unit-height ridge along the segment p0-p1 of the unit disk (Gaussian cross-section)."""
        ab = np.subtract(p1, p0)
        t = np.clip(((x - p0[0]) * ab[0] + (y - p0[1]) * ab[1]) / ab.dot(ab), 0.0, 1.0)
        d2 = (x - p0[0] - t * ab[0]) ** 2 + (y - p0[1] - t * ab[1]) ** 2
        return np.exp(-d2 / width ** 2)

    def depth(self, x, y):
        """Mid-surface offset along the ear normal (mm; + outwards): the helix rolled over the rim,
        the scapha groove inside it, the Y-shaped antihelix, the concha bowl with the tragus and
        antitragus at its mouth, the helix crus running into the bowl, and a flat lobe."""
        a, b = self.plane(x, y)
        rho = np.sqrt(x * x + y * y)
        lobe = 1.0 - _smoothstep(-0.45, -0.75, y)
        helix = 2.8 * _smoothstep(0.72, 0.97, rho) * _smoothstep(-0.95, -0.35, x + 0.4 * y) * lobe
        scapha = -1.6 * np.exp(-((rho - 0.8) / 0.07) ** 2) * lobe
        antihelix = 2.0 * np.exp(-((rho - 0.58) / 0.1) ** 2) * _smoothstep(-0.5, 0.2, x + 0.3 * y) * lobe
        antihelix += 1.4 * self._ridge(x, y, (0.1, 0.35), (-0.4, 0.72), 0.09)   # superior crus
        concha = -8.5 * np.exp(-((a - 5.0) ** 2 + (b + 3.0) ** 2) / (2 * 7.5 ** 2))
        crus = 1.8 * self._ridge(x, y, (-0.8, 0.55), (-0.25, 0.12), 0.08)
        tragus = 3.2 * np.exp(-((x + 0.86) ** 2 + (y + 0.22) ** 2) / 0.12 ** 2)
        antitragus = 2.2 * np.exp(-((x + 0.15) ** 2 + (y + 0.5) ** 2) / 0.11 ** 2)
        lobule = 1.2 * _smoothstep(-0.55, -0.95, y)
        return 3.0 * rho * rho + helix + scapha + antihelix + concha + crus + tragus + antitragus + lobule

    def half_thickness(self, x, y):
        rho = np.sqrt(x * x + y * y)
        t = np.clip((rho - (1.0 - self.RIM)) / self.RIM, 0.0, 1.0)
        return 0.5 * _EAR_THICKNESS * np.sqrt(np.maximum(1.0 - t * t, 0.0))

    def mid(self, x, y):
        a, b = self.plane(x, y)
        d = self.depth(x, y)
        return (self.origin + a[..., None] * self.back + b[..., None] * self.up
                + d[..., None] * self.normal)

    def sheet(self, x, y, front: bool):
        """Points of the front (outer) or back sheet and the mid-surface normal."""
        eps = 1e-3
        m = self.mid(x, y)
        mx = (self.mid(x + eps, y) - self.mid(x - eps, y))
        my = (self.mid(x, y + eps) - self.mid(x, y - eps))
        n = np.cross(mx, my)
        n *= np.sign(np.sum(n * self.normal, axis=-1, keepdims=True))
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        h = self.half_thickness(x, y)[..., None]
        return m + (h if front else -h) * n


# ---------------------------------------------------------------------------------------------
# helpers

def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


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


# ---------------------------------------------------------------------------------------------
# generation

def _generate(detail: int, seed: int) -> dict[str, np.ndarray]:
    spacing, res = _LEVELS[detail]
    th_max = _theta_max()

    # mean meridian arc length S(θ) and mean circumference C(θ) from a coarse pass
    th_c = np.linspace(0.0, th_max, 181)
    ph_c = np.linspace(-np.pi, np.pi, 73)
    tt, pp = np.meshgrid(th_c, ph_c, indexing="ij")
    pc = _RAY_ORIGIN + _direction(tt, pp) * _cast(tt, pp)[..., None]
    # root-mean-square over the columns, so grazing columns (neck sides, nose) get more rows
    seg = np.sqrt(np.mean(np.linalg.norm(np.diff(pc, axis=0), axis=2) ** 2, axis=1))
    s_of_theta = np.concatenate([[0.0], np.cumsum(seg)])
    circumference = np.linalg.norm(np.diff(pc, axis=1), axis=2).sum(axis=1)
    # the band's UV width follows the circumference but never shrinks to nothing at the pole
    # (the underside of the collar cut gets a little stretched texture instead of a UV point)
    circ_uv = np.maximum(circumference, _POLE_CIRC)

    # atlas scale (uv per mm): band across the bottom, crown cap and four ear islands on top
    s_cap = np.interp(_THETA_CAP, th_c, s_of_theta)
    band_height = s_of_theta[-1] - s_cap
    ears = [_Ear(+1.0), _Ear(-1.0)]
    ear_w = 2 * (_Ear.half_width(np.linspace(-1, 1, 201)).max() + 0.5)  # bounding width of an ear island (mm)
    ear_h = 2 * _Ear.HEIGHT
    band_width = circumference[th_c >= _THETA_CAP].max()
    top_row = max(2 * s_cap, ear_h)
    k = min((1 - 2 * _UV_MARGIN) / band_width,
            (1 - 2 * _UV_MARGIN - _UV_GUTTER) / (band_height + top_row),
            (1 - 2 * _UV_MARGIN - 4 * _UV_GUTTER) / (2 * s_cap + 4 * ear_w))
    v_band_top = _UV_MARGIN + k * band_height
    v_row = v_band_top + _UV_GUTTER                        # bottom of the top row
    cap_centre = np.array([_UV_MARGIN + k * s_cap, v_row + k * s_cap])

    def band_uv(theta, phi):
        c = np.interp(theta, th_c, circ_uv)
        u = 0.5 + k * c * phi / (2 * np.pi)
        v = _UV_MARGIN + k * (s_of_theta[-1] - np.interp(theta, th_c, s_of_theta))
        return np.stack([u, v], axis=-1)

    def cap_uv(theta, phi):
        rho = k * np.interp(theta, th_c, s_of_theta)
        return cap_centre + rho[..., None] * np.stack([np.sin(phi), -np.cos(phi)], axis=-1)

    ear_origins = []  # (uv origin of the island, mirror sign) per (ear, sheet)
    u0 = cap_centre[0] + k * s_cap + _UV_GUTTER
    for ear in ears:
        for front in (True, False):
            mirror = ear.side if front else -ear.side
            centre_u = u0 + 0.5 * k * ear_w
            ear_origins.append((ear, front, np.array([centre_u - mirror * k * _Ear.A_C,
                                                      v_row + 0.5 * k * ear_h]), mirror))
            u0 += k * ear_w + _UV_GUTTER

    # the two eyeball disks to the right of the ears
    eye_uv_r = min(0.095, (1 - _UV_MARGIN - u0 - _UV_GUTTER) / 4, (1 - _UV_MARGIN - v_row) / 2)
    eye_layout = (eye_uv_r, [np.array([u0 + eye_uv_r, v_row + eye_uv_r]),
                             np.array([u0 + 3 * eye_uv_r + _UV_GUTTER, v_row + eye_uv_r])])

    def ear_uv(ear_origin, x, y):
        ear, _, o, mirror = ear_origin
        a, b = ear.plane(x, y)
        return o + k * np.stack([mirror * a, b], axis=-1)

    # --- head mesh: band grid, finer over the face; cap from Delaunay rings -------------------
    face_rows = lambda th: 1.0 + 0.7 * _smoothstep(1.0, 1.25, th) * (1 - _smoothstep(2.45, 2.65, th))
    face_cols = lambda ph: 1.0 + 0.8 * np.exp(-(ph / 0.85) ** 2)
    mm_per_rad_row = band_height / (th_max - _THETA_CAP)
    n_th = _warp_count(_THETA_CAP, th_max, face_rows, spacing, mm_per_rad_row)
    n_ph = _warp_count(-np.pi, np.pi, face_cols, spacing, band_width / (2 * np.pi))
    # rows uniform in arc length (then warped towards the face), so neck rows are not stretched
    s_rows = _warp(s_cap, s_of_theta[-1], n_th,
                   lambda s: face_rows(np.interp(s, s_of_theta, th_c)))
    theta_b = np.interp(s_rows, s_of_theta, th_c)
    phi_b = _warp(-np.pi, np.pi, n_ph, face_cols)
    # the cap rows of the radius table (for texel lookups) are cast with the band
    theta_top = np.linspace(0.0, _THETA_CAP, max(int(np.ceil(s_cap / spacing)), 4) + 1)[:-1]
    theta_t = np.concatenate([theta_top, theta_b])
    tt, pp = np.meshgrid(theta_t, phi_b, indexing="ij")
    radius_table = _cast(tt, pp)
    n_top = len(theta_top)
    band_p = _RAY_ORIGIN + _direction(tt[n_top:], pp[n_top:]) * radius_table[n_top:, :, None]
    band_p[-1] = band_p[-1, 0]  # the pole row: one 3D point (exactly, so normals weld there)
    band_uvs = band_uv(tt[n_top:], pp[n_top:])
    ii = np.arange(n_th * n_ph).reshape(n_th, n_ph)
    q0, q1, q2, q3 = ii[:-1, :-1], ii[:-1, 1:], ii[1:, 1:], ii[1:, :-1]
    # the last row's (q0, q2, q3) triangles would have two corners on the pole: zero area, dropped
    band_tris = np.concatenate([np.stack([q0, q1, q2], -1).reshape(-1, 3),
                                np.stack([q0, q2, q3], -1)[:-1].reshape(-1, 3)])
    # eye windows: the band cells around each eye are re-triangulated (Delaunay in the band's
    # (φ, s) parameters) over finer points, finest along the lid margins
    eye_windows = []
    positions, uvs, keep_tri = [band_p.reshape(-1, 3)], [band_uvs.reshape(-1, 2)], np.ones(len(band_tris), bool)
    base = n_th * n_ph
    extra_tris = []
    cell = 0.25 * (band_p[:-1, :-1] + band_p[:-1, 1:] + band_p[1:, :-1] + band_p[1:, 1:])
    for side in (1.0, -1.0):
        box = ((side * cell[..., 0] > 14.0) & (side * cell[..., 0] < 50.0) & (cell[..., 1] > -3.0)
               & (cell[..., 1] < 27.0) & (cell[..., 2] > 50.0))
        ci, cj = np.nonzero(box)
        i0, i1, j0, j1 = ci.min(), ci.max() + 1, cj.min(), cj.max() + 1   # vertex index rectangle
        eye_windows.append((theta_b[i0], theta_b[i1], phi_b[j0], phi_b[j1]))
        quad_i = np.concatenate([np.repeat(np.arange(n_th - 1), n_ph - 1),
                                 np.repeat(np.arange(n_th - 1), n_ph - 1)[:-(n_ph - 1)]])
        quad_j = np.concatenate([np.tile(np.arange(n_ph - 1), n_th - 1),
                                 np.tile(np.arange(n_ph - 1), n_th - 2)])
        keep_tri &= ~((quad_i >= i0) & (quad_i < i1) & (quad_j >= j0) & (quad_j < j1))
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
        f_th = np.interp(f_s, s_of_theta, th_c)
        f_p = _RAY_ORIGIN + _direction(f_th, f_phi) * _cast(f_th, f_phi)[:, None]
        rho, lon, lat, alpha = _eye_coords(np.abs(f_p[:, 0]), f_p[:, 1], f_p[:, 2])
        near = (np.abs(_aperture(rho, lon, lat)) < 1.6) & (rho < _eye_radius(alpha) + 4.0)
        sel = coarse.ravel() | near
        pts = np.concatenate([rim_xy, np.stack([f_phi[sel] * sx, f_s[sel] * sy], axis=1)])
        simp = Delaunay(pts).simplices
        e1, e2 = pts[simp[:, 1]] - pts[simp[:, 0]], pts[simp[:, 2]] - pts[simp[:, 0]]
        simp = simp[np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) > 1e-6 * h * h]
        local = np.concatenate([ii[bi[rim], bj[rim]], base + np.arange(sel.sum())])
        extra_tris.append(local[simp])
        positions.append(f_p[sel])
        uvs.append(band_uv(f_th[sel], f_phi[sel]))
        base += int(sel.sum())
    tris = [band_tris[keep_tri]] + extra_tris

    # cap: top band row as its boundary (same 3D points), rings inside, pole in the middle
    ring_phi = phi_b[:-1]
    inner = _disk_points(s_cap, spacing, with_rim=False)
    in_s = np.linalg.norm(inner, axis=1)
    in_phi = np.arctan2(inner[:, 0], -inner[:, 1])
    in_theta = np.interp(in_s, s_of_theta, th_c)
    in_p = _RAY_ORIGIN + _direction(in_theta, in_phi) * _cast(in_theta, in_phi)[:, None]
    cap_p = np.concatenate([band_p[0, :-1], in_p])
    cap_uvs = np.concatenate([cap_uv(np.full(len(ring_phi), _THETA_CAP), ring_phi),
                              cap_uv(in_theta, in_phi)])
    cap_tris = Delaunay(cap_uvs).simplices + base
    positions.append(cap_p)
    uvs.append(cap_uvs)
    tris.append(cap_tris)
    base += len(cap_p)
    head_tris = _orient(np.concatenate(tris), np.concatenate(positions),
                        np.concatenate(positions)[np.concatenate(tris)].mean(axis=1) - _RAY_ORIGIN)
    tris = [head_tris]

    # ears: unit-disk rings (dense towards the rim so it rounds), two sheets sharing the rim
    ear_spacing = spacing * 0.54 / _Ear.HEIGHT  # ears are small and curled: finer
    disk = _disk_points(1.0 - _Ear.RIM, ear_spacing)
    n_rim = max(int(round(2 * np.pi / ear_spacing)), 24)
    for f in (0.45, 0.8, 0.95, 1.0):
        a = (np.arange(n_rim) + 0.5 * (f < 1)) * 2 * np.pi / n_rim
        rr = 1.0 - _Ear.RIM * (1 - f)
        disk = np.concatenate([disk, np.stack([rr * np.cos(a), rr * np.sin(a)], axis=1)])
    disk_tris = Delaunay(disk).simplices
    for ear_origin in ear_origins:
        ear, front = ear_origin[0], ear_origin[1]
        p = ear.sheet(disk[:, 0], disk[:, 1], front)
        ref = ear.normal if front else -ear.normal
        t = _orient(disk_tris + base, np.concatenate(positions + [p]), np.broadcast_to(ref, (len(disk_tris), 3)))
        positions.append(p)
        uvs.append(ear_uv(ear_origin, disk[:, 0], disk[:, 1]))
        tris.append(t)
        base += len(p)

    # eyeballs: closed globes with a corneal bulge; one azimuthal UV disk each (front pole in the
    # middle, the back compressed towards the rim, the back pole's ring collapsed in 3D)
    n_seg, n_ring = {0: (16, 10), 1: (28, 15), 2: (48, 24)}[detail]
    alpha_l = _limbus_alpha()
    rings = _warp(0.0, np.pi, n_ring + 1,
                  lambda al: 1.0 + 2.0 * np.exp(-((al - alpha_l) / 0.15) ** 2) + 1.5 * (al < 1.4))
    beta = np.arange(n_seg) * 2 * np.pi / n_seg
    ring_a, ring_b = np.meshgrid(rings[1:], beta, indexing="ij")
    eye_alpha = np.concatenate([[0.0], ring_a.ravel()])
    eye_beta = np.concatenate([[0.0], ring_b.ravel()])
    rr = _eye_radius(eye_alpha)
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
    eye_uv_r, eye_centres = eye_layout
    for side, cuv in zip((1.0, -1.0), eye_centres):
        centre = _EYE_C * np.array([side, 1.0, 1.0])
        p = centre + rr[:, None] * eye_dir * np.array([side, 1.0, 1.0])
        p[-n_seg:] = centre + np.array([0.0, 0.0, -_EYE_R])
        t = _orient(eye_tris + base, np.concatenate(positions + [p]),
                    p[eye_tris].mean(axis=1) - centre)
        positions.append(p)
        uvs.append(cuv + _eye_uv_radius(eye_alpha)[:, None] * eye_uv_r
                   * np.stack([np.cos(eye_beta), np.sin(eye_beta)], axis=1))
        tris.append(t)
        base += len(p)

    positions = np.concatenate(positions)
    uvs = np.concatenate(uvs)
    indices = np.concatenate(tris)
    # drop vertices no triangle uses (one pole-row vertex of the band)
    used = np.zeros(len(positions), dtype=bool)
    used[indices.ravel()] = True
    remap = np.cumsum(used) - 1
    positions, uvs, indices = positions[used], uvs[used], remap[indices]
    normals = _welded_normals(positions, indices)

    maps = _paint(res, seed, k, th_c, s_of_theta, circ_uv, theta_t, phi_b, radius_table,
                  cap_centre, ear_origins, v_band_top, eye_windows, eye_layout)
    return {"positions": positions.astype(np.float32), "normals": normals,
            "uvs": uvs.astype(np.float32), "indices": indices.astype(np.uint32), **maps}


def _welded_normals(positions, indices):
    """Smooth normals across UV seams and the ear rims: coincident vertices share one normal."""
    _, canon = np.unique(positions, axis=0, return_inverse=True)
    canon = canon.ravel()
    first = np.zeros(canon.max() + 1, dtype=np.int64)
    first[canon[::-1]] = np.arange(len(canon))[::-1]
    welded = first[canon]
    return vertex_normals(positions, welded[indices])[welded]


# ---------------------------------------------------------------------------------------------
# texture maps

def _paint(res, seed, k, th_c, s_of_theta, circumference, theta_t, phi_b, radius_table,
           cap_centre, ear_origins, v_band_top, eye_windows, eye_layout):
    rng = np.random.default_rng(seed)
    uv = (np.stack(np.meshgrid(np.arange(res), np.arange(res), indexing="xy"), axis=-1) + 0.5) / res
    u, v = uv[..., 0], uv[..., 1]
    point = np.zeros((res, res, 3))
    island = np.zeros((res, res), dtype=np.int8)  # 0 gutter, 1 band, 2 cap, 3 ear, 4 eyeball

    # texel -> (θ, φ) -> radius table -> 3D, inverting the band and cap maps analytically
    def head_point(theta, phi):
        ti = np.interp(theta, theta_t, np.arange(len(theta_t)))
        pj = np.interp(phi, phi_b, np.arange(len(phi_b)))
        r = ndimage.map_coordinates(radius_table, [ti, pj], order=1, mode="nearest")
        return _RAY_ORIGIN + _direction(theta, phi) * r[:, None]

    band = v <= v_band_top
    s = s_of_theta[-1] - (v[band] - _UV_MARGIN) / k
    theta = np.interp(s, s_of_theta, th_c)
    phi = (u[band] - 0.5) * 2 * np.pi / (k * np.interp(theta, th_c, circumference))
    ok = (np.abs(phi) <= np.pi) & (theta >= _THETA_CAP)
    idx = np.flatnonzero(band)[ok]
    point.reshape(-1, 3)[idx] = head_point(theta[ok], phi[ok])
    # the eye windows are meshed finer than the radius table: cast their texels exactly
    th_ok, ph_ok = theta[ok], phi[ok]
    for th0, th1, ph0, ph1 in eye_windows:
        w = (th_ok >= th0) & (th_ok <= th1) & (ph_ok >= min(ph0, ph1)) & (ph_ok <= max(ph0, ph1))
        point.reshape(-1, 3)[idx[w]] = (_RAY_ORIGIN + _direction(th_ok[w], ph_ok[w])
                                        * _cast(th_ok[w], ph_ok[w])[:, None])
    island.reshape(-1)[idx] = 1

    d = uv - cap_centre
    rho = np.linalg.norm(d, axis=-1) / k
    cap = rho <= np.interp(_THETA_CAP, th_c, s_of_theta)
    theta = np.interp(rho[cap], s_of_theta, th_c)
    phi = np.arctan2(d[cap][:, 0], -d[cap][:, 1])
    point[cap] = head_point(theta, phi)
    island[cap] = 2

    for ear, front, o, mirror in ear_origins:
        a = (u - o[0]) / (k * mirror)
        b = (v - o[1]) / k
        x, y = ear.from_plane(a, b)
        inside = (x * x + y * y <= 1.0) & (np.abs(y) <= 1.0)
        point[inside] = ear.sheet(x[inside], y[inside], front)
        island[inside] = 3

    eye_uv_r, eye_centres = eye_layout
    eye_polar = np.zeros((res, res, 2))  # (alpha, beta) on the eyeball
    for side, cuv in zip((1.0, -1.0), eye_centres):
        du, dv = u - cuv[0], v - cuv[1]
        frac = np.hypot(du, dv) / eye_uv_r
        inside = frac <= 1.0
        al = _eye_uv_alpha(frac[inside])
        be = np.arctan2(dv[inside], du[inside])
        eye_polar[inside] = np.stack([al, be], axis=1)
        dirs = np.stack([side * np.sin(al) * np.cos(be), np.sin(al) * np.sin(be), np.cos(al)], axis=1)
        point[inside] = _EYE_C * np.array([side, 1.0, 1.0]) + _eye_radius(al)[:, None] * dirs
        island[inside] = 4

    skin = (island > 0) & (island < 4)
    eyes = island == 4
    p = point[skin]
    region = _regions(p, island[skin])
    albedo, spec, pore_gain = _skin_colour(p, region, rng)
    eye_albedo = _eye_colour(eye_polar[eyes], np.random.default_rng(seed + 7919), res, eyes)

    # tangent-space normal map from a pore height field, in mm per texel of the local surface
    gain = np.zeros((res, res))
    gain[skin] = pore_gain
    height = _pores(res, rng) * ndimage.gaussian_filter(gain, 2.0)
    mm_u = np.linalg.norm(np.gradient(point, axis=1), axis=-1)  # mm per texel along +u
    mm_v = np.linalg.norm(np.gradient(point, axis=0), axis=-1)  # along +v (rows)
    scale = 1.0 / (k * res)
    mm_u = np.where(skin & (mm_u > 0.1 * scale) & (mm_u < 4 * scale), mm_u, scale)
    mm_v = np.where(skin & (mm_v > 0.1 * scale) & (mm_v < 4 * scale), mm_v, scale)
    dh_du = np.gradient(height, axis=1) / mm_u
    dh_dv = np.gradient(height, axis=0) / mm_v
    slope = np.hypot(dh_du, dh_dv)
    limit = np.minimum(1.0, 1.2 / np.maximum(slope, 1e-9))  # keep normals within ~50° of the mesh's
    n = np.stack([-dh_du * limit, -dh_dv * limit, np.ones_like(height)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)

    full_albedo = np.zeros((res, res, 3))
    full_albedo[skin] = albedo
    full_albedo[eyes] = eye_albedo
    full_spec = np.zeros((res, res, 1))
    full_spec[skin, 0] = spec
    full_spec[eyes, 0] = 0.9   # wet cornea and conjunctiva
    full_region = np.zeros((res, res), dtype=np.uint8)
    full_region[skin] = region
    full_region[eyes] = _REGION["other"]
    n[eyes] = (0.0, 0.0, 1.0)  # smooth: the cornea's bulge is in the mesh

    # fill the gutters from the nearest island texel
    filled = island > 0
    _, (ri, ci) = ndimage.distance_transform_edt(~filled, return_indices=True)
    out = {
        "albedo": full_albedo[ri, ci],
        "normal_map": (n * 0.5 + 0.5)[ri, ci],
        "specular_map": full_spec[ri, ci],
    }
    # the maps are stored as float16 (cache size); round here so fresh and cached heads agree
    out = {key: np.clip(val, 0.0, 1.0).astype(np.float16) for key, val in out.items()}
    out["region_map"] = full_region[ri, ci]
    return out


def _hair(p):
    """Cropped-hair coverage in [0, 1]: above a hairline that recedes at the temples, drops to
    sideburns in front of the ears, passes over them and ends at the nape."""
    az = np.abs(np.arctan2(p[:, 0], p[:, 2] - _RAY_ORIGIN[2]))
    knots = ([0.0, 0.55, 0.9, 1.12, 1.28, 1.42, 1.75, 2.1, np.pi],
             [82.0, 78.0, 58.0, 34.0, 8.0, 30.0, 26.0, -30.0, -62.0])
    line = np.interp(az, *knots)
    return _smoothstep(line - 3.0, line + 6.0, p[:, 1])


def _brow_y(ax):
    """Height of the eyebrow's centre line (mm) at a distance ax from the midline."""
    return 30.5 + 5.5 * np.exp(-((ax - 31.0) / 15.0) ** 2) - 0.004 * (ax - 30.0) ** 2


def _jaw_y(z):
    """Height of the jaw line / under-jaw crease (neck below it) at depth z."""
    return np.interp(z, [-120.0, -40.0, 0.0, 40.0, 70.0, 90.0], [-72.0, -72.0, -96.0, -110.0, -116.0, -118.0])


def _regions(p, island):
    """Region ID per skin point from smooth anatomical landmark shapes (mm)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax = np.abs(x)
    ell = lambda cx, cy, sx, sy: ((ax - cx) / sx) ** 2 + ((y - cy) / sy) ** 2
    r = np.full(len(p), _REGION["other"], dtype=np.uint8)
    front = z > 30.0
    r[front & (ell(36.0, -28.0, 30.0, 40.0) < 1.0)] = _REGION["cheeks"]
    r[front & (y >= _brow_y(ax) - 1.0) & (ell(0.0, 30.0, 58.0, 200.0) < 1.0)] = _REGION["forehead"]
    r[(z > 45.0) & (ell(0.0, -104.0, 30.0, 24.0) < 1.0)] = _REGION["chin"]
    lips = (ax / 25.0) ** 2 + ((y + 63.5) / np.where(y > -63.5, 10.0, 11.5)) ** 2 < 1.0
    r[lips & (z > 78.0)] = _REGION["lips"]
    nose_w = 7.5 + 14.0 * _smoothstep(8.0, -36.0, y)
    nose = (y < 22.0) & (y > -46.0 + 0.08 * ax * ax / 4) & (ax < nose_w) & (z > 82.0)
    r[nose] = _REGION["nose"]
    r[(y < _jaw_y(z)) & (r != _REGION["chin"])] = _REGION["neck"]
    r[(y < -122.0)] = _REGION["neck"]
    r[(_hair(p) > 0.5) | (island == 2)] = _REGION["scalp"]
    r[island == 3] = _REGION["ears"]
    return r


def _fbm(p, rng, base_mm, octaves):
    """Fractal value noise at 3D points (seamless across UV seams), roughly in [-1, 1]."""
    total = np.zeros(len(p))
    amp, freq, norm = 1.0, 1.0 / base_mm, 0.0
    for _ in range(octaves):
        lattice = rng.standard_normal((32, 32, 32))
        coords = (p * freq + rng.uniform(0, 32, 3)).T
        total += amp * ndimage.map_coordinates(lattice, coords, order=3, mode="grid-wrap", prefilter=False)
        norm += amp
        amp, freq = amp * 0.5, freq * 2.0
    return total / (0.4 * norm)


def _brow_strokes(ax, y, rng):
    """Eyebrow hair strokes in [0, 1]: noise stretched along the hair direction (up at the inner
    end, sweeping outwards and slightly down along the arch)."""
    lattice = rng.standard_normal((96, 512))
    ang = np.radians(75.0) - np.radians(70.0) * _smoothstep(12.0, 26.0, ax)   # hair direction
    s = y - _brow_y(ax)
    along = ax * np.cos(ang) + s * np.sin(ang)
    across = -ax * np.sin(ang) + s * np.cos(ang)
    n = ndimage.map_coordinates(lattice, [along / 3.5 + 40.0, across / 0.45 + 200.0], order=1,
                                mode="grid-wrap")
    return _smoothstep(-0.2, 0.9, n)


def _skin_colour(p, region, rng):
    """sRGB albedo, specular scale and pore depth per skin point."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax = np.abs(x)
    g = lambda cx, cy, cz, sx, sy, sz: np.exp(-0.5 * (((ax - cx) / sx) ** 2 + ((y - cy) / sy) ** 2
                                                      + ((z - cz) / sz) ** 2))
    # linear-light reflectances of light skin
    base = np.array([0.62, 0.40, 0.31])
    red = np.array([0.60, 0.27, 0.22])
    col = np.tile(base, (len(p), 1))
    is_ = lambda name: (region == _REGION[name]).astype(float)
    # flushed cheeks, nose tip and alae, ears; a little on the chin and forehead centre
    blush = (0.6 * g(38, -24, 70, 16, 16, 30) + 0.55 * g(0, -28, 110, 10, 9, 10)
             + 0.45 * g(11, -33, 97, 6, 6, 6) + 0.65 * is_("ears") + 0.2 * g(0, -100, 85, 14, 10, 15)
             + 0.12 * g(0, 45, 90, 25, 20, 20))
    col = col + (red - col) * np.clip(blush, 0, 1)[:, None] * 0.6
    # beard shadow: stubble under the skin over the upper lip, chin, jaw and lower cheeks
    beard = (_smoothstep(-38.0, -52.0, y + 0.15 * ax) * _smoothstep(-128.0, -112.0, y)
             * _smoothstep(-20.0, 15.0, z) * (1 - _smoothstep(55.0, 70.0, ax)))
    beard = np.maximum(beard, _smoothstep(-42.0, -50.0, y) * _smoothstep(-75.0, -70.0, y)
                       * (1 - _smoothstep(20.0, 30.0, ax)) * _smoothstep(80.0, 92.0, z))
    lips = (ax / 24.0) ** 2 + ((y + 63.5) / np.where(y > -63.5, 9.0, 10.5)) ** 2
    lip_w = _smoothstep(1.0, 0.7, lips) * _smoothstep(78.0, 86.0, z)
    beard *= 1 - _smoothstep(1.6, 1.1, lips)
    col = col * (1.0 - beard[:, None] * np.array([0.16, 0.12, 0.05]))
    col = col + (np.array([0.52, 0.18, 0.16]) - col) * lip_w[:, None] * 0.8
    # eyebrows (hair strokes), lash line and upper-lid crease, nostrils; scalp shows cropped hair
    by = _brow_y(ax)
    brow_mask = (_smoothstep(6.0, 2.0, np.abs(y - by + 0.02 * (ax - 30.0)))
                 * _smoothstep(54.0, 46.0, ax) * _smoothstep(8.0, 14.0, ax) * (z > 60.0))
    brow = brow_mask * (0.35 + 0.6 * _brow_strokes(ax, y, rng))
    # lid margins: a lash line along the upper lid (heavier laterally), a fainter lower one, the
    # upper-lid crease above it, pink conjunctiva inside the fissure (the caruncle at the corners)
    rho, lon, lat, alpha = _eye_coords(ax, y, z)
    up, lo = _fissure(lon)
    surf = _eye_radius(alpha)
    # the painted lines end inside the medial corner: where the margins converge they would
    # otherwise run on towards the nose as thin strokes
    in_lon = (_smoothstep(_LON_C - 0.05, _LON_C - 0.35, lon) * _smoothstep(-_LON_M + 0.25, -_LON_M + 0.55, lon)
              * (rho < 26.0))
    du, dl = rho * (lat - up), rho * (lo - lat)   # mm beyond the upper / lower margin
    lash = in_lon * ((0.8 + 0.15 * _smoothstep(-0.5, 0.8, lon)) * _smoothstep(1.9, 0.5, du) * _smoothstep(-1.2, -0.2, du)
                     + 0.45 * _smoothstep(1.0, 0.2, dl) * _smoothstep(-1.2, -0.2, dl))
    crease = 0.22 * in_lon * np.exp(-((du - 7.0) / 1.2) ** 2)
    conj = _smoothstep(surf + 0.6, surf - 0.2, rho) * (rho < 20.0)
    col = col + (np.array([0.50, 0.20, 0.18]) - col) * (0.8 * conj)[:, None]
    nostril = g(6.8, -39.5, 100.0, 2.6, 2.2, 4.0)
    scalp = _hair(p) * (region != _REGION["ears"])
    hair = np.array([0.07, 0.05, 0.035])
    col = col + (hair - col) * np.clip(0.85 * brow + 0.7 * lash, 0, 1)[:, None]
    col = col * (1.0 - crease - 0.85 * np.clip(nostril, 0, 1))[:, None]
    col = col + (np.array([0.28, 0.20, 0.16]) - col) * (0.55 * scalp)[:, None]
    col = col * np.array([1.0, 1.02, 1.03]) ** is_("neck")[:, None]
    # low-frequency mottling (fBm) in brightness and redness
    mottle = _fbm(p, rng, 40.0, 4)
    redness = _fbm(p, rng, 15.0, 2)
    col = col * (1.0 + 0.07 * mottle)[:, None]
    col = col + np.array([0.03, -0.012, -0.012]) * redness[:, None]
    albedo = np.where(col <= 0.0031308, 12.92 * col, 1.055 * np.clip(col, 0, None) ** (1 / 2.4) - 0.055)

    spec_by_region = np.array([0.5, 0.8, 0.85, 0.45, 0.65, 0.7, 0.4, 0.4, 0.3])
    spec = spec_by_region[region] * (1.0 + 0.1 * redness) * (1.0 - 0.5 * brow)
    pore_by_region = np.array([0.6, 0.8, 1.2, 1.0, 0.2, 0.8, 0.4, 0.5, 0.5])  # mm of pore depth ×10
    return albedo, spec, pore_by_region[region] * 0.1


def _eye_colour(polar, rng, res, eyes):
    """sRGB albedo of eyeball texels from (alpha, beta) on the globe: a warm grey sclera reddening
    towards the corners with a few thin veins, a dark limbal ring, a blue-grey iris with radial
    fibres, a darker outer rim and a warmer collarette, and a near-black pupil."""
    al, be = polar[:, 0], polar[:, 1]
    r_perp = _eye_radius(al) * np.sin(al)        # mm from the visual axis
    lateral = np.abs(np.sin(al) * np.cos(be))   # towards either canthus
    wrap = lambda lattice, a, b: ndimage.map_coordinates(lattice, [a, b], order=1, mode="grid-wrap")
    # sclera: warm grey, pinker and veined towards the canthi, darker behind the globe
    col = np.tile(np.array([0.66, 0.60, 0.54]), (len(al), 1))
    corner = _smoothstep(0.45, 0.95, lateral) * _smoothstep(0.6, 1.1, al)
    veins_n = ndimage.gaussian_filter(rng.standard_normal((64, 96)), 1.5, mode="wrap")
    veins_n /= np.abs(veins_n).max()
    vein = _smoothstep(0.05, 0.0, np.abs(wrap(veins_n, al / np.pi * 64, (be / (2 * np.pi)) * 96)))
    vein *= _smoothstep(0.65, 1.1, al) * (0.3 + 0.7 * corner)
    red = np.clip(0.45 * corner + 0.6 * vein, 0.0, 1.0)
    col = col + (np.array([0.55, 0.22, 0.19]) - col) * red[:, None]
    col *= (1.0 - 0.5 * _smoothstep(1.4, 2.0, al))[:, None]
    # iris: radial fibres (noise stretched along the radius), crypts, collarette, dark outer rim
    r_pupil, r_iris = 1.9, 6.0
    t = np.clip((r_perp - r_pupil) / (r_iris - r_pupil), 0.0, 1.0)
    fib = rng.standard_normal((720, 12))
    fibres = wrap(fib, (be / (2 * np.pi)) * 720, t * 8.0) / 2.0
    crypt_n = ndimage.gaussian_filter(rng.standard_normal((90, 8)), 0.8, mode="wrap")
    crypts = _smoothstep(0.25, 0.6, wrap(crypt_n / np.abs(crypt_n).max(), (be / (2 * np.pi)) * 90, t * 6.0))
    iris = np.array([0.15, 0.23, 0.30]) + (np.array([0.26, 0.21, 0.12]) - np.array([0.15, 0.23, 0.30])) \
        * (0.7 * _smoothstep(0.42, 0.22, t))[:, None]
    iris = iris * np.clip(0.75 + 0.45 * fibres - 0.35 * crypts, 0.3, 1.6)[:, None]
    iris *= (1.0 - 0.55 * _smoothstep(0.72, 1.0, t) - 0.15 * np.exp(-((t - 0.33) / 0.05) ** 2))[:, None]
    w_iris = _smoothstep(r_iris + 0.35, r_iris - 0.05, r_perp) * (al < 1.0)
    col = col + (iris - col) * w_iris[:, None]
    limbal = np.exp(-((r_perp - (r_iris - 0.05)) / 0.35) ** 2) * (al < 1.0)
    col = col + (np.array([0.05, 0.05, 0.06]) - col) * (0.85 * limbal)[:, None]
    pupil = _smoothstep(r_pupil + 0.15, r_pupil - 0.1, r_perp)
    col = col + (np.array([0.012, 0.012, 0.015]) - col) * pupil[:, None]
    return np.where(col <= 0.0031308, 12.92 * col, 1.055 * np.clip(col, 0, None) ** (1 / 2.4) - 0.055)


def _pores(res, rng):
    """Unit-depth pore field in texel space: sparse pits over fine bumpy noise (zero mean)."""
    pits = (rng.random((res, res)) < 0.08).astype(float)
    pits = ndimage.gaussian_filter(pits, 0.7, mode="wrap")
    bumps = ndimage.gaussian_filter(rng.standard_normal((res, res)), 1.2, mode="wrap")
    h = -pits / max(pits.max(), 1e-9) + 0.6 * bumps / max(np.abs(bumps).max(), 1e-9)
    return h - h.mean()
