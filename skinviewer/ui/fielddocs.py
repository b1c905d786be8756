"""Labels, units and tooltips of the settings: a technique's fields declare theirs in their section
(``ground/sections/<technique>.py``, ``field(label=, unit=, tip=)``); the shared sections' are the
tables below, keyed by dotted path (list indices as ``*``).
Equation numbers refer to seed 000 (the survey text the techniques follow) unless another seed is
named. The panel shows the label (words an artist uses; the paper's term is in the tooltip) with
the unit, and the text as the field's tooltip. A label with its unit must fit the panel's label
column (``LABEL_MAX_PX`` at the default font; a test checks every field)."""
from __future__ import annotations

import functools
import re
import typing
from typing import Any

from pydantic import BaseModel

from skinviewer.ground.sections.base import FieldDoc, field_doc
from skinviewer.ground.settings import Settings

# path -> (unit shown in the label, tooltip)
FIELD_DOCS: dict[str, tuple[str, str]] = {
    # scene
    "scene.mm_per_unit": ("mm", "millimetres per mesh unit: every physical length (Gaussian variances, TSM "
                          "thickness, stretch, eq. 27) is converted with it. Auto: the scene's own (built-ins are in mm)."),
    "scene.head_detail": ("", "resolution of the generated head: 0 small, 1 normal, 2 fine"),
    # camera
    "camera.yaw": ("deg", "orbit angle about +Y (LMB drag in the view)"),
    "camera.pitch": ("deg", "orbit elevation (LMB drag in the view)"),
    "camera.distance": ("units", "eye-to-target distance (mouse wheel). Auto: frame the mesh's bounding sphere"),
    "camera.target": ("units", "look-at point (MMB / shift+LMB pan). Auto: the mesh's bounds centre"),
    "camera.fov_y": ("deg", "vertical field of view"),
    # lights
    "lights.*.intensity": ("", "radiance scale of the light (linear); with colour it is Lc of eq. 8-10 / 28"),
    "lights.*.color": ("linear RGB", "light colour (linear, may exceed 1)"),
    "lights.*.direction": ("", "directional: the direction towards the light (normalised internally); "
                           "beam: the beam's axis"),
    "lights.*.position": ("units", "point / beam light position"),
    "lights.*.beam_radius": ("units", "radius of the collimated beam (the laser of seed 002 §14.4.1)"),
    "lights.*.cast_shadow": ("", "render a shadow map for this light (eq. 1-7)"),
    "lights.*.kind": ("", "directional, point, or a collimated beam (laser)"),
    # shadows
    "shadow.map_size": ("texels", "shadow-map resolution per light (eq. 1-6). Texture-space cost: re-runs every pass"),
    "shadow.tol": ("", "depth tolerance of the shadow test, eq. 7: shadowed if d(P) - d_s > tol "
                   "(normalised light-space depth)"),
    "shadow.pcf": ("texels", "percentage-closer filter radius (0 = the hard test of eq. 7)"),
    "shadow.pcf_filter": ("", "bilinear: the filter box slides with the exact lookup position, so shadow edges are "
                          "smooth instead of stepped in shadow-map texels (a little more work); box: snapped to texels"),
    # render
    "render.exposure": ("x", "linear exposure multiplier before the sRGB encode"),
    "render.background": ("linear RGB", "clear colour of the 3D view"),
    "render.timing": ("", "auto (default): gpu on a hardware GPU, sync on a software rasterizer; "
                      "sync: glFinish + wall clock per pass (true cost on llvmpipe, but a glFinish between "
                      "passes costs a GPU its overlap); gpu: GL_TIME_ELAPSED queries (accurate on real GPUs, "
                      "far too low on llvmpipe)"),
    "render.mesh_lod": ("", "auto: when the head is so small on screen that its triangles are far under a pixel "
                        "(over 4 per pixel), draw a coarser copy (1/4 of the triangles per level, UV seams kept) "
                        "and say so in the passes window; full: always the whole mesh"),
    "render.compute_blur": ("", "d'Eon's separable blurs and seam fills as compute passes (the same values as the "
                            "fragment draws): auto on an OpenGL 4.3 GPU, not on llvmpipe (slower there); on: wherever "
                            "the context has compute shaders (the passes window says when it has not); off: draws"),
    "render.check_finite": ("", "after a pass runs, scan its outputs for NaN/Inf on the GPU; the passes window "
                            "names a pass whose output is not finite (the screen shows the background there)"),
    # specular (Kelemen / Szirmay-Kalos)
    "specular.m": ("", "Beckmann roughness m of the Kelemen/Szirmay-Kalos BRDF, eq. 14-16 (seed 002 §14.3)"),
    "specular.f0": ("", "Fresnel reflectance at normal incidence (Schlick), eq. 14; skin ~0.028"),
    "specular.rho_s": ("", "specular intensity rho_s, eq. 16; also scales the rho_dt energy table (eq. 30-31)"),
    "specular.mode": ("", "direct: evaluate P_H analytically; beckmann_lut: listing 14-2's lookup texture"),
    "specular.lut_size": ("texels", "Beckmann lookup texture size (beckmann_lut mode)"),
    # the techniques' fields: their section modules (ground/sections/*.py, base.field)
    "scene.stretch_metric": ("", "vertex: the stretch map from the surface metric averaged at the vertices and "
                             "interpolated (smooth where the UVs are not); triangle: per triangle, as printed (eq. 27)"),
    "scene.back_faces": ("", "cull: the camera sees front faces only; show: the back of the surface too, lit "
                         "through the reversed normal (open sheets); auto: cull on a closed mesh, show on an open one"),
    "render.texel_surface": ("", "texture-space maps are shaded once per texel from a per-mesh map of the surface "
                             "instead of rasterising the mesh each time (same image, much faster; more memory)"),
    "shadow.map_size_mode": ("", "fixed: the shadow map size above; auto: from the head's size on screen"),
}

# path -> label (default: the field name with spaces). Short: the panel's label column is narrow.
LABELS: dict[str, str] = {
    "scene.mm_per_unit": "size of 1 unit",
    "scene.head_detail": "head detail",
    "scene.albedo_map": "colour map",
    "scene.specular_map": "specular map",
    "scene.region_map": "region map",
    "camera.fov_y": "field of view",
    "camera.target": "look at",
    "render.background": "background",
    "render.background_environment": "environment behind",
    "render.timing": "timing method",
    "render.mesh_lod": "mesh level of detail",
    "render.compute_blur": "compute blurs",
    "shadow.map_size": "shadow map size",
    "shadow.tol": "shadow bias",
    "shadow.pcf": "shadow softness",
    "shadow.pcf_filter": "shadow filter",
    "specular.m": "roughness",
    "specular.f0": "reflectance F0",
    "specular.rho_s": "intensity",
    "specular.mode": "evaluation",
    "specular.lut_size": "lookup size",
    "scene.stretch_metric": "stretch from",
    "scene.back_faces": "back faces",
    "shadow.map_size_mode": "shadow map sizing",
    "lights.*.intensity": "intensity",
    "lights.*.beam_radius": "beam radius",
    "lights.*.cast_shadow": "casts shadow",
}
LABEL_MAX_PX = 160.0  # the panel's label column at its default width (panel.LABEL_COLUMN_PX)

_INDEX = re.compile(r"\.\d+(?=\.|$)")


def generic(path: str) -> str:
    """``lights.0.intensity`` -> ``lights.*.intensity``; ``gosselin.regions.ears.scale_x`` ->
    ``gosselin.regions.*.scale_x``."""
    p = _INDEX.sub(".*", path)
    if p.startswith("gosselin.regions.") or p.startswith("specular.per_region."):
        parts = p.split(".")
        if len(parts) >= 4:
            parts[2] = "*"
            p = ".".join(parts)
    return p


def _inner_model(ann: Any) -> Any:
    """The section model a field holds: X of X, list[X], dict[str, X], X | None; else None."""
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann
    for a in reversed(typing.get_args(ann)):
        m = _inner_model(a)
        if m is not None:
            return m
    return None


@functools.cache
def _declared(path: str) -> FieldDoc | None:
    """The FieldDoc a section declared for the generic ``path`` (ground/sections/base.field), or None."""
    model: Any = Settings
    info = None
    for part in path.split("."):
        if part == "*":
            continue
        if model is None or part not in model.model_fields:
            return None
        info = model.model_fields[part]
        model = _inner_model(info.annotation)
    return field_doc(info)


def doc(path: str) -> tuple[str, str]:
    """(unit, tooltip) of the setting at ``path``: its section's declaration, else the table."""
    p = generic(path)
    d = _declared(p)
    return (d.unit, d.tip) if d is not None else FIELD_DOCS.get(p, ("", ""))


def label(path: str, name: str | None = None) -> str:
    """The label of the setting at ``path`` (its field name with spaces when it has none)."""
    p = generic(path)
    d = _declared(p)
    given = d.label if d is not None and d.label else LABELS.get(p)
    return given or (name or path.rsplit(".", 1)[-1]).replace("_", " ")


def label_with_unit(name: str, path: str) -> str:
    text, unit = label(path, name), doc(path)[0]
    return f"{text} ({unit})" if unit else text
