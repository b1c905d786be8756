"""One typed, validated settings model. Presets are its JSON; the viewer, presets and the CLI's
``--set key=value`` all edit this same object. Passes read only the dotted paths they declare.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from skinviewer.core.constants import MAX_GAUSSIANS, MAX_LIGHTS, MAX_PCF, REGIONS
from skinviewer.core.files import atomic_write_text  # noqa: F401  (presets are saved through it)

SCHEMA_VERSION = 1

Vec3 = tuple[float, float, float]



class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)


def _known_regions(v: dict) -> dict:
    bad = [k for k in v if k not in REGIONS]
    if bad:
        raise ValueError(f"unknown region(s) {bad}; known: {list(REGIONS)}")
    return v


def _finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError("must be a finite number")
    return v


class SceneSettings(_Model):
    name: Literal["head", "laser", "shadow-edge", "backlit-ear", "stretch-plane", "regions-plane"] = "head"
    mesh: str | None = Field(None, description="path of a glTF/GLB/OBJ/PLY mesh; overrides `name`")
    mm_per_unit: float | None = Field(
        None, gt=0, le=1e6, description="millimetres per mesh unit; None: the scene's own (built-ins are in mm)")
    albedo_map: str | None = None
    normal_map: str | None = None
    specular_map: str | None = None
    region_map: str | None = Field(None, description="region-ID PNG: red channel = index in REGIONS")
    head_detail: int = Field(1, ge=0, le=2, description="default head resolution level (0 small, 1 normal, 2 fine)")
    seam_aware: bool = Field(True, description="texture-space gutters near UV seams continue on the island across "
                             "the seam (3D adjacency), so blurs do not read invented values there (issue 10)")


class CameraSettings(_Model):
    yaw: float = Field(25.0, ge=-3600, le=3600, description="degrees about +Y")
    pitch: float = Field(5.0, ge=-89.0, le=89.0, description="degrees")
    distance: float | None = Field(None, gt=0, le=1e7, description="in mesh units; None: frame the mesh")
    target: Vec3 | None = Field(None, description="look-at point in mesh units; None: bounds centre")
    fov_y: float = Field(30.0, gt=1.0, lt=170.0, description="degrees")

    _f = field_validator("yaw", "pitch")(_finite)


class LightSettings(_Model):
    # beam: a collimated beam of radius beam_radius (mesh units) along -direction through position
    # (the laser of GPU Gems 3 §14.4.1)
    kind: Literal["directional", "point", "beam"] = "directional"
    color: Vec3 = (1.0, 1.0, 1.0)
    intensity: float = Field(3.0, ge=0.0, le=1e6)
    # directional: direction the light travels *from* (towards the light); point: position in mesh units
    direction: Vec3 = (0.4, 0.5, 1.0)
    position: Vec3 = (0.0, 0.0, 400.0)
    beam_radius: float = Field(0.05, gt=0.0, le=1e6)
    cast_shadow: bool = True
    enabled: bool = True

    @field_validator("color")
    @classmethod
    def _color(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 for c in v):
            raise ValueError("colour components must be finite and >= 0")
        return v

    @field_validator("direction")
    @classmethod
    def _dir(cls, v: Vec3) -> Vec3:
        if any(not math.isfinite(c) for c in v) or sum(c * c for c in v) < 1e-12:
            raise ValueError("direction must be a finite, non-zero vector")
        return v

    @field_validator("position")
    @classmethod
    def _pos(cls, v: Vec3) -> Vec3:
        if any(not math.isfinite(c) for c in v):
            raise ValueError("position must be finite")
        return v


class ShadowSettings(_Model):
    map_size: int = Field(1024, ge=64, le=8192)
    # seed 000 eq. (7): shadowed if d(P) - ds > tol; tol in normalised light-space depth
    tol: float = Field(0.002, ge=0.0, le=0.5)
    pcf: int = Field(1, ge=0, le=MAX_PCF, description="percentage-closer filter radius in texels (0 = eq. 7 hard test)")


class RenderSettings(_Model):
    width: int = Field(640, ge=16, le=8192)
    height: int = Field(640, ge=16, le=8192)
    exposure: float = Field(1.0, gt=0.0, le=1e4)
    background: Vec3 = (0.05, 0.05, 0.06)
    timing: Literal["sync", "gpu"] = Field(
        "sync", description="sync: glFinish + wall clock per pass (right on llvmpipe); gpu: GL timer queries")


class PhongSettings(_Model):
    ambient: float = Field(0.03, ge=0.0, le=10.0)
    specular: float = Field(0.25, ge=0.0, le=100.0)
    shininess: float = Field(32.0, ge=1.0, le=4096.0)


class RegionSpecular(_Model):
    m: float | None = Field(None, ge=0.0, le=1.0)
    rho_s: float | None = Field(None, ge=0.0, le=10.0)


class SpecularSettings(_Model):
    """Kelemen/Szirmay-Kalos (seed 000 eq. 14-16, seed 002 §14.3)."""
    m: float = Field(0.3, ge=0.0, le=1.0, description="Beckmann roughness")
    f0: float = Field(0.028, ge=0.0, le=1.0, description="Fresnel reflectance at normal incidence")
    rho_s: float = Field(0.18, ge=0.0, le=10.0, description="specular intensity")
    mode: Literal["direct", "beckmann_lut"] = "direct"
    lut_size: int = Field(512, ge=16, le=4096)
    per_region: dict[str, RegionSpecular] = Field(default_factory=dict)

    _regions = field_validator("per_region")(_known_regions)


class RegionKernel(_Model):
    kernel_size: float = Field(1.0, ge=0.0, le=1000.0)
    scale_x: float = Field(1.0, ge=0.0, le=1000.0)
    scale_y: float = Field(0.0, ge=0.0, le=1000.0)


def _default_gosselin_regions() -> dict[str, RegionKernel]:
    # seed 000 after eq. (13): ears and nose scatter more, cheeks less
    ks = {"other": 1.0, "forehead": 1.0, "nose": 1.6, "cheeks": 0.7, "lips": 1.0, "chin": 1.0,
          "ears": 2.0, "neck": 1.2, "scalp": 1.0}
    return {k: RegionKernel(kernel_size=v) for k, v in ks.items()}


class GosselinSettings(_Model):
    """Gosselin et al. 2004 (seed 000 §4.1, eq. 8-19)."""
    light_map_size: int = Field(1024, ge=256, le=4096)
    iterations: int = Field(4, ge=0, le=64)
    # seed 000 eq. (12): radius = size * (kernel_size * scale_x + scale_y), global scales multiply per-region ones;
    # size = 1/1024 (radii are texels at a 1024 map, rescaled to light_map_size: the look is size-independent).
    # 2.0: ~1.2 mm effective sigma after 4 iterations on the default head (0.57 mm/texel at 1024)
    scale_x: float = Field(2.0, ge=0.0, le=1000.0)
    scale_y: float = Field(0.0, ge=0.0, le=1000.0)
    regions: dict[str, RegionKernel] = Field(default_factory=_default_gosselin_regions)
    specular_shadow: Literal["visibility", "printed"] = Field(
        "visibility", description="eq. (18) attenuation: visibility = LUM(blurred)/LUM(unshadowed irradiance) "
        "in [0, 1] (default); printed = LUM(blurred) as printed (scales with Lc^2)")

    _regions = field_validator("regions")(_known_regions)


class Gaussian(_Model):
    variance: float = Field(..., ge=0.0, le=1e4, description="mm^2")
    weights: Vec3 = Field(..., description="RGB weights")

    @field_validator("weights")
    @classmethod
    def _w(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 for c in v):
            raise ValueError("weights must be finite and >= 0")
        return v


def _default_gaussians() -> list[Gaussian]:
    # d'Eon & Luebke 2007 six-Gaussian skin profile (seed 000 Tabela 2, seed 002, ../shared/reference)
    table = [(0.0064, (0.233, 0.455, 0.649)), (0.0484, (0.100, 0.336, 0.344)), (0.187, (0.118, 0.198, 0.0)),
             (0.567, (0.113, 0.007, 0.007)), (1.99, (0.358, 0.004, 0.0)), (7.41, (0.078, 0.0, 0.0))]
    return [Gaussian(variance=v, weights=w) for v, w in table]


class DeonSettings(_Model):
    """d'Eon & Luebke 2007 (seed 000 §4.2, eq. 20-35; seed 002 §14.4)."""
    # variances need not ascend (the blur chain clamps a negative increment to 0) and weights need not
    # sum to 1: profile_warnings() says so, never an error
    gaussians: list[Gaussian] = Field(default_factory=_default_gaussians, min_length=1, max_length=MAX_GAUSSIANS)
    mix: float = Field(0.5, ge=0.0, le=1.0, description="pre/post-scatter texturing, eq. (28), (34)")
    stretch: bool = True
    stretch_per_gaussian: bool = False
    stretch_shear: bool = Field(False, description="blur along the full UV->surface Jacobian (the second pass follows "
                                "the texels' shear) instead of eq. 27's per-axis lengths; exact on sheared planes, "
                                "not yet better on the scan (issue 10 item 2, notes/fidelity.md)")
    tsm: bool = True
    tsm_size: int = Field(1024, ge=64, le=8192)
    tsm_light: int | None = Field(
        None, ge=0, le=MAX_LIGHTS - 1, description="light the TSM is rendered from (None: the first shadow-casting light)")
    tsm_form: Literal["exact", "printed"] = Field(
        "exact", description="exact: exp(-d^2/(2 v_i)); printed: exp(-d^2/v_i) as in seed 000 eq. (33)")
    energy_conservation: bool = True
    irradiance_size: int = Field(1024, ge=256, le=4096)
    reuse_irradiance_below_texels: float = Field(
        0.5, ge=0.0, le=8.0,
        description="blur 1 reuses the irradiance itself when its sigma is under this many (mean) texels: "
                    "a sub-texel 7-tap blur changes nothing")



class Settings(_Model):
    schema_version: int = SCHEMA_VERSION
    technique: Literal["phong", "gosselin", "deon"] = "deon"
    scene: SceneSettings = Field(default_factory=SceneSettings)
    camera: CameraSettings = Field(default_factory=CameraSettings)
    render: RenderSettings = Field(default_factory=RenderSettings)
    lights: list[LightSettings] = Field(
        default_factory=lambda: [
            # key light front-right, rim light behind-left (it makes the ears glow with TSM)
            LightSettings(direction=(0.55, 0.35, 1.0), intensity=1.4, color=(1.0, 0.97, 0.92)),
            LightSettings(direction=(-0.8, 0.4, -0.9), intensity=1.2, color=(0.85, 0.9, 1.0)),
        ],
        min_length=1, max_length=MAX_LIGHTS)
    shadow: ShadowSettings = Field(default_factory=ShadowSettings)
    phong: PhongSettings = Field(default_factory=PhongSettings)
    specular: SpecularSettings = Field(default_factory=SpecularSettings)
    gosselin: GosselinSettings = Field(default_factory=GosselinSettings)
    deon: DeonSettings = Field(default_factory=DeonSettings)

    @model_validator(mode="after")
    def _version(self) -> "Settings":
        if self.schema_version != SCHEMA_VERSION:
            raise ValueError(f"schema_version {self.schema_version} is not supported (this build reads {SCHEMA_VERSION})")
        return self


# ---------------------------------------------------------------------------------------------
# errors, paths, presets

class SettingsError(ValueError):
    """Invalid settings: ``errors`` lists (path, message), one per invalid field."""

    def __init__(self, errors: list[tuple[str, str]], source: str = ""):
        self.errors = errors
        self.source = source
        head = f"{source}: " if source else ""
        super().__init__(head + "; ".join(f"{p}: {m}" for p, m in errors))


def _errors_of(exc: ValidationError) -> list[tuple[str, str]]:
    out = []
    for e in exc.errors():
        path = ".".join(str(p) for p in e["loc"]) or "<root>"
        msg = e["msg"]
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, "):]
        out.append((path, msg))
    return out


def validate(data: Any, source: str = "") -> Settings:
    try:
        return Settings.model_validate(data)
    except ValidationError as exc:
        raise SettingsError(_errors_of(exc), source) from None


def to_dict(s: Settings) -> dict:
    return s.model_dump(mode="json")


def get_path(obj: Any, path: str) -> Any:
    """Value at a dotted path (``lights.0.intensity``) in a settings object or a plain dict/list."""
    cur = obj
    if not path:
        return cur
    for part in path.split("."):
        if part == "#":  # "lights.#": the length of a list
            cur = len(cur)
        elif isinstance(cur, (list, tuple)):
            cur = cur[int(part)]
        elif isinstance(cur, dict):
            cur = cur[part]
        else:
            if part not in type(cur).model_fields:
                raise KeyError(path)
            cur = getattr(cur, part)
    return cur


def _jsonable(v: Any) -> Any:
    if isinstance(v, BaseModel):
        return v.model_dump(mode="json")
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    return v


def value_key(s: Settings, path: str) -> str:
    """A stable text key of the value at ``path`` (used by the pass graph's cache)."""
    return json.dumps(_jsonable(get_path(s, path)), sort_keys=True)


def parse_value(text: str) -> Any:
    """A ``--set`` value: JSON when it parses (numbers, true/false, null, lists), else the bare string."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        lowered = text.strip().lower()
        if lowered in ("on", "yes"):
            return True
        if lowered in ("off", "no"):
            return False
        if "," in text:  # 1,2,3 -> [1, 2, 3]
            try:
                return [json.loads(p) for p in text.split(",")]
            except json.JSONDecodeError:
                pass
        return text


def with_values(s: Settings, assignments: dict[str, Any]) -> Settings:
    """A new validated Settings with dotted-path assignments applied; SettingsError names bad paths."""
    data = to_dict(s)
    errors = []
    for path, value in assignments.items():
        parts = path.split(".")
        cur: Any = data
        try:
            for p in parts[:-1]:
                cur = cur[int(p)] if isinstance(cur, list) else cur[p]
            last = parts[-1]
            if isinstance(cur, list):
                idx = int(last)
                if idx == len(cur):
                    cur.append(value)
                else:
                    cur[idx] = value
            elif isinstance(cur, dict):
                # dict-valued fields (per-region tables) accept new keys; models do not
                if last not in cur and not _is_free_dict(parts[:-1]):
                    raise KeyError(last)
                cur[last] = value
            else:
                raise KeyError(last)
        except (KeyError, IndexError, ValueError, TypeError):
            errors.append((path, "no such setting"))
    if errors:
        raise SettingsError(errors)
    return validate(data)


def _is_free_dict(parent: list[str]) -> bool:
    return bool(parent) and parent[-1] in ("per_region", "regions")


def parse_assignments(items: list[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    errors = []
    for item in items:
        if "=" not in item:
            errors.append((item, "expected key=value"))
            continue
        k, v = item.split("=", 1)
        out[k.strip()] = parse_value(v.strip())
    if errors:
        raise SettingsError(errors)
    return out


def load_preset(path: str | os.PathLike, base: Settings | None = None) -> Settings:
    """Read a preset. A preset may be partial: its fields override ``base`` (default: defaults)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise SettingsError([("<file>", f"cannot read: {exc.strerror or exc}")], str(p)) from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SettingsError([("<json>", f"line {exc.lineno} column {exc.colno}: {exc.msg}")], str(p)) from None
    if not isinstance(data, dict):
        raise SettingsError([("<root>", "a preset is a JSON object")], str(p))
    if "schema_version" not in data:
        raise SettingsError([("schema_version", "missing")], str(p))
    merged = _deep_merge(to_dict(base or Settings()), data)
    return validate(merged, str(p))


def _deep_merge(base: dict, over: dict) -> dict:
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict) and k not in ("regions", "per_region"):
            out[k] = _deep_merge(out[k], v)
        else:
            out[k] = v
    return out


def save_preset(s: Settings, path: str | os.PathLike) -> None:
    atomic_write_text(path, json.dumps(to_dict(s), indent=2) + "\n")


def profile_warnings(d: DeonSettings) -> list[str]:
    """Non-fatal problems of a Gaussian table (seed 000 eq. 21): order and per-channel energy."""
    out = []
    vs = [g.variance for g in d.gaussians]
    if any(b <= a for a, b in zip(vs, vs[1:])):
        out.append("variances are not strictly ascending: the hierarchical blur clamps v_i - v_(i-1) to 0")
    if any(v <= 0 for v in vs):
        out.append("a variance is 0: that Gaussian is the irradiance itself")
    for c, name in enumerate("RGB"):
        total = sum(g.weights[c] for g in d.gaussians)
        if abs(total - 1.0) > 0.02:
            verb = "gains" if total > 1 else "loses"
            out.append(f"channel {name} weights sum to {total:.3f}: the profile {verb} energy")
    return out
