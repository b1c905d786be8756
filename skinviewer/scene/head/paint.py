"""The default head's texture maps: albedo (sRGB), tangent-space normal map (pores), specular
scale and region IDs, painted per texel from the 3D point the atlas maps it to."""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from skinviewer.ground.constants import REGIONS
from skinviewer.scene.head.atlas import (
    ISLAND_CAP,
    ISLAND_EAR,
    ISLAND_EYE,
    Atlas,
    RadiusTable,
)
from skinviewer.scene.head.geometry import (
    LON_C,
    LON_M,
    RAY_ORIGIN,
    eye_coords,
    eye_radius,
    fissure,
)
from skinviewer.scene.head.landmarks import (
    BLUSH,
    BLUSH_EARS,
    BROW,
    EYE,
    HAIR,
    HAIRLINE,
    JAW_LINE,
    NOSTRIL_SHADE,
    PORES_BY_REGION,
    REGION_SHAPES,
    SKIN_COLOURS,
    SPECULAR_BY_REGION,
)
from skinviewer.scene.head.shapes import smoothstep

REGION = {name: i for i, name in enumerate(REGIONS)}


def _srgb(col):
    return np.where(col <= 0.0031308, 12.92 * col, 1.055 * np.clip(col, 0, None) ** (1 / 2.4) - 0.055)


def hair(p, jitter=None):
    """Cropped-hair coverage in [0, 1]: above a hairline that recedes at the temples, drops to
    sideburns in front of the ears, passes over them and ends in a U at the nape. The edge is
    soft (HAIR edge, mm) and, given ``jitter`` (noise in [-1, 1] per point), irregular."""
    az = np.abs(np.arctan2(p[:, 0], p[:, 2] - RAY_ORIGIN[2]))
    line = np.interp(az, *HAIRLINE)
    if jitter is not None:
        line = line + HAIR["jitter"] * jitter
    lo, hi = HAIR["edge"]
    return smoothstep(line + lo, line + hi, p[:, 1])


def brow_y(ax):
    """Height of the eyebrow's centre line (mm) at a distance ax from the midline."""
    b = BROW
    return b["base"] + b["lift"] * np.exp(-((ax - b["peak_x"]) / b["width"]) ** 2) - b["droop"] * (ax - 30.0) ** 2


def jaw_y(z):
    """Height of the jaw line / under-jaw crease (neck below it) at depth z."""
    return np.interp(z, *JAW_LINE)


def regions(p, island):
    """Region ID per skin point from smooth anatomical landmark shapes (mm)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax = np.abs(x)
    sh = REGION_SHAPES

    def ell(name):
        (cx, cy), (sx, sy) = sh[name]["centre"], sh[name]["axes"]
        return (((ax - cx) / sx) ** 2 + ((y - cy) / sy) ** 2 < 1.0) & (z > sh[name]["z_min"])

    # every skin point gets a named region ("other" is left to the eyeballs, i.e. non-skin)
    above_brow = y >= brow_y(ax) - 1.0
    r = np.where(above_brow, REGION["forehead"], REGION["cheeks"]).astype(np.uint8)
    r[ell("cheeks")] = REGION["cheeks"]
    r[above_brow & ell("forehead")] = REGION["forehead"]
    r[ell("chin")] = REGION["chin"]
    lp = sh["lips"]
    half_h = np.where(y > lp["centre"][1], lp["axes"][1], lp["axes"][2])
    lips = (ax / lp["axes"][0]) ** 2 + ((y - lp["centre"][1]) / half_h) ** 2 < 1.0
    r[lips & (z > lp["z_min"])] = REGION["lips"]
    ns = sh["nose"]
    nose_w = ns["width"][0] + ns["width"][1] * smoothstep(ns["widen"][0], ns["widen"][1], y)
    nose = (y < ns["top"]) & (y > ns["bottom"] + 0.02 * ax * ax) & (ax < nose_w) & (z > ns["z_min"])
    r[nose] = REGION["nose"]
    r[(y < jaw_y(z)) & (r != REGION["chin"])] = REGION["neck"]
    r[(y < sh["neck_below"])] = REGION["neck"]
    r[(hair(p) > 0.5) | (island == ISLAND_CAP)] = REGION["scalp"]
    r[island == ISLAND_EAR] = REGION["ears"]
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
    ang = np.radians(75.0) - np.radians(70.0) * smoothstep(12.0, 26.0, ax)   # hair direction
    s = y - brow_y(ax)
    along = ax * np.cos(ang) + s * np.sin(ang)
    across = -ax * np.sin(ang) + s * np.cos(ang)
    n = ndimage.map_coordinates(lattice, [along / 3.5 + 40.0, across / 0.45 + 200.0], order=1, mode="grid-wrap")
    return smoothstep(-0.2, 0.9, n)


def skin_colour(p, region, rng):
    """sRGB albedo, specular scale and pore depth per skin point."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax = np.abs(x)
    g = lambda cx, cy, cz, sx, sy, sz: np.exp(-0.5 * (((ax - cx) / sx) ** 2 + ((y - cy) / sy) ** 2
                                                      + ((z - cz) / sz) ** 2))
    # linear-light reflectances of light skin
    c = {k: np.array(v) for k, v in SKIN_COLOURS.items()}
    red = c["flush"]
    col = np.tile(c["base"], (len(p), 1))
    is_ = lambda name: (region == REGION[name]).astype(float)
    # flushed cheeks, nose tip and alae, ears; a little on the chin and forehead centre
    blush = BLUSH_EARS * is_("ears") + sum(w * g(*centre, *sigma) for w, centre, sigma in BLUSH)
    col = col + (red - col) * np.clip(blush, 0, 1)[:, None] * 0.6
    # beard shadow: stubble under the skin over the upper lip, chin, jaw and lower cheeks
    beard = (smoothstep(-38.0, -52.0, y + 0.15 * ax) * smoothstep(-128.0, -112.0, y)
             * smoothstep(-20.0, 15.0, z) * (1 - smoothstep(55.0, 70.0, ax)))
    beard = np.maximum(beard, smoothstep(-42.0, -50.0, y) * smoothstep(-75.0, -70.0, y)
                       * (1 - smoothstep(20.0, 30.0, ax)) * smoothstep(80.0, 92.0, z))
    lips = (ax / 24.0) ** 2 + ((y + 63.5) / np.where(y > -63.5, 9.0, 10.5)) ** 2
    lip_w = smoothstep(1.0, 0.7, lips) * smoothstep(78.0, 86.0, z)
    beard *= 1 - smoothstep(1.6, 1.1, lips)
    col = col * (1.0 - beard[:, None] * c["beard"])
    col = col + (c["lips"] - col) * lip_w[:, None] * 0.8
    # eyebrows (hair strokes), lash line and upper-lid crease, nostrils; scalp shows cropped hair
    by = brow_y(ax)
    brow_mask = (smoothstep(6.0, 2.0, np.abs(y - by + 0.02 * (ax - 30.0)))
                 * smoothstep(54.0, 46.0, ax) * smoothstep(8.0, 14.0, ax) * (z > 60.0))
    brow = brow_mask * (0.35 + 0.6 * _brow_strokes(ax, y, rng))
    # lid margins: a lash line along the upper lid (heavier laterally), a fainter lower one, the
    # upper-lid crease above it, pink conjunctiva inside the fissure (the caruncle at the corners)
    rho, lon, lat, alpha = eye_coords(ax, y, z)
    up, lo = fissure(lon)
    surf = eye_radius(alpha)
    # the painted lines end inside the medial corner: where the margins converge they would
    # otherwise run on towards the nose as thin strokes
    in_lon = (smoothstep(LON_C - 0.05, LON_C - 0.35, lon) * smoothstep(-LON_M + 0.25, -LON_M + 0.55, lon)
              * (rho < 26.0))
    du, dl = rho * (lat - up), rho * (lo - lat)   # mm beyond the upper / lower margin
    lash = in_lon * ((0.8 + 0.15 * smoothstep(-0.5, 0.8, lon)) * smoothstep(1.9, 0.5, du) * smoothstep(-1.2, -0.2, du)
                     + 0.45 * smoothstep(1.0, 0.2, dl) * smoothstep(-1.2, -0.2, dl))
    crease = 0.22 * in_lon * np.exp(-((du - 7.0) / 1.2) ** 2)
    conj = smoothstep(surf + 0.6, surf - 0.2, rho) * (rho < 20.0)
    col = col + (c["conjunctiva"] - col) * (0.8 * conj)[:, None]
    nostril = g(*NOSTRIL_SHADE[0], *NOSTRIL_SHADE[1])
    col = col + (c["brow"] - col) * np.clip(0.85 * brow + 0.7 * lash, 0, 1)[:, None]
    col = col * (1.0 - crease - 0.85 * np.clip(nostril, 0, 1))[:, None]
    col = col * np.array([1.0, 1.02, 1.03]) ** is_("neck")[:, None]
    # low-frequency mottling (fBm) in brightness and redness, on skin, not under the hair
    scalp = hair(p, _fbm(p, rng, 12.0, 2)) * (region != REGION["ears"])
    mottle = _fbm(p, rng, 40.0, 4)
    redness = _fbm(p, rng, 15.0, 2)
    bare = 1.0 - scalp
    col = col * (1.0 + 0.07 * mottle * bare)[:, None]
    col = col + np.array([0.03, -0.012, -0.012]) * (redness * bare)[:, None]
    # cropped hair: a smooth dark-brown cover with the scalp showing through, fine strands
    strands = 1.0 + 0.12 * _fbm(p, rng, 1.5, 2)
    col = col + (np.array(HAIR["colour"]) * strands[:, None] - col) * (HAIR["cover"] * scalp)[:, None]

    spec = np.array(SPECULAR_BY_REGION)[region] * (1.0 + 0.1 * redness) * (1.0 - 0.5 * brow)
    spec = spec + (HAIR["specular"] - spec) * scalp   # smooth across the hairline
    return _srgb(col), spec, np.array(PORES_BY_REGION)[region] * 0.1


def eye_colour(polar, rng):
    """sRGB albedo of eyeball texels from (alpha, beta) on the globe: a warm grey sclera reddening
    towards the corners with a few thin veins, a dark limbal ring, a blue-grey iris with radial
    fibres, a darker outer rim and a warmer collarette, and a near-black pupil."""
    al, be = polar[:, 0], polar[:, 1]
    r_perp = eye_radius(al) * np.sin(al)        # mm from the visual axis
    lateral = np.abs(np.sin(al) * np.cos(be))   # towards either canthus
    wrap = lambda lattice, a, b: ndimage.map_coordinates(lattice, [a, b], order=1, mode="grid-wrap")
    # sclera: warm grey, pinker and veined towards the canthi, darker behind the globe
    col = np.tile(np.array([0.66, 0.60, 0.54]), (len(al), 1))
    corner = smoothstep(0.45, 0.95, lateral) * smoothstep(0.6, 1.1, al)
    veins_n = ndimage.gaussian_filter(rng.standard_normal((64, 96)), 1.5, mode="wrap")
    veins_n /= np.abs(veins_n).max()
    vein = smoothstep(0.05, 0.0, np.abs(wrap(veins_n, al / np.pi * 64, (be / (2 * np.pi)) * 96)))
    vein *= smoothstep(0.65, 1.1, al) * (0.3 + 0.7 * corner)
    red = np.clip(0.45 * corner + 0.6 * vein, 0.0, 1.0)
    col = col + (np.array([0.55, 0.22, 0.19]) - col) * red[:, None]
    col *= (1.0 - 0.5 * smoothstep(1.4, 2.0, al))[:, None]
    # iris: radial fibres (noise stretched along the radius), crypts, collarette, dark outer rim
    r_pupil, r_iris = EYE["pupil_radius"], EYE["iris_radius"]
    t = np.clip((r_perp - r_pupil) / (r_iris - r_pupil), 0.0, 1.0)
    fib = rng.standard_normal((720, 12))
    fibres = wrap(fib, (be / (2 * np.pi)) * 720, t * 8.0) / 2.0
    crypt_n = ndimage.gaussian_filter(rng.standard_normal((90, 8)), 0.8, mode="wrap")
    crypts = smoothstep(0.25, 0.6, wrap(crypt_n / np.abs(crypt_n).max(), (be / (2 * np.pi)) * 90, t * 6.0))
    iris = np.array([0.15, 0.23, 0.30]) + (np.array([0.26, 0.21, 0.12]) - np.array([0.15, 0.23, 0.30])) \
        * (0.7 * smoothstep(0.42, 0.22, t))[:, None]
    iris = iris * np.clip(0.75 + 0.45 * fibres - 0.35 * crypts, 0.3, 1.6)[:, None]
    iris *= (1.0 - 0.55 * smoothstep(0.72, 1.0, t) - 0.15 * np.exp(-((t - 0.33) / 0.05) ** 2))[:, None]
    w_iris = smoothstep(r_iris + 0.35, r_iris - 0.05, r_perp) * (al < 1.0)
    col = col + (iris - col) * w_iris[:, None]
    limbal = np.exp(-((r_perp - (r_iris - 0.05)) / 0.35) ** 2) * (al < 1.0)
    col = col + (np.array([0.05, 0.05, 0.06]) - col) * (0.85 * limbal)[:, None]
    pupil = smoothstep(r_pupil + 0.15, r_pupil - 0.1, r_perp)
    col = col + (np.array([0.012, 0.012, 0.015]) - col) * pupil[:, None]
    return _srgb(col)


def _pores(res, rng):
    """Unit-depth pore field in texel space: sparse pits over fine bumpy noise (zero mean)."""
    pits = (rng.random((res, res)) < 0.08).astype(float)
    pits = ndimage.gaussian_filter(pits, 1.0, mode="wrap")   # >= 2 texels across: no blocky texels
    bumps = ndimage.gaussian_filter(rng.standard_normal((res, res)), 1.6, mode="wrap")
    h = -pits / max(pits.max(), 1e-9) + 0.6 * bumps / max(np.abs(bumps).max(), 1e-9)
    return h - h.mean()


def _normal_map(point, skin, pore_gain, res, k, rng):
    """Tangent-space normals from a pore height field, its slopes in mm of the local surface."""
    mm_u = np.linalg.norm(np.gradient(point, axis=1), axis=-1)  # mm per texel along +u
    mm_v = np.linalg.norm(np.gradient(point, axis=0), axis=-1)  # along +v (rows)
    scale = 1.0 / (k * res)
    # where the atlas stretches texels (grazing rays on the neck, the pole), pores would become
    # streaks: fade them out beyond 1.5x the nominal texel size
    stretch = np.where(skin, np.maximum(mm_u, mm_v) / scale, 1.0)
    gain = np.zeros((res, res))
    gain[skin] = pore_gain
    gain /= np.maximum(1.0, stretch / 1.5) ** 2
    height = _pores(res, rng) * ndimage.gaussian_filter(gain, 2.0)
    mm_u = np.where(skin & (mm_u > 0.1 * scale) & (mm_u < 4 * scale), mm_u, scale)
    mm_v = np.where(skin & (mm_v > 0.1 * scale) & (mm_v < 4 * scale), mm_v, scale)
    dh_du = np.gradient(height, axis=1) / mm_u
    dh_dv = np.gradient(height, axis=0) / mm_v
    slope = np.hypot(dh_du, dh_dv)
    limit = np.minimum(1.0, 1.2 / np.maximum(slope, 1e-9))  # keep normals within ~50° of the mesh's
    n = np.stack([-dh_du * limit, -dh_dv * limit, np.ones_like(height)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def paint(atlas: Atlas, table: RadiusTable, res: int, seed: int) -> dict[str, np.ndarray]:
    """albedo, normal_map, specular_map (float16 in [0, 1]) and region_map (uint8) at res²."""
    rng = np.random.default_rng(seed)
    point, island, eye_polar = atlas.texels(res, table)
    skin = (island > 0) & (island < ISLAND_EYE)
    eyes = island == ISLAND_EYE
    p = point[skin]
    region = regions(p, island[skin])
    albedo, spec, pore_gain = skin_colour(p, region, rng)
    eye_albedo = eye_colour(eye_polar[eyes], np.random.default_rng(seed + 7919))
    n = _normal_map(point, skin, pore_gain, res, atlas.k, rng)

    full_albedo = np.zeros((res, res, 3))
    full_albedo[skin] = albedo
    full_albedo[eyes] = eye_albedo
    full_spec = np.zeros((res, res, 1))
    full_spec[skin, 0] = spec
    full_spec[eyes, 0] = 1.0   # wet cornea and conjunctiva: the catchlight
    full_region = np.zeros((res, res), dtype=np.uint8)
    full_region[skin] = region
    full_region[eyes] = REGION["other"]
    n[eyes] = (0.0, 0.0, 1.0)  # smooth: the cornea's bulge is in the mesh

    # fill the gutters from the nearest island texel
    _, (ri, ci) = ndimage.distance_transform_edt(island == 0, return_indices=True)
    out = {"albedo": full_albedo[ri, ci], "normal_map": (n * 0.5 + 0.5)[ri, ci], "specular_map": full_spec[ri, ci]}
    # the maps are stored as float16 (cache size); round here so fresh and cached heads agree
    out = {key: np.clip(val, 0.0, 1.0).astype(np.float16) for key, val in out.items()}
    out["region_map"] = full_region[ri, ci]
    return out
