"""Labels, units and tooltips of the settings, keyed by dotted path (list indices as ``*``).
Equation numbers refer to seed 000 (the survey text the techniques follow) unless another seed is
named. The panel shows the label (words an artist uses; the paper's term is in the tooltip) with
the unit, and the text as the field's tooltip. A label with its unit must fit the panel's label
column (``LABEL_MAX_PX`` at the default font; a test checks every field)."""
from __future__ import annotations

import re

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
    "deon.specular_shadows": ("", "where the specular's shadow test (eq. 10) is evaluated. texture: once per "
                               "irradiance texel, with the same PCF, kept per light, so orbiting does no "
                               "shadow-map lookups (a camera move costs about a quarter less). pixel: per "
                               "pixel in the final pass"),
    "render.mesh_lod": ("", "auto: when the head is so small on screen that its triangles are far under a pixel "
                        "(over 4 per pixel), draw a coarser copy (1/4 of the triangles per level, UV seams kept) "
                        "and say so in the passes window; full: always the whole mesh"),
    "render.check_finite": ("", "after a pass runs, scan its outputs for NaN/Inf on the GPU; the passes window "
                            "names a pass whose output is not finite (the screen shows the background there)"),
    # phong
    "phong.ambient": ("", "ambient term (fraction of albedo)"),
    "phong.specular": ("", "Blinn-Phong specular intensity"),
    "phong.shininess": ("exponent", "Blinn-Phong exponent (higher = tighter highlight)"),
    # specular (Kelemen / Szirmay-Kalos)
    "specular.m": ("", "Beckmann roughness m of the Kelemen/Szirmay-Kalos BRDF, eq. 14-16 (seed 002 §14.3)"),
    "specular.f0": ("", "Fresnel reflectance at normal incidence (Schlick), eq. 14; skin ~0.028"),
    "specular.rho_s": ("", "specular intensity rho_s, eq. 16; also scales the rho_dt energy table (eq. 30-31)"),
    "specular.mode": ("", "direct: evaluate P_H analytically; beckmann_lut: listing 14-2's lookup texture"),
    "specular.lut_size": ("texels", "Beckmann lookup texture size (beckmann_lut mode)"),
    # gosselin
    "gosselin.light_map_size": ("texels", "texture-space light map resolution, eq. 8-10. Texture-space cost ~ size^2"),
    "gosselin.iterations": ("", "number of 13-tap Poisson blurs, eq. 11-13 (each adds to the blur radius)"),
    "gosselin.scale_x": ("", "blur radius scale (scale_x of eq. 12: radius = size * (kernel_size * scale_x + "
                         "scale_y)); multiplies the per-region scale"),
    "gosselin.scale_y": ("texels", "extra blur radius in light-map texels at a 1024² map (rescaled to the map "
                         "size): scale_y of eq. 12, added to the per-region one"),
    "gosselin.specular_shadow": ("", "eq. 18 shadow attenuation of the specular: visibility (default) or as printed"),
    "gosselin.regions.*.kernel_size": ("", "per-region kernel size of eq. 12 (ears and nose scatter more)"),
    "gosselin.regions.*.scale_x": ("", "per-region blur radius scale (scale_x of eq. 12)"),
    "gosselin.regions.*.scale_y": ("texels", "per-region extra blur radius (scale_y of eq. 12), in light-map "
                                   "texels at a 1024² map"),
    # d'Eon
    "deon.gaussians.*.variance": ("mm²", "variance v_i of Gaussian i (mm²), seed 000 eq. 20: "
                                  "G(v, r) = exp(-r²/2v) / (2 pi v). Blurs are incremental: v_i - v_(i-1), eq. 24"),
    "deon.gaussians.*.weights": ("RGB", "weights w_i of R(r) = sum_i w_i G(v_i, r), seed 000 eq. 21; "
                                 "each channel's weights should sum to 1 (energy)"),
    "deon.mix": ("", "how much of the skin colour is applied before the blur (pre-scatter texturing): "
                 "albedo^mix before, albedo^(1-mix) after, eq. 28 and 34. 0: sharp colour detail, 1: blurred"),
    "deon.stretch": ("", "stretch-corrected blur radii from the UV stretch map (eq. 27, used in eq. 25)"),
    "deon.stretch_per_gaussian": ("", "a stretch map per Gaussian width instead of one (eq. 25-27)"),
    "deon.stretch_shear": ("", "the blur follows the full UV->surface Jacobian: the second pass runs along the "
                           "texels' shear, so a skewed parametrisation blurs round (eq. 27 keeps lengths only)"),
    "scene.stretch_metric": ("", "vertex: the stretch map from the surface metric averaged at the vertices and "
                             "interpolated (smooth where the UVs are not); triangle: per triangle, as printed (eq. 27)"),
    "scene.back_faces": ("", "cull: the camera sees front faces only; show: the back of the surface too, lit "
                         "through the reversed normal (open sheets); auto: cull on a closed mesh, show on an open one"),
    "deon.tsm": ("", "translucent shadow map: light through thin parts (ears), eq. 32-33"),
    "deon.tsm_size": ("texels", "translucent shadow map (TSM) resolution, eq. 32. Texture-space cost"),
    "deon.tsm_form": ("", "how light through thin parts fades with thickness d (translucent shadow map, eq. 33). "
                      "exact: exp(-d²/(2 v_i)); printed: exp(-d²/v_i) as printed in seed 000"),
    "deon.tsm_gather": ("samples", "light through folds: each wide Gaussian gathers this many lit points around the "
                        "light ray from the TSM, each at its own 3D distance, so an ear's folds lit from behind glow "
                        "(0: eq. 33's one lit point on the ray). Cost: once per light change"),
    "deon.energy_conservation": ("", "scale diffuse by 1 - rho_dt (eq. 30-31) at the light and the eye (eq. 28, 34)"),
    "deon.irradiance_size": ("texels", "resolution of the texture-space irradiance the blurs run on (eq. 28). "
                             "Texture-space cost ~ size² per blur pass"),
    "deon.reuse_irradiance_below_texels": ("texels", "skip the finest blur when its width is under this many "
                                             "texels (a blur narrower than a texel changes nothing): blur 1 "
                                             "reuses the irradiance itself"),
    "deon.irradiance_size_mode": ("", "fixed: the blur map size above; auto: sized from the head's size on screen "
                                  "(about a texel per pixel, the size above at most, with hysteresis)"),
    "deon.surface_gather_below_texels": ("texels", "a blur step at most this many texels wide is summed over the "
                                         "surface with 3D distances (closer to the truth where the atlas is "
                                         "coarse or uneven; slower); 0: every blur separable"),
    "deon.fold_below_texels": ("texels", "skip a later blur whose width step is under this many texels; the next "
                               "blur adds its width exactly (0: off). 1: closer to the ground truth than 0"),
    "deon.open_border": ("", "reflect: past an open mesh border each blur after the first reads the light "
                         "reflected about the border, so the rim keeps the light the surface keeps (issue 30); "
                         "absorb: no light there (the rim loses light)"),
    "deon.skip_gutters": ("", "blurs draw only the tiles of the UV islands and the ring a reader can reach "
                          "(images identical; the summed blur step ~15 % cheaper at 1024^2 maps)"),
    "render.texel_surface": ("", "texture-space maps are shaded once per texel from a per-mesh map of the surface "
                             "instead of rasterising the mesh each time (same image, much faster; more memory)"),
    "deon.tsm_auto": ("", "skip the translucent shadow map when no light is behind a thin part that is in view"),
    "deon.subpixel_kernel_px": ("px", "when the widest Gaussian spans under this many pixels on screen, the "
                                "diffusion cannot show: the blurs and TSM are skipped (0: never)"),
    "deon.combine_blurs": ("", "sum the weighted blurs and the transmitted light once in texture space, so an "
                           "orbit reads one texture (eq. 33-34; equal up to rounding)"),
    "gosselin.radius_mode": ("", "printed: eq. 12's radii in texels at a 1024 map; mm: per-channel radii from the "
                             "d'Eon profile's variance, through the stretch map (compares with d'Eon)"),
    "shadow.map_size_mode": ("", "fixed: the shadow map size above; auto: from the head's size on screen"),
    "burley.transmission": ("", "light through thin parts from the shadow-map thickness t (spec §5.4): closed "
                            "form (e^(-St) + 3e^(-St/3))/4, HDRP's thick mode e^(-St/3), or Jimenez 2010's"),
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
    "deon.specular_shadows": "specular shadows",
    "shadow.map_size": "shadow map size",
    "shadow.tol": "shadow bias",
    "shadow.pcf": "shadow softness",
    "shadow.pcf_filter": "shadow filter",
    "phong.shininess": "shininess",
    "specular.m": "roughness",
    "specular.f0": "reflectance F0",
    "specular.rho_s": "intensity",
    "specular.mode": "evaluation",
    "specular.lut_size": "lookup size",
    "gosselin.light_map_size": "light map size",
    "gosselin.iterations": "blur passes",
    "gosselin.scale_x": "blur scale",
    "gosselin.scale_y": "blur offset",
    "gosselin.specular_shadow": "specular shadow",
    "gosselin.regions.*.kernel_size": "kernel size",
    "gosselin.regions.*.scale_x": "blur scale",
    "gosselin.regions.*.scale_y": "blur offset",
    "deon.mix": "colour before blur",
    "deon.stretch": "stretch correction",
    "deon.stretch_per_gaussian": "stretch per Gaussian",
    "deon.stretch_shear": "stretch with shear",
    "scene.stretch_metric": "stretch from",
    "scene.back_faces": "back faces",
    "deon.tsm": "translucency (TSM)",
    "deon.tsm_size": "translucency map",
    "deon.tsm_light": "translucency light",
    "deon.tsm_form": "translucency falloff",
    "deon.tsm_gather": "fold gather",
    "deon.energy_conservation": "energy conservation",
    "deon.irradiance_size": "blur map size",
    "deon.reuse_irradiance_below_texels": "skip finest blur",
    "deon.irradiance_size_mode": "blur map sizing",
    "deon.surface_gather_below_texels": "surface sum",
    "deon.open_border": "open border",
    "deon.fold_below_texels": "fold narrow blurs",
    "deon.subpixel_kernel_px": "skip blur under",
    "deon.combine_blurs": "sum in texture space",
    "gosselin.radius_mode": "radius units",
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


def doc(path: str) -> tuple[str, str]:
    return FIELD_DOCS.get(generic(path), ("", ""))


def label(path: str, name: str | None = None) -> str:
    """The label of the setting at ``path`` (its field name with spaces when it has none)."""
    return LABELS.get(generic(path), (name or path.rsplit(".", 1)[-1]).replace("_", " "))


def label_with_unit(name: str, path: str) -> str:
    text, unit = label(path, name), doc(path)[0]
    return f"{text} ({unit})" if unit else text
