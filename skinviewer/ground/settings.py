"""One typed, validated settings model. Presets are its JSON; the viewer, presets and the CLI's
``--set key=value`` all edit this same object. Passes read only the dotted paths they declare.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from pydantic import (
    BaseModel,
    Field,
    StrictInt,
    ValidationError,
    field_validator,
    model_validator,
)

from skinviewer.ground.constants import MAX_GAUSSIANS, MAX_LIGHTS, MAX_PCF
from skinviewer.ground.constants import REGIONS as REGIONS  # re-exported: passes, scenes and the UI import it from here
from skinviewer.ground.files import FileReadError, atomic_write_text, read_regular_file
from skinviewer.ground.sections import TECHNIQUE_NAMES, TechniqueSections
from skinviewer.ground.sections.base import Section as _Model
from skinviewer.ground.sections.base import Vec3, finite, finite_vec, known_regions
from skinviewer.ground.sections.burley import BurleySettings as BurleySettings
from skinviewer.ground.sections.burley2 import Burley2Settings as Burley2Settings
from skinviewer.ground.sections.deon import DeonSettings as DeonSettings
from skinviewer.ground.sections.deon import Gaussian as Gaussian
from skinviewer.ground.sections.deon import profile_warnings as profile_warnings
from skinviewer.ground.sections.gosselin import GosselinSettings as GosselinSettings
from skinviewer.ground.sections.gosselin import RegionKernel as RegionKernel
from skinviewer.ground.sections.penner import PennerSettings as PennerSettings
from skinviewer.ground.sections.phong import PhongSettings as PhongSettings
from skinviewer.ground.sections.screen_space import ScreenSettings, TransmittanceSettings
from skinviewer.ground.sections.separable import SeparableSettings as SeparableSettings
from skinviewer.ground.sections.ssss import SsssSettings as SsssSettings

SCHEMA_VERSION = 1

# the section base and validators (ground/sections/base.py); the techniques' sections live in
# ground/sections/<technique>.py and are re-exported here (passes, the UI and tests import them from here)
_known_regions = known_regions
_finite = finite
_finite_vec = finite_vec

def _file_path(v: str | None) -> str | None:
    """A path the OS can open: no NUL byte, encodable (a lone surrogate from JSON is not)."""
    if v is None:
        return v
    if "\x00" in v:
        raise ValueError("path contains a NUL byte")
    if not v.strip():
        raise ValueError("path is empty")
    try:
        os.fsencode(v)
        v.encode("utf-8", "surrogateescape")
    except (UnicodeError, ValueError):
        raise ValueError("path is not valid text for this file system (lone surrogate?)") from None
    return v


# a light farther than this (mesh units) is refused: shadow-map projections lose all precision
MAX_POSITION = 1e9


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
    stretch_metric: Literal["vertex", "triangle"] = Field(
        "vertex", description="the stretch map (seed 000 eq. 27) from the UV->surface metric averaged at the "
        "vertices and interpolated (vertex: smooth where the UVs are not, e.g. slivers; the lowest RMS on the seam "
        "bench) or per triangle, as printed (triangle)")
    back_faces: Literal["auto", "cull", "show"] = Field(
        "auto", description="what the camera sees of back faces. cull: front faces only (a closed surface's "
        "inside is never visible; a back face that wins a depth fight at a thin fold shows a dark speck); show: the "
        "back of the surface too, shaded with the normal reversed (open sheets); auto: cull on a closed mesh, show "
        "on an open one")

    _paths = field_validator("mesh", "albedo_map", "normal_map", "specular_map", "region_map")(_file_path)


class CameraSettings(_Model):
    yaw: float = Field(25.0, ge=-3600, le=3600, description="degrees about +Y")
    pitch: float = Field(5.0, ge=-89.0, le=89.0, description="degrees")
    distance: float | None = Field(None, gt=0, le=1e7, description="in mesh units; None: frame the mesh")
    target: Vec3 | None = Field(None, description="look-at point in mesh units; None: bounds centre")
    fov_y: float = Field(30.0, gt=1.0, lt=170.0, description="degrees")

    _f = field_validator("yaw", "pitch")(_finite)
    _t = field_validator("target")(_finite_vec)


class LightSettings(_Model):
    # beam: a collimated beam of radius beam_radius (mesh units) along -direction through position
    # (the laser of GPU Gems 3 §14.4.1)
    # environment: an HDR image around the scene (issue 32; the fields below the shadow flag)
    kind: Literal["directional", "point", "beam", "environment"] = "directional"
    color: Vec3 = (1.0, 1.0, 1.0)
    intensity: float = Field(3.0, ge=0.0, le=1e6)
    # directional: direction the light travels *from* (towards the light); point: position in mesh units
    direction: Vec3 = (0.4, 0.5, 1.0)
    position: Vec3 = (0.0, 0.0, 400.0)
    beam_radius: float = Field(0.05, gt=0.0, le=1e6)
    cast_shadow: bool = True
    enabled: bool = True
    environment: str = Field(
        "studio", description="kind environment: a built-in (studio, overcast, window) or the path of a Radiance "
        ".hdr / OpenEXR .exr of linear radiance (notes/envlight.md)")
    layout: Literal["auto", "equirect", "cross"] = Field(
        "auto", description="the file's layout: equirect (2:1), cube cross (4:3 / 3:4), auto from the aspect")
    yaw: float = Field(0.0, ge=-3600, le=3600, description="degrees the environment is turned about +y")
    sh_order: int = Field(2, ge=0, le=2, description="spherical-harmonic order of the environment's diffuse "
                          "irradiance (Ramamoorthi & Hanrahan 2001; 2: 9 coefficients)")
    occlusion: bool = Field(True, description="the environment's light is occluded by the mesh: per-vertex "
                            "SH transfer vectors baked with Embree, and specular occlusion")
    ao_rays: int = Field(256, ge=4, le=4096, description="rays per vertex of the visibility bake (SH transfer "
                         "vectors and ambient occlusion; stratified, cosine-weighted; once per mesh, cached)")
    transfer_order: int = Field(4, ge=0, le=4, description="SH bands of the per-vertex transfer vectors that shadow "
                                "the environment's diffuse light (Sloan et al. 2002; 4: 25 coefficients, 2: 9); "
                                "0: ambient occlusion x SH irradiance at the bent normal")

    _env_path = field_validator("environment")(_file_path)

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
        if max(abs(c) for c in v) > MAX_POSITION:
            raise ValueError(f"position must be within +-{MAX_POSITION:g} mesh units")
        return v


class ShadowSettings(_Model):
    map_size: int = Field(1024, ge=64, le=8192)
    map_size_mode: Literal["fixed", "auto"] = Field(
        "fixed", description="auto: shadow maps sized from the scene's screen coverage, map_size at most (issue 14)")
    # seed 000 eq. (7): shadowed if d(P) - ds > tol; tol in normalised light-space depth
    tol: float = Field(0.002, ge=0.0, le=0.5)
    pcf: int = Field(1, ge=0, le=MAX_PCF, description="percentage-closer filter radius in texels (0 = eq. 7 hard test)")
    pcf_filter: Literal["bilinear", "box"] = Field(
        "bilinear", description="bilinear: the PCF box slides with the lookup's sub-texel position, so shadow edges "
        "have no one-texel terraces (16 instead of 9 taps at pcf 1; closer to the ground truth); box: snapped to texels")


class RenderSettings(_Model):
    width: int = Field(640, ge=16, le=8192)
    height: int = Field(640, ge=16, le=8192)
    exposure: float = Field(0.9, gt=0.0, le=1e4)
    tone_map: Literal["filmic", "linear"] = Field(
        "filmic", description="display transform after exposure: filmic (ACES fit, soft highlight roll-off) or "
        "linear (clamp; what measurements compare)")
    background: Vec3 = (0.05, 0.05, 0.06)
    background_environment: Literal["off", "sharp", "blurred"] = Field(
        "off", description="with an environment light: the background shows the environment seen from the camera "
        "(sharp, or blurred as the pre-filtered m = 0.15 level), exposed and tone-mapped like the skin; off: the "
        "background colour")
    check_finite: bool = Field(
        True, description="after a pass runs, check its outputs for NaN/Inf (a small GPU reduction); "
        "the frame report names a pass whose output is not finite")
    timing: Literal["auto", "sync", "gpu"] = Field(
        "auto", description="auto: GL timer queries on a hardware GPU (no glFinish between passes), sync on a "
        "software rasterizer (llvmpipe: its timer queries are far too low); sync: glFinish + wall clock per "
        "pass; gpu: GL timer queries")
    compute_blur: Literal["auto", "on", "off"] = Field(
        "auto", description="d'Eon's separable blur directions and their seam fills as compute passes (issue 27; "
        "the same values as the fragment draws): auto: on an OpenGL 4.3 GPU, off on a software rasterizer "
        "(llvmpipe: compute was slower there); on: wherever the context has compute shaders (said, and the "
        "fragment draws, where it has not); off: fragment draws")
    texel_surface: bool = Field(
        True, description="texture-space techniques (d'Eon's irradiance and transmitted light, Gosselin's light "
                          "map) shade once per texel from the texel surface map (the mesh's attributes per "
                          "texel, rasterised once per mesh and size) instead of rasterising the mesh's small "
                          "triangles each time (issue 14; the same values up to float rounding)")
    mesh_lod: Literal["auto", "full"] = Field(
        "auto", description="auto: draw a coarser copy of the mesh (1/4 of the triangles per level) when the "
        "head is so small on screen that its triangles are far under a pixel; full: always the whole mesh")
    governor: Literal["off", "interactive", "fixed-budget"] = Field(
        "interactive", description="the viewer's quality governor (issue 27; `render`/`bench` ignore it): "
        "interactive: while you drag or edit, the most accurate preview of the technique's own knobs that fits "
        "governor_budget_ms on this machine (skinviewer calibrate), refined up to your settings when input "
        "stops; fixed-budget: that preview always; off: every frame at your settings")
    governor_budget_ms: float = Field(
        100.0, ge=-1e6, le=1e6, description="the interaction budget (ms a frame) the governor's preview must fit; "
        "<= 0 or one nothing fits: the cheapest preview, said in the status bar")

    _bg = field_validator("background")(_finite_vec)

    @field_validator("background_environment", mode="before")
    @classmethod
    def _bg_env(cls, v: Any) -> Any:
        # --set reads off / on as false / true
        return {False: "off", True: "sharp"}.get(v, v) if isinstance(v, bool) else v

    @field_validator("compute_blur", mode="before")
    @classmethod
    def _compute_on_off(cls, v: Any) -> Any:
        # --set reads on / off as true / false
        return {False: "off", True: "on"}.get(v, v) if isinstance(v, bool) else v

    @field_validator("governor", mode="before")
    @classmethod
    def _governor_off(cls, v: Any) -> Any:
        # --set render.governor=off reads "off" as false (on: the default, interactive)
        return {False: "off", True: "interactive"}.get(v, v) if isinstance(v, bool) else v


class RegionSpecular(_Model):
    m: float | None = Field(None, ge=0.0, le=1.0)
    rho_s: float | None = Field(None, ge=0.0, le=10.0)


def _default_region_specular() -> dict[str, RegionSpecular]:
    # seed 002 §14.3: Weyrich et al. 2006 measured m and rho_s per facial region; the pattern they found
    # (nose and lips shinier, cheeks and chin rougher) with values inside their measured range
    table = {"forehead": (0.32, 0.20), "nose": (0.28, 0.24), "lips": (0.30, 0.22), "cheeks": (0.38, 0.15),
             "chin": (0.35, 0.17)}
    return {k: RegionSpecular(m=m, rho_s=r) for k, (m, r) in table.items()}


class SpecularSettings(_Model):
    """Kelemen/Szirmay-Kalos (seed 000 eq. 14-16, seed 002 §14.3)."""
    m: float = Field(0.3, ge=0.0, le=1.0, description="Beckmann roughness")
    f0: float = Field(0.028, ge=0.0, le=1.0, description="Fresnel reflectance at normal incidence")
    rho_s: float = Field(0.18, ge=0.0, le=10.0, description="specular intensity")
    mode: Literal["direct", "beckmann_lut"] = "direct"
    lut_size: int = Field(512, ge=16, le=4096)
    per_region: dict[str, RegionSpecular] = Field(default_factory=lambda: _default_region_specular())

    _regions = field_validator("per_region")(_known_regions)


class LookSettings(_Model):
    """The artist model (physics/artist.py): scatter colour and radius per channel, Burley's surface albedo
    and (diffuse) mean free path as Unreal's Burley profile and HDRP present them (seed 001 eq. 2.84, 2.88).
    With source = look they drive deon.gaussians (d'Eon, ssss, penner, Gosselin in mm mode) and
    burley.albedo / burley.mfp (burley, burley2); the raw tables stay editable under Advanced."""
    source: Literal["table", "look"] = Field(
        "table", description="look: the scatter colour and radius below set each technique's profile; table: the "
        "techniques' own tables (deon.gaussians, burley.albedo/mfp) as they are, the look only shown as an estimate")
    scatter_color: Vec3 = Field(
        (0.436, 0.227, 0.131), description="surface albedo A per channel: the profile's total diffuse reflectance "
        "(eq. 2.84) and its shape s(A) (eq. 2.88)")
    scatter_radius: Vec3 = Field(
        (1.574, 0.364, 0.244), description="mean free path per channel, mm (Unreal: mean free path colour x distance): "
        "the profile's scale d = radius / s(A), its mean radius 2.5 d (default: d'Eon's table)")
    gaussians: int = Field(6, ge=2, le=MAX_GAUSSIANS, description="Gaussians of the fitted table (d'Eon, ssss, penner)")
    energy: Literal["albedo-map", "profile"] = Field(
        "albedo-map", description="albedo-map: the table's weights sum to 1 per channel (d'Eon's convention: the "
        "colour is in the albedo map); profile: they sum to the scatter colour (the profile tints the skin)")

    @field_validator("scatter_color")
    @classmethod
    def _color(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0 or c > 1 for c in v):
            raise ValueError("scatter colour components must be in [0, 1]")
        return v

    @field_validator("scatter_radius")
    @classmethod
    def _radius(cls, v: Vec3) -> Vec3:
        if any((not math.isfinite(c)) or c < 0.01 or c > 50 for c in v):
            raise ValueError("scatter radius components must be in [0.01, 50] mm")
        return v


def three_light_rig() -> list[LightSettings]:
    """The default rig before issue 32 (presets/studio-three-lights.json): a warm key high on the left
    of the face, a cool rim behind the right ear (deon.tsm_light = 1: it makes the ears glow), a soft
    unshadowed fill from the camera side."""
    return [LightSettings(direction=(-0.45, 0.55, 0.75), intensity=1.8, color=(1.0, 0.95, 0.88)),
            LightSettings(direction=(0.55, 0.35, -0.9), intensity=1.6, color=(0.9, 0.93, 1.0)),
            LightSettings(direction=(0.9, 0.05, 0.45), intensity=0.3, color=(0.85, 0.9, 1.0), cast_shadow=False)]


def default_rig() -> list[LightSettings]:
    """The default lights (issue 32): the warm key of the three-light rig and the built-in studio
    environment (two soft boxes, occluded by the mesh), as presets/studio-environment.json, with both
    intensities scaled by 0.61 so that the default exposure 0.9 is the one the scene's luminance calls
    for (passes/environment.exposure_from_luminance; the preset's own exposure is 0.55 at 1.2 / 1.0).
    The key is light 0, so deon.tsm_light = 1 (the environment) falls back to it."""
    return [LightSettings(direction=(-0.45, 0.55, 0.75), intensity=0.73, color=(1.0, 0.95, 0.88)),
            LightSettings(kind="environment", environment="studio", intensity=0.61, cast_shadow=False)]


if TYPE_CHECKING:
    TechniqueName = str
else:  # the techniques' names: the registry's sections (ground/sections/__init__.py)
    TechniqueName = Literal[TECHNIQUE_NAMES]


class _SharedSections(_Model):
    schema_version: StrictInt = SCHEMA_VERSION  # strict: JSON `true` is not version 1
    technique: TechniqueName = "deon"
    scene: SceneSettings = Field(default_factory=SceneSettings)
    camera: CameraSettings = Field(default_factory=CameraSettings)
    render: RenderSettings = Field(default_factory=RenderSettings)
    lights: list[LightSettings] = Field(
        default_factory=lambda: default_rig(),
        min_length=1, max_length=MAX_LIGHTS)
    shadow: ShadowSettings = Field(default_factory=ShadowSettings)
    specular: SpecularSettings = Field(default_factory=SpecularSettings)
    screen: ScreenSettings = Field(default_factory=ScreenSettings)
    transmittance: TransmittanceSettings = Field(default_factory=TransmittanceSettings)


# the whole model: the shared sections, then each technique's (TechniqueSections), then the look (no
# docstring: it would enter the JSON schema)
class Settings(TechniqueSections, _SharedSections):
    look: LookSettings = Field(default_factory=LookSettings)

    @model_validator(mode="after")
    def _version(self) -> Settings:
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


def to_dict(s: Settings) -> dict[str, Any]:
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
            cur = cur[_index(part)]
        elif isinstance(cur, dict):
            cur = cur[part]
        else:
            if part not in type(cur).model_fields:
                raise KeyError(path)
            cur = getattr(cur, part)
    return cur


def _index(part: str) -> int:
    """A list index in a dotted path: plain decimal digits only (``lights.-1`` is not the last light)."""
    if not (part.isascii() and part.isdigit()) or len(part) > 6:
        raise IndexError(part)
    return int(part)


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
    except (ValueError, RecursionError) as exc:
        if not isinstance(exc, json.JSONDecodeError):  # 5,000-digit integers, 100,000 nested lists
            raise SettingsError([("<value>", _json_problem(exc))]) from None
        lowered = text.strip().lower()
        if lowered in ("on", "yes"):
            return True
        if lowered in ("off", "no"):
            return False
        if "," in text:  # 1,2,3 -> [1, 2, 3]
            try:
                return [json.loads(p) for p in text.split(",")]
            except (ValueError, RecursionError):
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
                cur = cur[_index(p)] if isinstance(cur, list) else cur[p]
            last = parts[-1]
            if isinstance(cur, list):
                idx = _index(last)
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
            errors.append((path, "no such setting" + _did_you_mean(data, parts)))
    if errors:
        raise SettingsError(errors)
    return validate(data)


def _did_you_mean(data: Any, parts: list[str]) -> str:
    """'; did you mean lights.0.intensity?' for a mistyped dotted path (the closest key where it goes wrong)."""
    import difflib
    cur = data
    done: list[str] = []
    for p in parts:
        if isinstance(cur, dict) and p in cur:
            cur, done = cur[p], done + [p]
        elif isinstance(cur, list) and p.isdigit() and int(p) < len(cur):
            cur, done = cur[int(p)], done + [p]
        elif isinstance(cur, dict):
            close = difflib.get_close_matches(p, list(cur), n=1, cutoff=0.6)
            if not close:
                return ""
            rest = parts[len(done) + 1:]
            return f"; did you mean {'.'.join(done + close + rest)}?"
        else:
            return ""
    return ""


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
        try:
            out[k.strip()] = parse_value(v.strip())
        except SettingsError as exc:
            errors += [(k.strip(), m) for _, m in exc.errors]
    if errors:
        raise SettingsError(errors)
    return out


# a preset is a small JSON file: anything larger is not one (and /dev/zero never ends)
MAX_PRESET_BYTES = 4 * 1024 * 1024
# scene fields holding file paths: relative ones in a preset are relative to the preset's folder
PATH_FIELDS = ("mesh", "albedo_map", "normal_map", "specular_map", "region_map")


def _json_problem(exc: BaseException) -> str:
    if isinstance(exc, RecursionError):
        return "nested too deeply"
    if isinstance(exc, UnicodeDecodeError):
        return f"not UTF-8 text (byte 0x{exc.object[exc.start]:02x} at offset {exc.start})"
    if isinstance(exc, json.JSONDecodeError):
        return f"line {exc.lineno} column {exc.colno}: {exc.msg}"
    return str(exc).split(";")[0]  # e.g. "Exceeds the limit (4300 digits) for integer string conversion"


def load_preset(path: str | os.PathLike[str], base: Settings | None = None) -> Settings:
    """Read a preset. A preset may be partial: its fields override ``base`` (default: defaults).
    Relative scene paths in it are resolved against the preset's folder."""
    p = Path(path)
    try:
        raw = read_regular_file(p, MAX_PRESET_BYTES, what="preset")
    except FileReadError as exc:
        raise SettingsError([("<file>", str(exc))], _shown(p)) from None
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise SettingsError([("<file>", "UTF-16 text: save the preset as UTF-8")], _shown(p))
    try:
        text = raw.decode("utf-8")
        if text.startswith("\ufeff"):
            text = text[1:]  # a UTF-8 byte-order mark
        data = json.loads(text)
    except (ValueError, RecursionError) as exc:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        where = "<json>" if isinstance(exc, json.JSONDecodeError) or not isinstance(exc, UnicodeDecodeError) \
            else "<file>"
        raise SettingsError([(where, _json_problem(exc))], _shown(p)) from None
    if not isinstance(data, dict):
        raise SettingsError([("<root>", "a preset is a JSON object")], _shown(p))
    if "schema_version" not in data:
        raise SettingsError([("schema_version", "missing")], _shown(p))
    scene = data.get("scene")
    if isinstance(scene, dict):
        data = dict(data, scene={k: _resolve_against(v, p.parent) if k in PATH_FIELDS else v
                                 for k, v in scene.items()})
    try:
        merged = _deep_merge(to_dict(base or Settings()), data)
        return validate(merged, _shown(p))
    except RecursionError:
        raise SettingsError([("<json>", "nested too deeply")], _shown(p)) from None


def _shown(p: Path) -> str:
    """A path as printable text (a lone surrogate in it must not break the error line)."""
    return str(p).encode("utf-8", "backslashreplace").decode("utf-8")


def _resolve_against(v: Any, folder: Path) -> Any:
    if not isinstance(v, str) or not v or "\x00" in v:
        return v  # validation says what is wrong with it
    try:
        if os.path.isabs(v):
            return v
        return os.path.normpath(os.path.join(os.path.abspath(folder), v))
    except (ValueError, UnicodeError):
        return v


def _relative_to(v: str | None, folder: Path) -> str | None:
    if not v:
        return v
    try:
        return os.path.relpath(os.path.abspath(v), os.path.abspath(folder))
    except ValueError:  # another drive (Windows)
        return v


def _deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict) and k not in ("regions", "per_region"):
            out[k] = _deep_merge(out[k], v)
        else:
            out[k] = v
    return out


def save_preset(s: Settings, path: str | os.PathLike[str], data: dict[str, Any] | None = None) -> None:
    """Write ``s`` (or ``data``, a dict of it such as the viewer's trimmed payload) atomically; scene
    paths are written relative to the preset's folder."""
    data = to_dict(s) if data is None else dict(data)
    folder = Path(path).parent
    if "scene" in data:
        data["scene"] = {k: _relative_to(v, folder) if k in PATH_FIELDS else v for k, v in data["scene"].items()}
    atomic_write_text(path, json.dumps(data, indent=2) + "\n")


