"""Exports and imports of the skin profile for Unity HDRP, Unreal, MaterialX / OpenPBR and Blender.

The physics (Burley fits, each target's parametrisation, unit and specular conversions) is in
:mod:`skinviewer.physics.engines`; this module reads the current settings, writes the targets' files
(atomically, every one) and reads them back. Field names and where they come from:

* HDRP ``DiffusionProfile`` (com.unity.render-pipelines.high-definition, Runtime/Material/DiffusionProfile/
  DiffusionProfileSettings.cs; the asset YAML as HDRP's own RenderPipelineResources/*DiffusionProfile*.asset,
  m_Script guid b2686e09ec7aef44bad2843e4416f057, m_Version 2 = SplitScatteringDistance).
* Unreal ``SubsurfaceProfile`` (Engine/Classes/Engine/SubsurfaceProfile.h, FSubsurfaceProfileStruct; the
  editor Python names of unreal.SubsurfaceProfileStruct: surface_albedo, mean_free_path_color,
  mean_free_path_distance (cm), world_unit_scale, enable_burley, enable_mean_free_path, tint,
  transmission_tint_color, roughness0/1, lobe_mix, ior).
* MaterialX ``standard_surface`` (subsurface, subsurface_color, subsurface_radius (color3),
  subsurface_scale (float)) and ``open_pbr_surface`` (subsurface_weight, subsurface_color,
  subsurface_radius (float), subsurface_radius_scale (color3)), as the installed MaterialX defines them.
* Blender 4.x Principled BSDF inputs: Base Color, Subsurface Weight, Subsurface Radius, Subsurface Scale,
  Roughness, IOR; the material's subsurface_method 'BURLEY' (Christensen-Burley).
"""
from __future__ import annotations

import ast
import hashlib
import json
import math
import re
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from skinviewer.ground.files import FileReadError, atomic_write_text, read_regular_file
from skinviewer.ground.settings import Settings, with_values
from skinviewer.physics import engines as E
from skinviewer.physics.burley import shape_distance
from skinviewer.physics.profiles import (
    Burley,
    burley_normalized,
    burley_scale,
    sum_of_gaussians,
)

if TYPE_CHECKING:
    import MaterialX
    import yaml


MAX_IMPORT_BYTES = 4 << 20
HDRP_SCRIPT_GUID = "b2686e09ec7aef44bad2843e4416f057"  # DiffusionProfileSettings (HDRP's own assets)
HDRP_VERSION = 2  # DiffusionProfileSettings.Version.SplitScatteringDistance
SUFFIX = {"hdrp": ".asset", "unreal": ".py", "materialx": ".mtlx", "openpbr": ".mtlx", "blender": ".py"}


class ExchangeError(ValueError):
    """One clear line for the user."""


# ---------------------------------------------------------------------------------------------
# the current profile

@dataclass
class CurrentProfile:
    profile: Callable[[np.ndarray], np.ndarray]
    description: str


def current_profile(s: Settings) -> CurrentProfile:
    """The radial profile the current technique renders with: Burley's (burley, burley2: the
    ``burley`` section, normalised as the techniques render it; the albedo is the map's) or the sum
    of Gaussians of ``deon.gaussians`` (every other technique)."""
    if s.technique in ("burley", "burley2"):
        b = s.burley
        d = shape_distance(b.albedo, b.mfp, b.fit) * b.scale

        def prof(r: np.ndarray, d: np.ndarray = d) -> np.ndarray:
            return burley_normalized(np.asarray(r, float)[..., None], d)
        return CurrentProfile(prof, f"Burley ({b.fit}, scale {b.scale:g}) of the burley section")
    v = np.array([g.variance for g in s.deon.gaussians], float)
    w = np.array([g.weights for g in s.deon.gaussians], float)
    keep = v > 0

    def gauss(r: np.ndarray, v: np.ndarray = v[keep], w: np.ndarray = w[keep]) -> np.ndarray:
        return sum_of_gaussians(r, v, w)
    return CurrentProfile(gauss, f"{int(keep.sum())} Gaussians of deon.gaussians")


def model_profile(spec: str) -> CurrentProfile:
    """The profile lab's models, unfitted: ``dipole[:MATERIAL]``, ``multipole[:MATERIAL]`` (a 2 mm
    slab; without a material the three-layer skin example), ``burley[:MATERIAL]`` (searchlight, diffuse
    mean free path of the material's dipole), as ``skinviewer reference --profile`` names them."""
    from skinviewer.physics import profiles as P
    model, _, name = spec.strip().partition(":")
    try:
        if model == "dipole":
            m = P.material(name or "Skin1")
            return CurrentProfile(P.Dipole(m.sigma_s_prime, m.sigma_a, m.eta), f"the {name or 'Skin1'} dipole")
        if model == "burley":
            m = P.material(name or "Skin1")
            A = P.Dipole(m.sigma_s_prime, m.sigma_a, m.eta).total_reflectance()
            return CurrentProfile(P.Burley(A, P.diffuse_mean_free_path(m.sigma_s_prime, m.sigma_a)),
                                  f"Burley (dmfp) of {name or 'Skin1'}")
        if model == "multipole":
            if name:
                m = P.material(name)
                return CurrentProfile(P.Multipole(m.sigma_s_prime, m.sigma_a, 2.0, m.eta), f"a 2 mm {name} slab")
            return CurrentProfile(P.three_layer_skin(), "the three-layer skin multipole")
    except KeyError as exc:
        raise ExchangeError(str(exc.args[0])) from None
    except ValueError as exc:
        raise ExchangeError(f"{spec}: {exc}") from None
    raise ExchangeError(f"unknown profile model {model!r} (have: dipole, multipole, burley)")


def skin_of_settings(s: Settings, target: str = "unreal", model: str | None = None
                     ) -> tuple[E.EngineSkin, E.BurleyFit, str]:
    """The Burley fit the target will render, and its engine-neutral values. HDRP normalises the
    profile (the material's base colour is the albedo), so there A is R_d and only d is fitted.
    ``model``: fit a profile-lab model (``model_profile``) instead of the current profile."""
    cur = model_profile(model) if model else current_profile(s)
    fit = E.fit_burley(cur.profile)
    if target == "hdrp":
        fit = E.fit_burley(cur.profile, fixed_albedo=np.clip(fit.rd_target, 0.0, 1.0))
    skin = E.EngineSkin(fit.A, fit.d, E.beckmann_to_roughness(s.specular.m), E.f0_to_ior(s.specular.f0))
    return skin, fit, cur.description


# ---------------------------------------------------------------------------------------------
# writers

def _f(x: float) -> str:
    return f"{float(x):.7g}"


def _guid(text: str) -> str:
    return uuid.UUID(bytes=hashlib.md5(text.encode()).digest()).hex


def hdrp_text(skin: E.EngineSkin, name: str, metres_per_unit: float, texturing_mode: int, fit_note: str) -> str:
    v = E.hdrp_values(skin, metres_per_unit)
    c = v["scatteringDistance"]
    head = "".join(f"# {line}\n" for line in fit_note.splitlines())
    return (
        "%YAML 1.1\n%TAG !u! tag:unity3d.com,2011:\n"
        + head +
        "--- !u!114 &11400000\nMonoBehaviour:\n"
        "  m_ObjectHideFlags: 0\n  m_CorrespondingSourceObject: {fileID: 0}\n  m_PrefabInstance: {fileID: 0}\n"
        "  m_PrefabAsset: {fileID: 0}\n  m_GameObject: {fileID: 0}\n  m_Enabled: 1\n  m_EditorHideFlags: 0\n"
        f"  m_Script: {{fileID: 11500000, guid: {HDRP_SCRIPT_GUID}, type: 3}}\n"
        f"  m_Name: {name}\n  m_EditorClassIdentifier: \n  profile:\n"
        f"    scatteringDistance: {{r: {_f(c[0])}, g: {_f(c[1])}, b: {_f(c[2])}, a: 1}}\n"
        f"    scatteringDistanceMultiplier: {_f(v['scatteringDistanceMultiplier'])}\n"
        "    transmissionTint: {r: 1, g: 1, b: 1, a: 1}\n"
        f"    texturingMode: {texturing_mode}\n"
        "    smoothnessMultipliers: {x: 1, y: 1}\n"
        "    lobeMix: 0\n"
        "    diffuseShadingPower: 1\n"
        "    transmissionMode: 0\n"
        "    thicknessRemap: {x: 0, y: 5}\n"
        f"    worldScale: {_f(v['worldScale'])}\n"
        f"    ior: {_f(v['ior'])}\n"
        "    hash: 0\n"
        f"  m_Version: {HDRP_VERSION}\n")


def hdrp_meta(asset_text: str) -> str:
    # NativeFormatImporter, as HDRP's defaultDiffusionProfile.asset.meta; the guid is the asset's hash
    return (f"fileFormatVersion: 2\nguid: {_guid(asset_text)}\nNativeFormatImporter:\n  externalObjects: {{}}\n"
            "  mainObjectFileID: 11400000\n  userData: \n  assetBundleName: \n  assetBundleVariant: \n")


def unreal_values(skin: E.EngineSkin, world_unit_scale: float) -> dict[str, Any]:
    u = E.unreal_values(skin)
    return {"target": "unreal", "SurfaceAlbedo": list(u["surface_albedo"]),
            "MeanFreePathColor": list(u["mean_free_path_color"]),
            "MeanFreePathDistance": u["mean_free_path_distance"], "WorldUnitScale": world_unit_scale,
            "bEnableBurley": True, "bEnableMeanFreePath": True, "Tint": [1.0, 1.0, 1.0],
            "TransmissionTintColor": [1.0, 1.0, 1.0], "Roughness0": 1.0, "Roughness1": 1.0, "LobeMix": 0.0,
            "IOR": u["ior"], "MaterialRoughness": u["roughness"]}


UNREAL_SCRIPT = '''
import unreal

NAME = {name!r}
FOLDER = "/Game/Skin"


def lc(c):
    return unreal.LinearColor(c[0], c[1], c[2], 1.0)


tools = unreal.AssetToolsHelpers.get_asset_tools()
asset = tools.create_asset(NAME, FOLDER, unreal.SubsurfaceProfile, None)
s = asset.get_editor_property("settings")
s.set_editor_property("surface_albedo", lc(VALUES["SurfaceAlbedo"]))
s.set_editor_property("mean_free_path_color", lc(VALUES["MeanFreePathColor"]))
s.set_editor_property("mean_free_path_distance", VALUES["MeanFreePathDistance"])  # cm
s.set_editor_property("world_unit_scale", VALUES["WorldUnitScale"])
s.set_editor_property("enable_burley", VALUES["bEnableBurley"])
s.set_editor_property("enable_mean_free_path", VALUES["bEnableMeanFreePath"])
s.set_editor_property("tint", lc(VALUES["Tint"]))
s.set_editor_property("transmission_tint_color", lc(VALUES["TransmissionTintColor"]))
s.set_editor_property("roughness0", VALUES["Roughness0"])
s.set_editor_property("roughness1", VALUES["Roughness1"])
s.set_editor_property("lobe_mix", VALUES["LobeMix"])
s.set_editor_property("ior", VALUES["IOR"])
asset.set_editor_property("settings", s)
unreal.EditorAssetLibrary.save_loaded_asset(asset)
unreal.log("skinviewer: created %s/%s; set the material's Roughness to %.4f" % (FOLDER, NAME, VALUES["MaterialRoughness"]))
'''

BLENDER_SCRIPT = '''
import bpy

NAME = {name!r}

mat = bpy.data.materials.get(NAME) or bpy.data.materials.new(NAME)
mat.use_nodes = True
bsdf = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
if bsdf is None:
    bsdf = mat.node_tree.nodes.new("ShaderNodeBsdfPrincipled")
scale_length = bpy.context.scene.unit_settings.scale_length or 1.0  # metres per Blender unit
bsdf.inputs["Base Color"].default_value = (*VALUES["Base Color"], 1.0)
bsdf.inputs["Subsurface Weight"].default_value = VALUES["Subsurface Weight"]
bsdf.inputs["Subsurface Radius"].default_value = VALUES["Subsurface Radius"]
bsdf.inputs["Subsurface Scale"].default_value = VALUES["Subsurface Scale (m)"] / scale_length
bsdf.inputs["Roughness"].default_value = VALUES["Roughness"]
bsdf.inputs["IOR"].default_value = VALUES["IOR"]
bsdf.subsurface_method = VALUES["subsurface_method"]
print("skinviewer: material %s ready" % NAME)
'''


def blender_values(skin: E.EngineSkin) -> dict[str, Any]:
    v = E.cb_values(skin)
    return {"target": "blender", "Base Color": list(v["subsurface_color"]), "Subsurface Weight": 1.0,
            "Subsurface Radius": list(v["radius_color"]), "Subsurface Scale (m)": v["radius_scale_mm"] / E.MM_PER_M,
            "Roughness": v["roughness"], "IOR": v["ior"], "subsurface_method": "BURLEY"}


def _script(values: dict[str, Any], body: str, name: str, note: str) -> str:
    head = "".join(f"# {line}\n" for line in note.splitlines())
    lit = "VALUES = {\n" + "".join(f"    {k!r}: {_py(v)},\n" for k, v in values.items()) + "}\n"
    return head + "# VALUES is read back by `skinviewer import` (never executed there).\n" + lit + body.format(name=name)


def _py(v: Any) -> str:
    if isinstance(v, float):
        return _f(v)
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(_py(x) for x in v) + ")"
    return repr(v)


def materialx_doc(skin: E.EngineSkin, name: str, kind: str) -> MaterialX.Document:
    """A MaterialX document with one surface shader and its material; radius lengths in mm, marked
    with MaterialX's distance unit."""
    import MaterialX as mx
    v = E.cb_values(skin)
    doc = mx.createDocument()
    doc.setDocString("skinviewer export: Burley fit of the current profile; subsurface lengths in millimetres")
    if kind == "openpbr":
        if not _has_openpbr():
            raise ExchangeError(f"the installed MaterialX ({mx.getVersionString()}) has no open_pbr_surface")
        sh = doc.addNode("open_pbr_surface", f"{name}_shader", "surfaceshader")
        sh.setInputValue("base_color", mx.Color3(*v["subsurface_color"]))
        sh.setInputValue("subsurface_weight", 1.0)
        sh.setInputValue("subsurface_color", mx.Color3(*v["subsurface_color"]))
        i = sh.setInputValue("subsurface_radius", float(v["radius_scale_mm"]))
        sh.setInputValue("subsurface_radius_scale", mx.Color3(*v["radius_color"]))
    else:
        sh = doc.addNode("standard_surface", f"{name}_shader", "surfaceshader")
        sh.setInputValue("base_color", mx.Color3(*v["subsurface_color"]))
        sh.setInputValue("subsurface", 1.0)
        sh.setInputValue("subsurface_color", mx.Color3(*v["subsurface_color"]))
        sh.setInputValue("subsurface_radius", mx.Color3(*v["radius_color"]))
        i = sh.setInputValue("subsurface_scale", float(v["radius_scale_mm"]))
    i.setUnitType("distance")
    i.setUnit("millimeter")
    sh.setInputValue("specular_roughness", float(v["roughness"]))
    # standard_surface spells it specular_IOR, open_pbr_surface specular_ior
    sh.setInputValue("specular_ior" if kind == "openpbr" else "specular_IOR", float(v["ior"]))
    doc.addMaterialNode(name, sh)
    return doc


_LIB: MaterialX.Document | None = None


def _library() -> MaterialX.Document:
    global _LIB
    if _LIB is None:
        import MaterialX as mx
        lib = mx.createDocument()
        mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
        _LIB = lib
    return _LIB


def _has_openpbr() -> bool:
    return _library().getNodeDef("ND_open_pbr_surface_surfaceshader") is not None


def validate_mtlx(doc: MaterialX.Document) -> tuple[bool, str]:
    """MaterialX's own validator, against the standard libraries."""
    import MaterialX as mx
    check = mx.createDocument()
    check.copyContentFrom(doc)
    check.importLibrary(_library())
    ok, msg = check.validate()
    return bool(ok), str(msg)


def _note(fit: E.BurleyFit, description: str, extra: str = "") -> str:
    lines = [f"skinviewer export: Burley fit of {description}",
             "  channel        A     d (mm)   err r.R(r)   err R_d"]
    for c, ch in enumerate("RGB"):
        lines.append(f"  {ch:>7} {fit.A[c]:8.4f} {fit.d[c]:10.5f} {100 * fit.error[c]:10.2f} % "
                     f"{100 * fit.rd_error[c]:8.2f} %")
    if extra:
        lines.append(extra)
    return "\n".join(lines)


@dataclass
class ExportResult:
    written: list[Path]
    fields: dict[str, Any]  # what the target shows, for the table
    skin: E.EngineSkin
    fit: E.BurleyFit
    description: str


def _name_of(path: Path) -> str:
    n = re.sub(r"[^A-Za-z0-9_]", "_", path.stem) or "skin"
    return n if not n[0].isdigit() else "skin_" + n


def export(s: Settings, target: str, out: str | Path, metres_per_unit: float | None = None,
           world_unit_scale: float = 1.0, model: str | None = None) -> ExportResult:
    """Fit and write ``target``'s file(s) at ``out``. Every file is written atomically, and the
    HDRP pair (.asset + .meta) only after both texts are complete."""
    if target not in E.TARGETS:
        raise ExchangeError(f"unknown target {target!r} (have: {', '.join(E.TARGETS)})")
    out = Path(out)
    want = SUFFIX[target]
    if out.suffix.lower() != want:
        raise ExchangeError(f"{target} writes a {want} file, not {out.name!r}")
    if out.exists() and not out.is_file():
        raise ExchangeError(f"{out} exists and is not a file")
    skin, fit, desc = skin_of_settings(s, target, model)
    name = _name_of(out)
    if metres_per_unit is None:
        mpu = s.scene.mm_per_unit / E.MM_PER_M if s.scene.mm_per_unit else 1.0
    else:
        mpu = metres_per_unit
    if not (math.isfinite(mpu) and mpu > 0):
        raise ExchangeError(f"world scale must be > 0 metres per unit, got {mpu}")
    written: list[Path] = []
    if target == "hdrp":
        mode = 1 if s.screen.texturing == "post" else 0  # PostScatter / PreAndPostScatter
        fields = E.hdrp_values(skin, mpu)
        note = _note(fit, desc, f"HDRP normalises the profile: the albedo A belongs in the material's base colour; "
                                f"worldScale {mpu:g} m per unit")
        text = hdrp_text(skin, name, mpu, mode, note)
        meta = hdrp_meta(text)
        atomic_write_text(out, text)
        written.append(out)
        meta_path = out.with_name(out.name + ".meta")
        try:
            atomic_write_text(meta_path, meta)
        except BaseException:
            out.unlink(missing_ok=True)
            raise
        written.append(meta_path)
    elif target == "unreal":
        fields = unreal_values(skin, world_unit_scale)
        atomic_write_text(out, _script(fields, UNREAL_SCRIPT, name, _note(fit, desc, "Unreal units: cm")))
        written.append(out)
    elif target == "blender":
        fields = blender_values(skin)
        atomic_write_text(out, _script(fields, BLENDER_SCRIPT, name,
                                       _note(fit, desc, "Subsurface Scale: metres, divided by the scene's unit scale")))
        written.append(out)
    else:
        import MaterialX as mx
        doc = materialx_doc(skin, name, target)
        ok, msg = validate_mtlx(doc)
        if not ok:
            raise ExchangeError(f"MaterialX rejects the document: {msg.strip().splitlines()[0]}")
        fields = E.cb_values(skin)
        atomic_write_text(out, mx.writeToXmlString(doc))
        written.append(out)
    return ExportResult(written, fields, skin, fit, desc)


# ---------------------------------------------------------------------------------------------
# readers

@dataclass
class Imported:
    skin: E.EngineSkin
    target: str
    skipped: list[str] = field(default_factory=list)  # fields read but not understood / not used
    notes: list[str] = field(default_factory=list)
    metres_per_unit: float | None = None
    has_roughness: bool = True  # False: the target keeps roughness in the material (HDRP)


def _key(k: str) -> str:
    return re.sub(r"[^a-z0-9]", "", k.lower())


def _num(v: Any, what: str) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ExchangeError(f"{what}: expected a number, got {v!r}") from None
    if not math.isfinite(x):
        raise ExchangeError(f"{what} is {x}: expected a finite number")
    return x


def _col(v: Any, what: str) -> tuple[float, float, float]:
    if isinstance(v, dict):
        v = [v.get(c) for c in "rgb"] if all(c in v for c in "rgb") else [v.get(c) for c in "xyz"]
    if not isinstance(v, (list, tuple)) or len(v) < 3:
        raise ExchangeError(f"{what}: expected r, g, b, got {v!r}")
    return tuple(_num(x, f"{what}[{i}]") for i, x in enumerate(v[:3]))  # type: ignore[return-value]


def _positive(c: tuple[float, ...], what: str) -> None:
    for i, x in enumerate(c):
        if x <= 0:
            raise ExchangeError(f"{what} has {x:g} in channel {'rgb'[i]}: distances must be > 0")


def _skin(make: Callable[[], E.EngineSkin]) -> E.EngineSkin:
    try:
        return make()
    except ValueError as exc:
        raise ExchangeError(str(exc)) from None


def _class_loader() -> type[yaml.SafeLoader]:
    import yaml

    class Loader(yaml.SafeLoader):
        pass

    def unity(loader: yaml.SafeLoader, suffix: str, node: yaml.Node) -> dict[Any, Any]:  # `--- !u!114 &11400000` documents: plain mappings
        if not isinstance(node, yaml.MappingNode):  # Unity's MonoBehaviour documents are mappings
            raise yaml.constructor.ConstructorError(None, None, f"expected a mapping for {suffix}", node.start_mark)
        return loader.construct_mapping(node, deep=True)

    Loader.add_multi_constructor("tag:unity3d.com,2011:", unity)
    return Loader


def parse_unity_yaml(text: str) -> list[dict[str, Any]]:
    import yaml
    try:
        docs = [d for d in yaml.load_all(text, Loader=_class_loader()) if d is not None]
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise ExchangeError(f"not valid Unity YAML{where}: {getattr(exc, 'problem', None) or exc}") from None
    return docs


HDRP_KNOWN = {"scatteringDistance", "scatteringDistanceMultiplier", "ior", "worldScale", "hash",
              "smoothnessMultipliers", "lobeMix"}
HDRP_KEPT = {"transmissionTint", "texturingMode", "transmissionMode", "thicknessRemap", "diffuseShadingPower"}


def read_hdrp(text: str) -> Imported:
    docs = parse_unity_yaml(text)
    mono = next((d["MonoBehaviour"] for d in docs if isinstance(d, dict) and "MonoBehaviour" in d), None)
    if mono is None:
        kinds = ", ".join(sorted({next(iter(d)) for d in docs if isinstance(d, dict) and d})) or "nothing"
        raise ExchangeError(f"not an HDRP Diffusion Profile: the asset holds {kinds}, no MonoBehaviour")
    guid = str((mono.get("m_Script") or {}).get("guid", ""))
    if guid != HDRP_SCRIPT_GUID:
        raise ExchangeError(f"not an HDRP Diffusion Profile: m_Script guid {guid or '(none)'} is another "
                            f"script (DiffusionProfileSettings is {HDRP_SCRIPT_GUID})")
    notes: list[str] = []
    version = mono.get("m_Version", 0)
    if "profiles" in mono and "profile" not in mono:
        raise ExchangeError("an HDRP diffusion profile list (m_Version 0, up to 16 profiles per asset): "
                            "open it in HDRP 7+ to split it into single-profile assets first")
    prof = mono.get("profile")
    if not isinstance(prof, dict):
        raise ExchangeError("the asset has no 'profile' section")
    skipped = [f"profile.{k}" for k in prof if k not in HDRP_KNOWN | HDRP_KEPT]
    skipped += [k for k in mono if k not in {"profile", "m_Version"} and not k.startswith("m_")]
    if isinstance(version, int) and version > HDRP_VERSION:
        notes.append(f"m_Version {version} is newer than this reader's {HDRP_VERSION}: read the fields it knows")
    kept = sorted(k for k in HDRP_KEPT if k in prof)
    if kept:
        notes.append(f"kept for the engine, no equivalent here: {', '.join(kept)}")
    c = _col(prof.get("scatteringDistance"), "scatteringDistance")
    # m_Version 1 stored the whole distance in the colour (no multiplier)
    mult = _num(prof.get("scatteringDistanceMultiplier", 1.0), "scatteringDistanceMultiplier")
    _positive(tuple(x * mult for x in c), "scatteringDistance x multiplier")
    ior = _num(prof.get("ior", 1.4), "ior")
    ws = _num(prof.get("worldScale", 1.0), "worldScale")
    if ws <= 0:
        raise ExchangeError(f"worldScale is {ws:g}: it must be > 0 metres per unit")
    lobe = prof.get("lobeMix", 0)
    if lobe and _num(lobe, "lobeMix") > 0:
        notes.append(f"lobeMix {lobe} (dual-lobe specular) is read as one lobe")
    skin = _skin(lambda: E.hdrp_skin(c, mult, ior))
    return Imported(skin, "hdrp", skipped, notes, ws, has_roughness=False)


def read_mtlx(text: str, material: str | None = None) -> Imported:
    import MaterialX as mx
    doc = mx.createDocument()
    opts = mx.XmlReadOptions()
    opts.readXIncludeFunction = None  # an import reads the one file given: no <xi:include href="/etc/...">
    try:
        mx.readFromXmlString(doc, text, mx.FileSearchPath(), opts)
    except (mx.ExceptionParseError, mx.Exception, ValueError) as exc:
        raise ExchangeError(f"not a MaterialX document: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
    shaders = [n for n in doc.getNodes() if n.getCategory() in ("standard_surface", "open_pbr_surface")]
    mats = [n for n in doc.getMaterialNodes()]
    if material:
        by_mat = {m.getName(): m for m in mats}
        if material in by_mat:
            names = [i.getNodeName() for i in by_mat[material].getInputs() if i.getName() == "surfaceshader"]
            shaders = [n for n in shaders if n.getName() in names]
        else:
            shaders = [n for n in shaders if n.getName() == material]
        if not shaders:
            raise ExchangeError(f"no material or surface shader {material!r} (have: "
                                f"{', '.join(m.getName() for m in mats) or 'none'})")
    if not shaders:
        cats = sorted({n.getCategory() for n in doc.getNodes()})
        raise ExchangeError("no standard_surface or open_pbr_surface in the document (it has: "
                            f"{', '.join(cats) or 'no nodes'})")
    if len(shaders) > 1:
        raise ExchangeError(f"{len(shaders)} surface shaders ({', '.join(n.getName() for n in shaders)}): "
                            "pick one with --material NAME")
    sh = shaders[0]
    kind = "openpbr" if sh.getCategory() == "open_pbr_surface" else "materialx"
    vals: dict[str, Any] = {}
    units: dict[str, str] = {}
    for i in sh.getInputs():
        if i.getNodeName() or i.getNodeGraphString() or i.getOutputString():
            vals[i.getName()] = None  # connected: not a constant
            continue
        vals[i.getName()] = i.getValue()
        if i.hasUnit():
            units[i.getName()] = i.getUnit()
    if kind == "openpbr":
        used = {"base_color", "subsurface_weight", "subsurface_color", "subsurface_radius",
                "subsurface_radius_scale", "specular_roughness", "specular_ior"}
        col, rad, scale_key = "subsurface_color", "subsurface_radius_scale", "subsurface_radius"
        weight = vals.get("subsurface_weight", 0.0)
    else:
        used = {"base_color", "subsurface", "subsurface_color", "subsurface_radius", "subsurface_scale",
                "specular_roughness", "specular_IOR"}
        col, rad, scale_key = "subsurface_color", "subsurface_radius", "subsurface_scale"
        weight = vals.get("subsurface", 0.0)
    connected = [k for k in used if k in vals and vals[k] is None]
    if connected:
        raise ExchangeError(f"{', '.join(sorted(connected))} connected to a node graph: only constant values are read")
    skipped = sorted(k for k in vals if k not in used)
    notes: list[str] = []
    if weight is not None and _num(weight, "subsurface weight") < 1.0:
        notes.append(f"subsurface weight {weight:g} < 1: the profile is read as fully subsurface")
    radius = _col(list(vals.get(rad, (1.0, 1.0, 1.0))), rad)
    scale = _num(vals.get(scale_key, 1.0), scale_key)
    unit = units.get(scale_key, "millimeter")
    mm = _unit_mm(unit)
    if scale_key not in units:
        notes.append(f"{scale_key} has no unit: read as millimetres")
    _positive(tuple(x * scale for x in radius), f"{rad} x {scale_key}")
    colour = _col(list(vals.get(col, (0.8, 0.8, 0.8))), col)
    rough = _num(vals.get("specular_roughness", 0.548), "specular_roughness")
    ior_key = "specular_ior" if kind == "openpbr" else "specular_IOR"
    ior = _num(vals.get(ior_key, 1.4), ior_key)
    skin = _skin(lambda: E.cb_skin(colour, radius, scale * mm, rough, ior))
    return Imported(skin, kind, skipped, notes)


_UNITS_MM = {"nanometer": 1e-6, "micron": 1e-3, "millimeter": 1.0, "centimeter": 10.0, "inch": 25.4,
             "foot": 304.8, "yard": 914.4, "meter": 1000.0, "kilometer": 1e6, "mile": 1.609344e6}


def _unit_mm(unit: str) -> float:
    if unit not in _UNITS_MM:
        raise ExchangeError(f"unknown distance unit {unit!r} (MaterialX has: {', '.join(_UNITS_MM)})")
    return _UNITS_MM[unit]


UNREAL_USED = {"target", "surfacealbedo", "meanfreepathcolor", "meanfreepathdistance", "worldunitscale", "ior",
               "materialroughness", "benableburley", "benablemeanfreepath", "enableburley", "enablemeanfreepath",
               "roughness0", "roughness1", "lobemix"}
BLENDER_USED = {"target", "basecolor", "subsurfaceweight", "subsurfaceradius", "subsurfacescalem",
                "subsurfacescale", "roughness", "ior", "subsurfacemethod", "scalelength"}
HDRP_USED = {"target", "scatteringdistance", "scatteringdistancemultiplier", "ior", "worldscale", "smoothness",
             "multiplier"}


def skin_from_values(values: dict[str, Any]) -> Imported:
    """The values an engine shows (JSON, or an exported script's VALUES), keyed by the engine's
    names in any spelling (``Mean Free Path Distance``, ``MeanFreePathDistance``, ``mean_free_path_distance``)."""
    if not isinstance(values, dict):
        raise ExchangeError("expected a JSON object of the values an engine shows")
    v = {_key(str(k)): x for k, x in values.items()}
    orig = {_key(str(k)): str(k) for k in values}
    target = str(v.get("target", "")).lower()
    if not target:
        target = ("unreal" if "meanfreepathdistance" in v else "hdrp" if "scatteringdistance" in v
                  else "blender" if "subsurfaceradius" in v else "")
    notes: list[str] = []
    if target == "unreal":
        used = UNREAL_USED
        need = ["surfacealbedo", "meanfreepathcolor", "meanfreepathdistance"]
        _require(v, need, orig, "Unreal")
        if v.get("benablemeanfreepath", v.get("enablemeanfreepath", True)) is False:
            raise ExchangeError("bEnableMeanFreePath is off (a UE4 diffuse-mean-free-path profile): open and save "
                                "it in UE5 to upgrade it first")
        mfp_col = _col(v["meanfreepathcolor"], "MeanFreePathColor")
        dist = _num(v["meanfreepathdistance"], "MeanFreePathDistance")
        _positive(tuple(x * dist for x in mfp_col), "MeanFreePathColor x MeanFreePathDistance")
        albedo = _col(v["surfacealbedo"], "SurfaceAlbedo")
        rough = _num(v.get("materialroughness", 0.548), "MaterialRoughness")
        ior = _num(v.get("ior", 1.4), "IOR")
        skin = _skin(lambda: E.unreal_skin(albedo, mfp_col, dist, ior, rough))
    elif target == "hdrp":
        used = HDRP_USED
        _require(v, ["scatteringdistance"], orig, "HDRP")
        c = _col(v["scatteringdistance"], "scatteringDistance")
        mult = _num(v.get("scatteringdistancemultiplier", v.get("multiplier", 1.0)), "scatteringDistanceMultiplier")
        _positive(tuple(x * mult for x in c), "scatteringDistance x multiplier")
        ior = _num(v.get("ior", 1.4), "ior")
        sm = v.get("smoothness")
        skin = _skin(lambda: E.hdrp_skin(c, mult, ior, None if sm is None else _num(sm, "smoothness")))
    elif target == "blender":
        used = BLENDER_USED
        _require(v, ["basecolor", "subsurfaceradius"], orig, "Blender")
        if "subsurfacescalem" in v:
            scale_mm = _num(v["subsurfacescalem"], "Subsurface Scale (m)") * E.MM_PER_M
        else:  # the UI shows scene units: metres x scale_length
            scale_mm = (_num(v.get("subsurfacescale", 0.05), "Subsurface Scale")
                        * _num(v.get("scalelength", 1.0), "scale_length") * E.MM_PER_M)
        rad = _col(v["subsurfaceradius"], "Subsurface Radius")
        _positive(tuple(x * scale_mm for x in rad), "Subsurface Radius x Subsurface Scale")
        base = _col(v["basecolor"], "Base Color")
        rough = _num(v.get("roughness", 0.5), "Roughness")
        ior = _num(v.get("ior", 1.4), "IOR")
        skin = _skin(lambda: E.cb_skin(base, rad, scale_mm, rough, ior))
        if str(v.get("subsurfacemethod", "BURLEY")).upper() != "BURLEY":
            notes.append(f"subsurface_method {v['subsurfacemethod']}: read with the Christensen-Burley mapping")
    else:
        raise ExchangeError("cannot tell which engine these values are from: give \"target\": "
                            "\"unreal\" | \"hdrp\" | \"blender\" (or their fields)")
    skipped = sorted(orig[k] for k in v if k not in used)
    ws = None
    if target == "hdrp" and "worldscale" in v:
        ws = _num(v["worldscale"], "worldScale")
        if ws <= 0:
            raise ExchangeError(f"worldScale is {ws:g}: it must be > 0 metres per unit")
    has_rough = target != "hdrp" or "smoothness" in v
    return Imported(skin, target, skipped, notes, ws, has_roughness=has_rough)


def _require(v: dict[str, Any], keys: list[str], orig: dict[str, Any], what: str) -> None:
    missing = [k for k in keys if k not in v]
    if missing:
        raise ExchangeError(f"{what} values lack {', '.join(missing)}")


def read_script(text: str) -> Imported:
    """An exported Unreal/Blender script: its VALUES literal, parsed with ``ast`` (never run)."""
    try:
        tree = ast.parse(text)
    except SyntaxError as exc:
        raise ExchangeError(f"not a Python script (line {exc.lineno}: {exc.msg})") from None
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "VALUES" for t in node.targets):
            try:
                values = ast.literal_eval(node.value)
            except ValueError:
                raise ExchangeError("VALUES is not a literal: not a script skinviewer wrote") from None
            return skin_from_values(values)
    raise ExchangeError("no VALUES = {...} in the script: not one skinviewer exported")


def read_any(path: str | Path, material: str | None = None) -> Imported:
    try:
        return _read_any(path, material)
    except RecursionError:  # JSON, YAML or a script literal nested thousands deep
        raise ExchangeError("nested too deeply to be an engine's profile") from None


def _read_any(path: str | Path, material: str | None = None) -> Imported:
    p = Path(path)
    try:
        data = read_regular_file(p, MAX_IMPORT_BYTES, what=str(p))
    except FileReadError as exc:
        raise ExchangeError(str(exc)) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ExchangeError(f"{p.name} is not text (a binary asset? Unreal's .uasset is not readable: "
                            "export the values as JSON)") from None
    ext = p.suffix.lower()
    if ext == ".asset" or text.startswith("%YAML"):
        return read_hdrp(text)
    if ext == ".mtlx" or text.lstrip().startswith("<?xml") or text.lstrip().startswith("<materialx"):
        return read_mtlx(text, material)
    if ext == ".py":
        return read_script(text)
    if ext == ".json" or text.lstrip().startswith("{"):
        try:
            values = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ExchangeError(f"not valid JSON (line {exc.lineno}: {exc.msg})") from None
        return skin_from_values(values)
    raise ExchangeError(f"{p.name}: not a format this reads (.asset, .mtlx, .json, or an exported .py)")


def settings_with(base: Settings, imp: Imported, k: int = 6) -> tuple[Settings, Any]:
    """``base`` with the imported profile: the burley section (d = mfp, 'direct', as HDRP-new),
    the techniques' Gaussians fitted to it (the profile lab's fit, weights normalised per channel:
    R_d belongs in the albedo), and the specular."""
    from skinviewer.physics.fitting import fit_gaussians
    skin = imp.skin
    A = np.clip(skin.A, 1e-6, 1.0)
    prof = Burley(A, skin.d_mm * burley_scale(A, "searchlight-dmfp"), "searchlight-dmfp")  # d = mfp / s(A)
    fit = fit_gaussians(prof, k, shared=True)
    rows = fit.table(normalize=True)
    vals = {"burley.albedo": [float(x) for x in A], "burley.mfp": [float(x) for x in skin.d_mm],
            "burley.fit": "direct", "burley.scale": 1.0,
            "deon.gaussians": [{"variance": v, "weights": list(w)} for v, w in rows if max(w) > 0],
            "specular.f0": E.ior_to_f0(skin.ior)}
    if imp.has_roughness:
        vals["specular.m"] = E.roughness_to_beckmann(skin.roughness)
    return with_values(base, vals), fit
