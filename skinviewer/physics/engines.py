"""The engines' skin models as Burley normalized diffusion (seed 001 eq. 2.83-2.89), and back.

Every engine target describes subsurface scattering with Burley's profile (eq. 2.84)
    R(r) = A (e^(-r/d) + e^(-r/(3d))) / (8 pi d r),   2 pi int r R dr = A,
per colour channel, each with its own parametrisation of the shape distance d:

  target        stored                                   d (mm)                          source
  HDRP          scatteringDistance (colour) x            d = colour x multiplier         DiffusionProfileSettings.cs
                scatteringDistanceMultiplier, mm                                         UpdateKernel: S = 1/sd
  Unreal        SurfaceAlbedo A; MeanFreePathColor x      d = 10 l_cm / (0.6 s_86(A))     SubsurfaceProfile.cpp:
                MeanFreePathDistance = l (cm)                                            DMFP = mfp s_88/s_86 x10/0.6,
                                                                                         d = DMFP/s_88 (eq. 2.88)
  MaterialX     subsurface_color A; subsurface_radius x   d = l / s_89(A)                 Christensen-Burley as Cycles'
  (standard_    subsurface_scale = l (scene units)                                       bssrdf_burley_fitting (eq. 2.89,
  surface),     (OpenPBR: subsurface_radius_scale x                                      diffuse surface transmission)
  OpenPBR,      subsurface_radius)
  Blender       Subsurface Radius x Subsurface Scale = l

with Christensen's fits s_86 (eq. 2.86, searchlight + mfp), s_88 (eq. 2.88, searchlight + dmfp) and
s_89 (eq. 2.89, diffuse surface transmission). The OpenPBR and standard_surface specifications leave
the profile to the renderer; the Christensen-Burley reading (radius = mean free path, eq. 2.89) is the
one Blender's Cycles implements and is stated as this tool's convention.

The fit (``fit_burley``) is the profile lab's least squares run the other way: A and d per channel
minimise the L2 distance of r R(r) (the radial energy density; int of it is R_d / 2 pi) to the
current profile's, A in [0, 1] (every target clamps it). Its errors are what the engine loses:
    e_c  = ||r (R_c - B_c)|| / ||r R_c||   (L2 over r in (0, inf))
    e_Rd = |A_c - R_d,c| / R_d,c.

Specular: the Kelemen/Szirmay-Kalos lobe uses a Beckmann slope m (seed 000 eq. 15). The engines use
GGX with alpha = roughness^2 (perceptual roughness). We map alpha_GGX = m (Walter et al. 2007 §5.2:
the two distributions with equal alpha have the same slope variance near the peak), so
roughness = sqrt(m); HDRP smoothness = 1 - roughness. F0 -> IOR inverts Schlick's normal-incidence
Fresnel, F0 = ((n - 1)/(n + 1))^2, as HDRP's UpdateCache does the other way: n = (1 + sqrt F0)/(1 - sqrt F0).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import FloatArray
from skinviewer.physics.profiles import burley_normalized, burley_scale

TWO_PI = 2.0 * math.pi
UNREAL_DMFP_TO_MFP = 0.6  # SubsurfaceProfile.cpp Dmfp2MfpMagicNumber ("match BurleyNormalizedSSSCommon.ush")
MM_PER_CM = 10.0
MM_PER_M = 1000.0
TARGETS = ("hdrp", "unreal", "materialx", "openpbr", "blender")


# ---------------------------------------------------------------------------------------------
# units and specular conversions

def beckmann_to_roughness(m: float) -> float:
    """Perceptual (GGX, alpha = r^2) roughness of Beckmann slope m: alpha = m (see module doc)."""
    return float(math.sqrt(min(max(m, 0.0), 1.0)))


def roughness_to_beckmann(roughness: float) -> float:
    return float(min(max(roughness, 0.0), 1.0) ** 2)


def f0_to_ior(f0: float) -> float:
    """n with F0 = ((n - 1)/(n + 1))^2 (HDRP DiffusionProfileSettings.UpdateCache, inverted)."""
    s = math.sqrt(min(max(f0, 0.0), 0.999))
    return (1.0 + s) / (1.0 - s)


def ior_to_f0(ior: float) -> float:
    return ((ior - 1.0) / (ior + 1.0)) ** 2


# ---------------------------------------------------------------------------------------------
# Burley's d in each target's terms

def _rgb(x: ArrayLike, name: str) -> FloatArray:
    a = np.asarray(x, dtype=np.float64).reshape(-1)
    if a.size == 1:
        a = np.repeat(a, 3)
    if a.size != 3 or not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {x!r}")
    return a


def unreal_mfp_mm(A: ArrayLike, d_mm: ArrayLike) -> FloatArray:
    """Unreal's (UE5) mean free path in mm for Burley (A, d): l = 0.6 s_86(A) d."""
    out: FloatArray = UNREAL_DMFP_TO_MFP * burley_scale(np.clip(A, 0.0, 1.0), "searchlight-mfp") * np.asarray(d_mm, float)
    return out


def unreal_d_mm(A: ArrayLike, mfp_mm: ArrayLike) -> FloatArray:
    """d = DMFP / s_88(A) with DMFP = mfp s_88(A)/s_86(A) / 0.6 (SubsurfaceProfile.cpp,
    GetDiffuseMeanFreePathFromMeanFreePath): d = mfp / (0.6 s_86(A))."""
    return np.asarray(mfp_mm, float) / (UNREAL_DMFP_TO_MFP * burley_scale(np.clip(A, 0.0, 1.0), "searchlight-mfp"))


def cb_mfp_mm(A: ArrayLike, d_mm: ArrayLike) -> FloatArray:
    """Christensen-Burley radius (mean free path) for (A, d): l = s_89(A) d (eq. 2.89)."""
    out: FloatArray = burley_scale(np.clip(A, 0.0, 1.0), "diffuse-transmission") * np.asarray(d_mm, float)
    return out


def cb_d_mm(A: ArrayLike, mfp_mm: ArrayLike) -> FloatArray:
    return np.asarray(mfp_mm, float) / burley_scale(np.clip(A, 0.0, 1.0), "diffuse-transmission")


def split_colour(v: ArrayLike) -> tuple[tuple[float, float, float], float]:
    """A per-channel length as (colour with max 1, multiplier): how every target stores it."""
    a = np.asarray(v, float)
    m = float(np.max(a))
    if not (m > 0):
        raise ValueError("lengths must be > 0")
    c = a / m
    return (float(c[0]), float(c[1]), float(c[2])), m


# ---------------------------------------------------------------------------------------------
# the fit

@dataclass(frozen=True)
class BurleyFit:
    """Burley (A, d) per channel fitted to a profile, with what the fit loses."""
    A: FloatArray  # (3,) in [0, 1]
    d: FloatArray  # (3,) mm
    error: FloatArray  # (3,) relative L2 of r R(r)
    rd_target: FloatArray  # (3,) R_d of the fitted profile
    rd_error: FloatArray  # (3,) |A - R_d| / R_d

    def __call__(self, r: ArrayLike) -> FloatArray:
        return burley_profile(r, self.A, self.d)

    def to_dict(self) -> dict[str, Any]:
        return {"albedo": self.A.tolist(), "d_mm": self.d.tolist(), "error_rR": self.error.tolist(),
                "rd_target": self.rd_target.tolist(), "rd_error": self.rd_error.tolist()}


def burley_profile(r: ArrayLike, A: ArrayLike, d_mm: ArrayLike) -> FloatArray:
    """Eq. (2.84) per channel: A burley_normalized(r, d), shape np.shape(r) + (3,)."""
    r = np.asarray(r, float)
    return np.asarray(A, float) * burley_normalized(r[..., None], np.asarray(d_mm, float))


@dataclass(frozen=True)
class RGrid:
    """Radii (mm) and weights q with sum_j q_j f(r_j)^2 ~ int_0^inf f(r)^2 dr (f = r R)."""
    r: FloatArray
    q: FloatArray

    def norm(self, f: FloatArray) -> FloatArray:
        out: FloatArray = np.sqrt(self.q @ (np.asarray(f, float) ** 2))
        return out


def r_grid(profile: Callable[[FloatArray], ArrayLike], n: int = 400, rel: float = 1e-9) -> RGrid:
    """A log-spaced grid holding all but ``rel`` of int (r R_c)^2 dr in every channel (probed over
    1e-5..1e4 mm), trapezoid in log r: int f^2 dr = int r f^2 dlog r."""
    probe = np.geomspace(1e-5, 1e4, 361)  # 40 a decade
    f = probe[:, None] * _values(profile(probe))
    dens = probe[:, None] * f**2
    tot = dens.sum(0)
    live = tot > 0
    if not np.any(live):
        raise ValueError("the profile is zero everywhere")
    cum = np.cumsum(dens[:, live], 0) / tot[live]
    lo = probe[max(0, int(np.min(np.argmax(cum >= rel, 0))) - 1)]
    hi = probe[min(probe.size - 1, int(np.max(np.argmax(cum >= 1.0 - rel, 0))) + 1)]
    r = np.geomspace(lo, hi, n)
    t = np.log(r)
    q = np.zeros(n)
    dt = np.diff(t)
    q[:-1] += 0.5 * dt * r[:-1]
    q[1:] += 0.5 * dt * r[1:]
    q[0] += r[0]  # [0, r_0]: r R(r) is bounded near 0 for every model here
    return RGrid(r, q)


def _values(profile_values: ArrayLike) -> FloatArray:
    R = np.asarray(profile_values, np.float64)
    if R.ndim == 1:
        R = np.repeat(R[:, None], 3, 1)
    if not np.all(np.isfinite(R)):
        raise ValueError("the profile has non-finite values")
    return R


def relative_error(target: Callable[[FloatArray], ArrayLike], fitted: Callable[[FloatArray], ArrayLike],
                   grid: RGrid | None = None) -> FloatArray:
    """||r (R - F)|| / ||r R|| per channel (0 where the target is 0)."""
    g = grid or r_grid(target)
    T = g.r[:, None] * _values(target(g.r))
    F = g.r[:, None] * _values(fitted(g.r))
    den = g.norm(T)
    return np.where(den > 0, g.norm(T - F) / np.where(den > 0, den, 1.0), 0.0)


def total_reflectance(profile: Callable[[FloatArray], ArrayLike], grid: RGrid | None = None) -> FloatArray:
    """R_d = 2 pi int r R dr (the model's own closed form when it has one)."""
    if hasattr(profile, "total_reflectance"):
        return np.asarray(profile.total_reflectance(), float)
    probe = np.geomspace(1e-6, 1e4, 4001)
    return TWO_PI * np.asarray(np.trapezoid(probe[:, None] ** 2 * _values(profile(probe)), np.log(probe), axis=0))


def fit_burley(profile: Callable[[FloatArray], FloatArray], grid: RGrid | None = None,
               fixed_albedo: ArrayLike | None = None) -> BurleyFit:

    """Burley's A and d per channel by least squares on r R(r). For a fixed d the best A is linear
    (clamped to [0, 1], still the constrained optimum of a 1-D quadratic); d is found by a log-spaced
    scan and refined by Brent's bounded method on log d. ``fixed_albedo`` (3,): only d is fitted (a
    target that normalises the profile, HDRP, renders A = R_d whatever the fit's A)."""
    from scipy.optimize import minimize_scalar  # here, not at import: scipy costs the viewer's start (issue 34)
    g = grid or r_grid(profile)
    T = g.r[:, None] * _values(profile(g.r))
    rd = total_reflectance(profile, g)
    fixed = None if fixed_albedo is None else np.clip(_rgb(fixed_albedo, "albedo"), 0.0, 1.0)
    A = np.zeros(3)
    d = np.ones(3)
    err = np.zeros(3)
    for c in range(3):
        t = T[:, c]
        tn = math.sqrt(float(g.q @ t**2))
        if tn == 0:
            A[c], d[c] = 0.0, 1.0
            continue

        def cost(logd: float, c: int = c, t: FloatArray = t) -> tuple[float, float]:
            b = g.r * burley_normalized(g.r, math.exp(logd))
            bb = float(g.q @ (b * b))
            if fixed is not None:
                a = float(fixed[c])
            else:
                a = min(max(float(g.q @ (b * t)) / bb, 0.0), 1.0) if bb > 0 else 0.0
            res = t - a * b
            return float(g.q @ (res * res)), a

        logs = np.linspace(math.log(g.r[0]) - 2.0, math.log(g.r[-1]) + 1.0, 160)
        vals = [cost(x)[0] for x in logs]
        i = int(np.argmin(vals))
        lo, hi = logs[max(i - 1, 0)], logs[min(i + 1, logs.size - 1)]
        res = minimize_scalar(lambda x: cost(x)[0], bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-9})
        best = float(res.x) if res.fun <= vals[i] else float(logs[i])
        f, a = cost(best)
        A[c], d[c], err[c] = a, math.exp(best), math.sqrt(max(f, 0.0)) / tn
    with np.errstate(invalid="ignore", divide="ignore"):
        rd_err = np.where(rd > 0, np.abs(A - rd) / np.where(rd > 0, rd, 1.0), 0.0)
    return BurleyFit(A, d, err, rd, rd_err)


# ---------------------------------------------------------------------------------------------
# what each target stores, and back

@dataclass(frozen=True)
class EngineSkin:
    """A profile and specular in engine-neutral terms: Burley A and d (mm) per channel, GGX
    perceptual roughness, IOR. ``albedo_in_profile`` is False for HDRP (its profile is normalised:
    the albedo is the material's base colour)."""
    A: FloatArray
    d_mm: FloatArray
    roughness: float = 0.548
    ior: float = 1.4
    albedo_in_profile: bool = True

    def __post_init__(self) -> None:
        A = _rgb(self.A, "albedo")
        d = _rgb(self.d_mm, "scattering distance")
        if np.any(A < 0) or np.any(A > 1):
            raise ValueError(f"albedo must be in [0, 1], got {A.tolist()}")
        if np.any(d <= 0):
            raise ValueError(f"distances must be > 0, got {d.tolist()}")
        if not (0.0 <= self.roughness <= 1.0) or not math.isfinite(self.roughness):
            raise ValueError(f"roughness must be in [0, 1], got {self.roughness}")
        if not (1.0 <= self.ior <= 3.0) or not math.isfinite(self.ior):
            raise ValueError(f"IOR must be in [1, 3], got {self.ior}")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "d_mm", d)

    def __call__(self, r: ArrayLike) -> FloatArray:
        return burley_profile(r, self.A, self.d_mm)


def hdrp_values(skin: EngineSkin, metres_per_unit: float = 1.0) -> dict[str, Any]:
    """The DiffusionProfile fields (DiffusionProfileSettings.cs): distances in mm, worldScale = the
    size of one world unit in metres. The profile is normalised (albedo: the material's base colour)."""
    colour, mult = split_colour(skin.d_mm)
    return {"scatteringDistance": colour, "scatteringDistanceMultiplier": mult,
            "worldScale": float(metres_per_unit), "ior": float(skin.ior),
            "smoothness": 1.0 - skin.roughness}


def hdrp_skin(scattering_distance: ArrayLike, multiplier: float, ior: float = 1.4, smoothness: float | None = None) -> EngineSkin:
    d = _rgb(scattering_distance, "scatteringDistance") * float(multiplier)
    return EngineSkin(np.ones(3), d, 0.548 if smoothness is None else 1.0 - smoothness, ior, albedo_in_profile=False)


def unreal_values(skin: EngineSkin) -> dict[str, Any]:
    """FSubsurfaceProfileStruct (UE5, bEnableMeanFreePath): distances in cm (Unreal units)."""
    colour, dist_mm = split_colour(unreal_mfp_mm(skin.A, skin.d_mm))
    return {"surface_albedo": tuple(float(x) for x in skin.A), "mean_free_path_color": colour,
            "mean_free_path_distance": dist_mm / MM_PER_CM, "ior": float(skin.ior),
            "roughness": float(skin.roughness)}


def unreal_skin(surface_albedo: ArrayLike, mfp_color: ArrayLike, mfp_distance_cm: float, ior: float = 1.4,
                roughness: float = 0.548) -> EngineSkin:
    A = np.clip(_rgb(surface_albedo, "SurfaceAlbedo"), 0.0, 1.0)
    mfp = _rgb(mfp_color, "MeanFreePathColor") * float(mfp_distance_cm) * MM_PER_CM
    return EngineSkin(A, unreal_d_mm(A, mfp), roughness, ior)


def cb_values(skin: EngineSkin) -> dict[str, Any]:
    """Christensen-Burley radius (mean free path per channel, mm) as colour x scale (MaterialX,
    OpenPBR, Blender)."""
    colour, scale_mm = split_colour(cb_mfp_mm(skin.A, skin.d_mm))
    return {"subsurface_color": tuple(float(x) for x in skin.A), "radius_color": colour,
            "radius_scale_mm": scale_mm, "roughness": float(skin.roughness), "ior": float(skin.ior)}


def cb_skin(colour: ArrayLike, radius_color: ArrayLike, radius_scale_mm: float, roughness: float = 0.548, ior: float = 1.4) -> EngineSkin:
    A = np.clip(_rgb(colour, "subsurface colour"), 0.0, 1.0)
    mfp = _rgb(radius_color, "subsurface radius") * float(radius_scale_mm)
    return EngineSkin(A, cb_d_mm(A, mfp), roughness, ior)
