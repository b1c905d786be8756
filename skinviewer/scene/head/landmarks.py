"""The default head's anatomy as data: every landmark and feature size in millimetres, in one place.

Frame: Y up, the face looks along +Z, x = 0 is the midline; a feature marked ``mirrored`` is
evaluated at |x| (both sides). The implicit surface is built by folding ``FEATURES`` in order:
``add`` is a smooth union, ``cut`` a smooth subtraction, each with its blend width in mm.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Feature:
    """One primitive of the implicit head.

    shape ``ellipsoid``: ``a`` centre, ``b`` semi-axes; ``capsule``: segment ``a``-``b`` with radius
    tapering ``radii[0]`` -> ``radii[1]``; ``eyelids``: the open lids over the eyeballs (EYE below).
    Optional warps: ``x_scale`` multiplies x; ``taper = (amount, z0, z1)`` narrows x by ``amount``
    from z0 to z1 (a mandible narrowing towards the chin); ``bend`` lifts the centre by bend * x²
    (a curved mouth line); ``blend_back = (extra, z0, z1)`` widens the blend by ``extra`` from z0 to z1.
    """
    name: str
    op: str                  # "base" | "add" | "cut"
    shape: str               # "ellipsoid" | "capsule" | "eyelids"
    a: tuple = (0.0, 0.0, 0.0)
    b: tuple = (1.0, 1.0, 1.0)
    blend: float = 0.0
    mirrored: bool = False
    radii: tuple = (0.0, 0.0)
    x_scale: float = 1.0
    taper: tuple | None = None
    bend: float = 0.0
    blend_back: tuple | None = None


def E(name, op, centre, axes, blend=0.0, mirrored=False, **kw):
    return Feature(name, op, "ellipsoid", tuple(centre), tuple(axes), blend, mirrored, **kw)


def C(name, op, start, end, r0, r1, blend=0.0, mirrored=False, **kw):
    return Feature(name, op, "capsule", tuple(start), tuple(end), blend, mirrored, radii=(r0, r1), **kw)


FEATURES: tuple[Feature, ...] = (
    # neurocranium: braincase, the flatter more upright frontal bone, the occipital bulge behind
    E("braincase", "base", (0, 22, -8), (75, 93, 93)),
    E("frontal bone", "add", (0, 40, 8), (66, 64, 85), 20),
    E("occiput", "add", (0, 2, -64), (50, 46, 40), 22),
    E("temple", "cut", (100, 18, 38), (30, 40, 42), 25, True),
    # midface (maxilla), zygomatic bones (cheekbones) and the arches running back to the ears
    E("maxilla", "add", (0, -22, 24), (54, 56, 68), 30),
    E("zygoma", "add", (42, -4, 52), (19, 16, 20), 26, True),
    C("zygomatic arch", "add", (52, -8, 36), (63, -10, 8), 1.5, 1.5, 20, True),
    E("malar fat", "add", (28, -42, 74), (13, 14, 11), 14, True),
    # masseter and buccal fat fill the cheek between the cheekbone and the jaw angle
    E("masseter", "add", (44, -62, 24), (12, 24, 22), 26, True),
    E("buccal fat", "add", (34, -50, 54), (15, 19, 17), 26, True),
    # dental arch under the lips, and a mandible narrowing towards the chin
    E("dental arch", "add", (0, -66, 46), (37, 40, 47), 14),
    E("mandible mass", "add", (0, -70, 20), (45, 24, 60), 14, taper=(0.3, -5.0, 90.0)),
    # mandible: body along the jawline (gonion -> mental tubercle), ramus up towards the ear
    C("mandible body", "add", (46, -82, -2), (14, -106, 72), 8.0, 8.0, 12, True),
    C("ramus", "add", (47, -34, -6), (46, -82, -2), 6.5, 8.0, 16, True),
    E("chin", "add", (0, -105, 80), (16, 11, 9), 10),
    E("mentolabial sulcus", "cut", (0, -84, 97), (15, 3.0, 6), 8),
    # brow ridges (supraorbital), glabella, orbits, open lids over the eyeballs
    E("brow ridge", "add", (24, 30, 84), (23, 8, 11), 10, True),
    E("glabella", "add", (0, 27, 90), (12, 7, 6), 8),
    E("orbit", "cut", (32, 15, 95), (20, 15, 19), 7, True),
    Feature("eyelids", "add", "eyelids"),
    # nose: bridge from the nasion to the tip, alae (nostril wings), columella, nostrils
    C("nasal bridge", "add", (0, 17, 87), (0, -20, 106), 5.0, 7.5, 8, x_scale=1.15),
    E("nose tip", "add", (0, -27, 107), (8.5, 8.0, 9.0), 8),
    E("ala", "add", (11.5, -33, 96), (6.5, 6.0, 7.5), 6, True),
    E("columella", "add", (0, -37, 101), (3.4, 4.5, 9), 5),
    E("nostril", "cut", (6.8, -39.0, 100.5), (3.0, 2.6, 4.2), 3, True),
    E("alar crease", "cut", (19.5, -33, 95), (2.0, 8, 4), 4, True),
    # lips: upper lip with the cupid's bow, tubercle and philtrum; lower lip; mouth line; corners
    E("subnasale", "add", (0, -45, 94), (7, 5, 5), 8),
    E("upper lip", "add", (0, -56.5, 88), (23, 7, 10), 9),
    E("cupid's bow", "add", (6, -57, 95), (6, 4, 3.5), 4, True),
    E("tubercle", "add", (0, -61, 96.5), (4.5, 3, 3), 3.5),
    E("lower lip", "add", (0, -70.5, 88), (20, 6.5, 10), 9),
    E("mouth line", "cut", (0, -63.5, 101), (25, 0.9, 13), 2.5, bend=0.006),
    E("philtrum", "cut", (0, -49, 99.5), (2.6, 6, 3), 2),
    E("mouth corner", "cut", (25, -64, 82), (2.2, 2.2, 3.5), 4, True),
    C("nasolabial fold", "cut", (20, -37, 93), (30, -63, 85), 0.3, 0.5, 6, True),
    # neck: slightly forward-tilted, tapering up into the head (crisp under the jaw, soft at the
    # nape); sternocleidomastoids from behind the ears to the sternal notch; larynx; trapezius
    E("neck root", "add", (0, -55, -44), (52, 45, 52), 20),
    C("neck", "add", (0, -240, -22), (0, -100, -16), 60.0, 52.0, 8, x_scale=1.04, blend_back=(16.0, 10.0, -50.0)),
    C("sternocleidomastoid", "add", (40, -86, -34), (19, -194, 30), 7.0, 6.5, 26, True),
    E("thyroid cartilage", "add", (0, -135, 30.5), (9, 17, 8.5), 14),
    E("sternal notch", "cut", (0, -188, 48), (10, 9, 9), 6),
    C("trapezius", "add", (26, -120, -50), (50, -230, -38), 12.0, 14.0, 25, True),
    C("trapezius slope", "add", (36, -112, -38), (64, -192, -30), 14.0, 17.0, 26, True),
)

# collar cut: y = Y + SLOPE * (z - 40 mm) - DROP * x², lower at the back and down the shoulders,
# rounded over BLEND mm
CUT: dict[str, Any] = dict(y=-196.0, slope=0.17, drop=0.0025, blend=8.0)

# eyes: the right eyeball (x > 0; the left mirrors), its cornea, and the palpebral fissure
EYE: dict[str, Any] = dict(
    centre=(32.0, 12.0, 70.0),   # eyeball centre
    radius=12.0,                 # sclera (24 mm globe)
    cornea_radius=7.8,           # corneal curvature radius
    cornea_height=1.5,           # protrusion beyond the sclera
    lateral_canthus=75.0,        # deg, horizontal angle from the eye's axis
    medial_canthus=60.0,         # deg (the nose side: kept shallow)
    canthus_tilt=(-2.3, 4.7),    # deg: fissure centre line at the medial .. lift to the lateral canthus
    upper_lid=15.0,              # deg above the centre line at the middle of the fissure
    lower_lid=25.5,              # deg below it
    lid_gap=0.5,                 # hidden skin behind the eyeball inside the fissure
    lid_thickness=(1.4, 0.6),    # lower lid, extra for the upper lid
    iris_radius=6.0, pupil_radius=1.9,
)

# ears: a planar outline (a back, b up from the attachment in front of the tragus)
EAR: dict[str, Any] = dict(
    height=32.0,                 # half height of the outline
    centre_back=9.0,             # outline centre behind the attachment point
    half_width=(15.0, 3.5, -2.0),  # half width = c0 + c1 y + c2 y² (y in [-1, 1] down..up)
    thickness=(2.0, 4.8),        # between the two sheets: at the helix rim, at the root (concha)
    root=(5.0, -3.0, 6.0, 10.0),  # the root's centre (a, b) and extent (sa, sb) in the ear plane
    rim=0.09,                    # fraction of the unit disk over which the rim rounds off
    tilt=15.0, flare=24.0,       # deg: backwards lean, flare away from the head
    attach=(85.0, 88.0),         # deg (theta from +Y, phi from +Z) of the attachment ray
)

# hairline (cropped hair) height in mm against the azimuth about the skull (rad from the front)
# (a rounded U at the nape, not a V); HAIR: the soft edge's width, its jitter, the hair colour
HAIRLINE = ([0.0, 0.55, 0.9, 1.12, 1.28, 1.42, 1.75, 2.1, 2.5, np.pi],
            [82.0, 78.0, 58.0, 34.0, 8.0, 30.0, 26.0, -28.0, -50.0, -54.0])
HAIR: dict[str, Any] = dict(edge=(-6.0, 12.0), jitter=4.0, colour=(0.085, 0.062, 0.048), cover=0.72, specular=0.35)

# brow centre line y(|x|) = base + lift * exp(-((|x| - peak_x) / width)²) - droop * (|x| - 30)²
BROW: dict[str, Any] = dict(base=30.5, lift=5.5, peak_x=31.0, width=15.0, droop=0.004)

# jaw line (under-jaw crease) height against depth z: neck below it
JAW_LINE = ([-120.0, -40.0, 0.0, 40.0, 70.0, 90.0], [-72.0, -72.0, -96.0, -110.0, -116.0, -118.0])

# ---------------------------------------------------------------------------------------------
# paint: region shapes, flushes and colours (mm; |x|, y, z)

# facial regions as ellipses in (|x|, y): centre, semi-axes, and the depth the region starts at
REGION_SHAPES: dict[str, Any] = dict(
    cheeks=dict(centre=(36.0, -28.0), axes=(30.0, 40.0), z_min=30.0),
    forehead=dict(centre=(0.0, 30.0), axes=(58.0, 200.0), z_min=30.0),
    chin=dict(centre=(0.0, -104.0), axes=(30.0, 24.0), z_min=45.0),
    lips=dict(centre=(0.0, -63.5), axes=(25.0, 10.0, 11.5), z_min=78.0),   # upper, lower half-height
    nose=dict(top=22.0, bottom=-46.0, width=(7.5, 14.0), widen=(8.0, -36.0), z_min=82.0),
    neck_below=-122.0,
)

# flushed spots (Gaussian: weight, centre, sigma) where the skin is redder
BLUSH = (
    (0.60, (38, -24, 70), (16, 16, 30)),    # cheeks
    (0.55, (0, -28, 110), (10, 9, 10)),     # nose tip
    (0.45, (11, -33, 97), (6, 6, 6)),       # alae
    (0.20, (0, -100, 85), (14, 10, 15)),    # chin
    (0.12, (0, 45, 90), (25, 20, 20)),      # forehead centre
)
BLUSH_EARS = 0.65
NOSTRIL_SHADE = ((6.8, -39.5, 100.0), (2.6, 2.2, 4.0))

# linear-light reflectances
SKIN_COLOURS: dict[str, Any] = dict(base=(0.62, 0.40, 0.31), flush=(0.60, 0.27, 0.22), lips=(0.52, 0.18, 0.16),
                    conjunctiva=(0.50, 0.20, 0.18), brow=(0.07, 0.05, 0.035),
                    beard=(0.16, 0.12, 0.05))   # beard: fractional darkening per channel

# per region (order of settings.REGIONS: other, forehead, nose, cheeks, lips, chin, ears, neck,
# scalp): specular scale and pore depth (x 0.1 mm)
SPECULAR_BY_REGION = (1.0, 0.8, 0.85, 0.45, 0.65, 0.7, 0.4, 0.4, 0.3)
PORES_BY_REGION = (0.6, 0.8, 1.2, 1.0, 0.2, 0.8, 0.4, 0.5, 0.5)
