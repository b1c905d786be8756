"""Declarations shared by passes: lights and shadow maps (shaders/lib/lights.glsl), surface maps
(lib/surface.glsl), the Kelemen/Szirmay-Kalos parameters (lib/specular_params.glsl), the camera of
the final passes and the lit image they write. GL work goes through the ExecuteContext services."""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from skinviewer.ground.constants import LIGHT_KINDS, MAX_LIGHTS
from skinviewer.kernel.pass_api import Reflection, TexSpec, declare, whole
from skinviewer.passes.luts import BECKMANN_LUT
from skinviewer.passes.rules import analytic_on, light_off_reason, shadow_map_size
from skinviewer.physics.specular import per_region_specular
from skinviewer.scene.camera import gl_bytes
from skinviewer.scene.mesh import culls_back_faces


def declare_pose(light: Any) -> Any:
    """Declare a light's pose (what its shadow map and light space depend on: not its colour) read
    through ``r.settings.lights[i]``; returns the light for ``GpuScene.light_space``."""
    declare(light.kind, light.direction, light.position, light.beam_radius, light.cast_shadow, light.enabled)
    return light


def shadow_resource(i: int) -> str:
    return f"shadow_map_{i}"


def shadow_bounds_resource(i: int) -> str:
    """Light i's shadow-map bounds (passes.shadow_map.ShadowBoundsPass, lib/lights.glsl SHADOW_BOUNDS)."""
    return f"shadow_bounds_{i}"


# issue 27: the specialised PCF can decide a lookup whose every tap is lit (or shadowed) from the shadow
# map's per-block bounds, without its taps (lib/lights.glsl SHADOW_BOUNDS; bit-identical). Off: on
# llvmpipe it decides ~70 % of the lookups but saves ~7 % of d'Eon's irradiance light pass, about what
# the bounds pass costs (notes/deon_light_move.md section 13). SKINVIEWER_PCF_BOUNDS=1 in the
# environment turns it on (for a GPU, whose branches skip what its lanes all skip; an A/B)
PCF_BOUNDS = os.environ.get("SKINVIEWER_PCF_BOUNDS", "0") == "1"
SHADOW_BOUNDS_BLOCK = 8  # shadow-map texels per block side (a 1024^2 map: a 128^2 bounds map)
PCF_BOUNDS_MARK = False  # benchmarks and tests: a decided lookup returns -1 (lit) or -2 (shadowed), not 1 or 0


def declare_lighting(r: Reflection, shadow_maps: bool = True) -> dict[str, Any]:
    """Declare what a lit pass reads: every light, the shadow test settings, and the shadow maps
    of shadow-casting lights (not with ``shadow_maps=False``: a pass that reads the shadow test's
    result from elsewhere). Returns the defines that specialise shaders/lib/lights.glsl to this
    frame's lights (declare the lit program with them: ``r.program(name, **defines)``). Plans
    ``light_slots`` (the settings index of each slot's light) and ``shadow_map_size`` for set_lighting."""
    lights = whole(r.settings.lights)
    declare(r.settings.shadow.tol)
    pcf = r.settings.shadow.pcf
    bilinear = r.settings.shadow.pcf_filter == "bilinear"
    active = [(i, l) for i, l in enumerate(lights[:MAX_LIGHTS]) if analytic_on(l)]
    r.plan(light_slots=tuple(i for i, _ in active), shadow_map_size=shadow_map_size(r))
    for i, l in enumerate(lights[:MAX_LIGHTS]):
        if not analytic_on(l) and l.cast_shadow:
            r.drop(shadow_resource(i), light_off_reason(i, l))
    mask = 0
    bounds = shadow_maps and PCF_BOUNDS and pcf >= 1  # one tap at pcf 0: nothing to skip
    for slot, (i, l) in enumerate(active):
        if l.cast_shadow:
            if shadow_maps:
                r.input(shadow_resource(i))
                if bounds:
                    r.input(shadow_bounds_resource(i))
            mask |= 1 << slot
    r.plan(shadow_bounds=bool(bounds and mask))
    kinds = {k: sum(1 << slot for slot, (_, l) in enumerate(active) if l.kind == k) for k in ("point", "beam")}
    out = {"LIGHT_COUNT": len(active), "SHADOW_PCF": int(pcf), "SHADOW_BILINEAR": int(bilinear), "SHADOW_MASK": mask,
           "POINT_MASK": kinds["point"], "BEAM_MASK": kinds["beam"]}
    if bounds and mask:
        out.update(SHADOW_BOUNDS=1, SHADOW_BOUNDS_BLOCK=SHADOW_BOUNDS_BLOCK)
        if PCF_BOUNDS_MARK:
            out.update(SHADOW_BOUNDS_MARK=1)
    return out


def set_lighting(ec, prog, shadow_maps: bool = True) -> None:
    """Set the uniforms and shadow maps of shaders/lib/lights.glsl (slot k = k-th enabled light);
    ``shadow_maps=False``: the uniforms only (see declare_lighting, which planned the slots and map size)."""
    scene = ec.scene
    lights = whole(ec.settings.lights)
    active = [(i, lights[i]) for i in ec.plan.light_slots]
    map_size = ec.plan.shadow_map_size
    kind = np.zeros(MAX_LIGHTS, np.int32)
    radiance = np.zeros((MAX_LIGHTS, 3), np.float32)
    dirs = np.tile(np.array([0.0, 0.0, 1.0], np.float32), (MAX_LIGHTS, 1))
    poss = np.zeros((MAX_LIGHTS, 3), np.float32)
    radii = np.ones(MAX_LIGHTS, np.float32)
    shadowed = np.zeros(MAX_LIGHTS, np.int32)
    mats = np.zeros((MAX_LIGHTS, 4, 4), np.float32)
    texels = np.zeros(MAX_LIGHTS, np.float32)
    for slot, (i, l) in enumerate(active):
        ls = scene.light_space(l)
        d = np.asarray(l.direction, dtype=np.float64)
        kind[slot] = LIGHT_KINDS[l.kind]
        radiance[slot] = np.asarray(l.color) * l.intensity
        dirs[slot] = d / np.linalg.norm(d)
        poss[slot] = l.position
        radii[slot] = l.beam_radius
        shadowed[slot] = 1 if l.cast_shadow else 0
        mats[slot] = ls.gl_matrix.T  # column-major
        texels[slot] = ls.texel_world(map_size)
        if l.cast_shadow and shadow_maps:
            ec.bind(prog, f"shadow_map{slot}", shadow_resource(i))
            if ec.plan.shadow_bounds:  # SHADOW_BOUNDS: generic shaders compile it out
                ec.bind(prog, f"shadow_bounds{slot}", shadow_bounds_resource(i), optional=True)
    ec.uniforms(prog, u_light_count=len(active), u_light_kind=kind, u_light_radiance=radiance,
                u_light_dir=dirs, u_light_pos=poss, u_beam_radius=radii, u_light_shadowed=shadowed,
                u_light_matrix=mats, u_shadow_texel=texels,
                u_shadow_tol=ec.settings.shadow.tol, u_shadow_pcf=ec.settings.shadow.pcf,
                u_shadow_bilinear=ec.settings.shadow.pcf_filter == "bilinear")


def bind_surface(ec, prog) -> None:
    """Bind albedo and normal maps (shaders/lib/surface.glsl)."""
    scene = ec.scene
    ec.textures(prog, albedo_map=scene.albedo, normal_map=scene.normal_map)
    ec.set(prog, "u_has_normal_map", scene.has_normal_map)


LIT = "lit"  # every technique's linear image, read by the output pass


def declare_lit(r: Reflection, program: str, **defines) -> None:
    """A view-dependent final pass: its program (with ``defines``) and the render-size linear image
    it writes."""
    w, h = r.settings.render.width, r.settings.render.height
    r.program(program, **defines)
    r.output(LIT, TexSpec((w, h), 4, "f2", depth=True))


def declare_view_mesh(r: Reflection) -> None:
    """A pass that draws the mesh from the camera (draw_view_mesh): it reads ``scene.back_faces``."""
    declare(r.settings.scene.back_faces)


def draw_view_mesh(ec, prog, *targets) -> None:
    """Draw the mesh from the camera into ``targets``: back faces culled when ``scene.back_faces``
    resolves to cull for this mesh (auto: a closed mesh), else both sides (the shaders reverse the
    normal of a back face: gl_FrontFacing)."""
    cull = culls_back_faces(ec.settings.scene.back_faces, ec.scene.closed)
    with ec.band():  # a tileable pass (issue 27): this band's rows (depth cleared and tested per band)
        ec.draw_mesh(prog, *targets, cull_back=cull, space="camera")


def set_camera(ec, prog) -> None:
    """The camera uniforms of a mesh pass drawn from the view (u_view_proj, u_eye)."""
    view = ec.view
    ec.set(prog, "u_view_proj", gl_bytes(view.view_proj))
    ec.set(prog, "u_eye", tuple(float(x) for x in view.eye))


def declare_specular(r: Reflection, lut: bool = True) -> None:
    """Declare what shaders/lib/specular_params.glsl reads; the Beckmann LUT only in its mode."""
    sp = r.settings.specular
    declare(sp.m, sp.rho_s, sp.f0, sp.per_region)
    if lut and r.settings.specular.mode == "beckmann_lut":
        r.input(BECKMANN_LUT)


def bind_specular(ec, prog) -> None:
    """Set the uniforms and maps of shaders/lib/specular_params.glsl."""
    scene = ec.scene
    sp = ec.settings.specular
    m, rho = per_region_specular(sp)
    ec.uniforms(prog, u_spec_m=m, u_spec_rho_s=rho, u_spec_rho_s_table=float(sp.rho_s), u_f0=float(sp.f0),
                u_spec_lut=ec.has_input(BECKMANN_LUT))
    ec.textures(prog, region_map=scene.region_map, specular_map=scene.specular_map)
    if ec.has_input(BECKMANN_LUT):
        ec.bind(prog, "beckmann_tex", BECKMANN_LUT)
