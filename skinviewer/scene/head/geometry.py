"""The default head's shape: one implicit surface (the FEATURES table folded with smooth CSG),
open eyelids around separate eyeballs, and thin two-sheet ears.

The surface is star-shaped about RAY_ORIGIN: a vertex is found by casting a ray from there along
the spherical direction (θ from +Y, φ from +Z towards +X), so the skin is a radial function r(θ, φ)
with no folds and every texel maps straight back to a 3D point.
"""
from __future__ import annotations

import numpy as np

from skinviewer.scene.head.landmarks import CUT, EAR, EYE, FEATURES, Feature
from skinviewer.scene.head.shapes import capsule, ellipsoid, smax, smin, smoothstep

RAY_ORIGIN = np.array([0.0, -5.0, -12.0])   # inside the skull; the neck axis runs under it
CAST_RADII = (10.0, 260.0, 26)                # coarse ray samples (mm): the farthest skin is ~235 mm out

EYE_C = np.array(EYE["centre"])
EYE_R = EYE["radius"]
LON_C = np.radians(EYE["lateral_canthus"])
LON_M = np.radians(EYE["medial_canthus"])


# ---------------------------------------------------------------------------------------------
# eyes: separate closed eyeballs in the orbits, eyelids of the head surface open around them

def eye_radius(alpha):
    """Eyeball surface distance from its centre at angle alpha from the visual axis (+Z): the
    sclera sphere with the corneal cap (a smaller sphere) blended on."""
    rc, d = EYE["cornea_radius"], EYE_R + EYE["cornea_height"] - EYE["cornea_radius"]
    cornea = d * np.cos(alpha) + np.sqrt(np.maximum(rc ** 2 - (d * np.sin(alpha)) ** 2, 0.0))
    return smax(np.full_like(cornea, EYE_R), cornea, 0.6)


def limbus_alpha() -> float:
    """Angle from the visual axis where the cornea meets the sclera."""
    al = np.linspace(0.0, 1.2, 2401)
    rc, d = EYE["cornea_radius"], EYE_R + EYE["cornea_height"] - EYE["cornea_radius"]
    cornea = d * np.cos(al) + np.sqrt(np.maximum(rc ** 2 - (d * np.sin(al)) ** 2, 0.0))
    return float(al[np.argmax(cornea < EYE_R)])


def fissure(lon):
    """Upper and lower lid margins (latitude, rad) at horizontal angle lon about the eye centre
    (+ lateral): an almond between the canthi, the lateral canthus ~2 mm above the medial one,
    the upper lid over the top quarter of the iris, the lower lid at the iris's lower edge."""
    t = np.clip(lon / np.where(lon < 0, LON_M, LON_C), -1.0, 1.0)
    c0, lift = EYE["canthus_tilt"]
    canth = np.radians(c0 + lift * t)
    w = 1.0 - t * t
    up = canth + np.radians(EYE["upper_lid"]) * w ** 0.6 * (1.0 - 0.2 * t)
    lo = canth - np.radians(EYE["lower_lid"]) * w ** 0.8 * (1.0 + 0.1 * t)
    return up, lo


def eye_coords(ax, y, z):
    """(rho, lon, lat, alpha) about the eye centre; ax = |x| so both eyes share it."""
    qx, qy, qz = ax - EYE_C[0], y - EYE_C[1], z - EYE_C[2]
    rho = np.sqrt(qx * qx + qy * qy + qz * qz) + 1e-9
    lon = np.arctan2(qx, qz)
    lat = np.arcsin(np.clip(qy / rho, -1.0, 1.0))
    alpha = np.arccos(np.clip(qz / rho, -1.0, 1.0))
    return rho, lon, lat, alpha


def aperture(rho, lon, lat):
    """Signed distance-like (mm) to the palpebral fissure's cone: negative inside the opening."""
    up, lo = fissure(lon)
    return rho * np.maximum(np.maximum(lat - up, lo - lat), np.maximum(lon - LON_C, -lon - LON_M))


def eyelids(d, ax, y, z):
    """Open eyelids: the orbit inside the fissure is emptied down to just behind the eyeball, the
    lids are a shell over the globe (following the corneal bulge) cut by the fissure with a
    rounded margin, and a thin layer of hidden conjunctiva sits just behind the eyeball."""
    rho, lon, lat, alpha = eye_coords(ax, y, z)
    surf = eye_radius(alpha)
    a = aperture(rho, lon, lat)
    gap = EYE["lid_gap"]
    carve = np.maximum(a, np.maximum(surf - gap - rho, rho - surf - 6.0))
    d = smax(d, -carve, 0.5)
    t0, t_up = EYE["lid_thickness"]
    thick = t0 + t_up * smoothstep(-0.35, 0.15, lat)          # upper lid thicker than the lower
    lid = smax(rho - surf - thick, -a, 1.2)
    d = smin(d, lid, 2.0)
    return np.minimum(d, rho - surf + gap)


# ---------------------------------------------------------------------------------------------
# the implicit head

def _feature_distance(f: Feature, x, ax, y, z):
    px = (ax if f.mirrored else x) * f.x_scale
    if f.taper is not None:
        amount, z0, z1 = f.taper
        px = px / (1.0 - amount * smoothstep(z0, z1, z))
    if f.shape == "ellipsoid":
        c = f.a if not f.bend else (f.a[0], f.a[1] + f.bend * x * x, f.a[2])
        return ellipsoid(px, y, z, c, f.b)
    return capsule(px, y, z, f.a, f.b, *f.radii)


def head_sdf(x, y, z):
    """Signed distance (mm, approximate) to the skin of head and neck, FEATURES folded in order."""
    ax = np.abs(x)
    d = None
    for f in FEATURES:
        if f.shape == "eyelids":
            d = eyelids(d, ax, y, z)
            continue
        fd = _feature_distance(f, x, ax, y, z)
        if f.op == "base":
            d = fd
            continue
        k = f.blend
        if f.blend_back is not None:
            extra, z0, z1 = f.blend_back
            k = k + extra * smoothstep(z0, z1, z)
        d = smin(d, fd, k) if f.op == "add" else smax(d, -fd, k)
    return smax(d, cut_y(x, z) - y, CUT["blend"])


def cut_y(x, z):
    """Height of the collar cut at (x, z)."""
    return CUT["y"] + CUT["slope"] * (z - 40.0) - CUT["drop"] * x * x


def direction(theta, phi):
    st = np.sin(theta)
    return np.stack([st * np.sin(phi), np.cos(theta), st * np.cos(phi)], axis=-1)


def cast(theta, phi):
    """Radius of the head surface along each ray from RAY_ORIGIN (outermost sign change)."""
    d = direction(np.ravel(theta), np.ravel(phi))
    o = RAY_ORIGIN

    def f(r):
        p = o + d * r[:, None]
        return head_sdf(p[:, 0], p[:, 1], p[:, 2])

    radii = np.linspace(*CAST_RADII)
    inside = np.stack([f(np.full(len(d), r)) < 0 for r in radii])
    last = len(radii) - 1 - np.argmax(inside[::-1], axis=0)  # outermost inside sample
    lo, hi = radii[last], radii[np.minimum(last + 1, len(radii) - 1)]
    for _ in range(15):
        mid = 0.5 * (lo + hi)
        neg = f(mid) < 0
        lo, hi = np.where(neg, mid, lo), np.where(neg, hi, mid)
    return (0.5 * (lo + hi)).reshape(np.shape(theta))


def surface_point(theta, phi):
    """Skin points along the rays (θ, φ)."""
    return RAY_ORIGIN + direction(theta, phi) * cast(theta, phi)[..., None]


# ---------------------------------------------------------------------------------------------
# ears: thin closed shells over a planar outline

class Ear:
    """One ear. The outline is a unit disk (x, y) mapped to ear-plane mm (a back, b up):
    b = HEIGHT y, a = A_C + W(y) x, wider at the helix than at the lobe. The mid-surface is displaced
    along the ear plane's normal (helix rim, scapha, antihelix, concha bowl); the two sheets sit
    ±T/2 along the mid-surface normal, closing with a rounded rim."""

    HEIGHT, A_C = EAR["height"], EAR["centre_back"]
    RIM = EAR["rim"]

    def __init__(self, side: float):
        self.side = side
        tilt, flare = np.radians(EAR["tilt"]), np.radians(EAR["flare"])
        up = np.array([0.0, np.cos(tilt), -np.sin(tilt)])
        back = np.array([side * np.sin(flare), 0.0, -np.cos(flare)])
        back -= up * back.dot(up)
        self.back = back / np.linalg.norm(back)
        self.up = up
        n = np.cross(self.up, self.back)
        self.normal = n * np.sign(n[0] * side)
        # attach the outline's front edge to the skin just in front of the tragus
        th, ph = np.radians(EAR["attach"][0]), side * np.radians(EAR["attach"][1])
        self.origin = surface_point(np.array([th]), np.array([ph]))[0]

    @staticmethod
    def half_width(y):
        """Half the outline's width (mm): broad at the helix, narrowing to a rounded lobe."""
        c0, c1, c2 = EAR["half_width"]
        return c0 + c1 * y + c2 * y * y

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
        lobe = 1.0 - smoothstep(-0.45, -0.75, y)
        helix = 2.8 * smoothstep(0.72, 0.97, rho) * smoothstep(-0.95, -0.35, x + 0.4 * y) * lobe
        scapha = -1.6 * np.exp(-((rho - 0.8) / 0.07) ** 2) * lobe
        antihelix = 2.0 * np.exp(-((rho - 0.58) / 0.1) ** 2) * smoothstep(-0.5, 0.2, x + 0.3 * y) * lobe
        antihelix += 1.4 * self._ridge(x, y, (0.1, 0.35), (-0.4, 0.72), 0.09)   # superior crus
        concha = -8.5 * np.exp(-((a - 5.0) ** 2 + (b + 3.0) ** 2) / (2 * 7.5 ** 2))
        crus = 1.8 * self._ridge(x, y, (-0.8, 0.55), (-0.25, 0.12), 0.08)
        tragus = 3.0 * np.exp(-((x + 0.84) ** 2 + (y + 0.22) ** 2) / 0.2 ** 2)
        antitragus = 2.0 * np.exp(-((x + 0.15) ** 2 + (y + 0.5) ** 2) / 0.17 ** 2)
        lobule = 1.2 * smoothstep(-0.55, -0.95, y)
        return 3.0 * rho * rho + helix + scapha + antihelix + concha + crus + tragus + antitragus + lobule

    def half_thickness(self, x, y):
        """Half the flap's thickness: thin (EAR thickness[0]) over the helix and scapha, thicker
        towards the root behind the concha, rounding off to the rim."""
        a, b = self.plane(x, y)
        ca, cb, sa, sb = EAR["root"]
        thin, thick = EAR["thickness"]
        root = np.exp(-0.5 * (((a - ca) / sa) ** 2 + ((b - cb) / sb) ** 2))
        rho = np.sqrt(x * x + y * y)
        t = np.clip((rho - (1.0 - self.RIM)) / self.RIM, 0.0, 1.0)
        return 0.5 * (thin + (thick - thin) * root) * np.sqrt(np.maximum(1.0 - t * t, 0.0))

    def mid(self, x, y):
        a, b = self.plane(x, y)
        d = self.depth(x, y)
        return (self.origin + a[..., None] * self.back + b[..., None] * self.up
                + d[..., None] * self.normal)

    def sheet(self, x, y, front: bool):
        """Points of the front (outer) or back sheet: the mid-surface is a height field over the
        ear plane, and so are both sheets, offset ±h along the plane's normal (an offset along
        the mid-surface normal folds where the helix and tragus curve tighter than h)."""
        h = self.half_thickness(x, y)[..., None]
        return self.mid(x, y) + (h if front else -h) * self.normal
