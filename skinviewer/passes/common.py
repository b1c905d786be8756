"""Helpers shared by passes: light uniforms, shadow-map inputs, drawing the mesh or a full-screen
triangle, binding textures."""
from __future__ import annotations

from types import SimpleNamespace

import moderngl
import numpy as np

from skinviewer.core.graph import Reflection, TexSpec
from skinviewer.core.settings import REGIONS
from skinviewer.passes.luts import BECKMANN_LUT
from skinviewer.scene.camera import gl_bytes, light_space

MAX_LIGHTS = 4
_KIND = {"directional": 0, "point": 1, "beam": 2}
LIGHT_POSE_FIELDS = ("kind", "direction", "position", "beam_radius", "cast_shadow", "enabled")


def shadow_resource(i: int) -> str:
    return f"shadow_map_{i}"


def active_lights(settings) -> list[tuple[int, object]]:
    return [(i, l) for i, l in enumerate(settings.lights[:MAX_LIGHTS]) if l.enabled]


def declare_lighting(r: Reflection) -> list[tuple[int, object]]:
    """Declare what a lit pass reads: every light, the shadow test settings, and the shadow maps
    of shadow-casting lights. Returns the enabled lights."""
    lights = r.setting("lights")
    r.setting("shadow.tol")
    r.setting("shadow.pcf")
    r.setting("shadow.map_size")
    active = [(i, l) for i, l in enumerate(lights[:MAX_LIGHTS]) if l.enabled]
    for i, l in active:
        if l.cast_shadow:
            r.input(shadow_resource(i))
    return active


def set_lighting(ec, prog, first_unit: int) -> int:
    """Set the uniforms of shaders/lib/lights.glsl; returns the next free texture unit."""
    scene = ec.scene
    lights = ec.setting("lights")
    active = [(i, l) for i, l in enumerate(lights[:MAX_LIGHTS]) if l.enabled]
    n = len(active)
    kinds, radiance, dirs, poss, radii, shadowed, mats, texels = [], [], [], [], [], [], [], []
    map_size = ec.setting("shadow.map_size")
    unit = first_unit
    for slot, (i, l) in enumerate(active):
        ls = light_space(l, scene.center, scene.radius)
        d = np.asarray(l.direction, dtype=np.float64)
        d = d / np.linalg.norm(d)
        kinds.append(_KIND[l.kind])
        radiance.extend(np.asarray(l.color) * l.intensity)
        dirs.extend(d)
        poss.extend(l.position)
        radii.append(l.beam_radius)
        shadowed.append(1 if l.cast_shadow else 0)
        mats.append(ls.gl_matrix)
        texels.append(ls.texel_world(map_size))
        if l.cast_shadow:
            ec.input(shadow_resource(i)).use(unit)
            _set(prog, f"shadow_map{slot}", unit)
            unit += 1
    pad = MAX_LIGHTS - n
    _set(prog, "u_light_count", n)
    _set_array(prog, "u_light_kind", kinds + [0] * pad)
    _set_array(prog, "u_light_radiance", list(radiance) + [0.0] * 3 * pad)
    _set_array(prog, "u_light_dir", list(dirs) + [0.0, 0.0, 1.0] * pad)
    _set_array(prog, "u_light_pos", list(poss) + [0.0] * 3 * pad)
    _set_array(prog, "u_beam_radius", radii + [1.0] * pad)
    _set_array(prog, "u_light_shadowed", shadowed + [0] * pad)
    _set_array(prog, "u_shadow_texel", texels + [0.0] * pad)
    if "u_light_matrix" in prog:
        m = np.zeros((MAX_LIGHTS, 4, 4), dtype=np.float32)
        for k, mat in enumerate(mats):
            m[k] = mat.T  # column-major
        prog["u_light_matrix"].write(m.tobytes())
    _set(prog, "u_shadow_tol", ec.setting("shadow.tol"))
    _set(prog, "u_shadow_pcf", ec.setting("shadow.pcf"))
    # unused shadow samplers must not alias a float texture of another kind: point them at a unit
    # that holds no texture the shader reads as a shadow map
    for slot in range(MAX_LIGHTS):
        if slot >= n or not active[slot][1].cast_shadow:
            _set(prog, f"shadow_map{slot}", unit)
    return unit + 1


def _set(prog, name, value):
    if name in prog:
        prog[name].value = value


def _set_array(prog, name, values):
    if name in prog:
        u = prog[name]
        fmt = "i" if u.fmt.endswith("i") else "f"
        prog[name].write(np.asarray(values, dtype=np.int32 if fmt == "i" else np.float32).tobytes())


def set_uniform(prog, name, value):
    """Set a uniform if the compiled program still has it (the GLSL compiler drops unused ones)."""
    _set(prog, name, value)


def bind_surface(ec, prog, first_unit: int) -> int:
    """Bind albedo and normal maps (shaders/lib/surface.glsl); returns the next free unit."""
    scene = ec.scene
    scene.albedo.use(first_unit)
    _set(prog, "albedo_map", first_unit)
    scene.normal_map.use(first_unit + 1)
    _set(prog, "normal_map", first_unit + 1)
    _set(prog, "u_has_normal_map", 1 if scene.has_normal_map else 0)
    return first_unit + 2


def draw_fullscreen(ec, prog) -> None:
    ec.graph.fullscreen_vao(prog).render(vertices=3)


LIT = "lit"  # every technique's linear image, read by the output pass


def declare_lit(r: Reflection, program: str) -> None:
    """A view-dependent final pass: its program and the render-size linear image it writes."""
    w, h = r.setting("render.width"), r.setting("render.height")
    r.program(program)
    r.output(LIT, TexSpec((w, h), 4, "f2", depth=True))


def set_camera(ec, prog) -> None:
    """The camera uniforms of a mesh pass drawn from the view (u_view_proj, u_eye)."""
    view = ec.view
    prog["u_view_proj"].write(gl_bytes(view.view_proj))
    _set(prog, "u_eye", tuple(float(x) for x in view.eye))


def draw_mesh(ec, prog, resource: str, clear=(0.0, 0.0, 0.0, 0.0)) -> None:
    """Rasterise the mesh into ``resource`` (with its depth buffer), both faces, after a clear."""
    fbo = ec.framebuffer(resource)
    fbo.use()
    fbo.clear(*clear, depth=1.0)
    ec.gl.enable(moderngl.DEPTH_TEST)
    ec.gl.disable(moderngl.CULL_FACE)
    ec.scene.vao(prog).render()
    ec.gl.disable(moderngl.DEPTH_TEST)


def per_region_specular(sp) -> tuple[np.ndarray, np.ndarray]:
    """(m, rho_s) float32 arrays indexed by region ID: ``specular.per_region`` overrides (None
    fields keep the global value)."""
    m = np.full(len(REGIONS), sp.m, np.float32)
    rho = np.full(len(REGIONS), sp.rho_s, np.float32)
    for name, rs in sp.per_region.items():
        k = REGIONS.index(name)
        if rs.m is not None:
            m[k] = rs.m
        if rs.rho_s is not None:
            rho[k] = rs.rho_s
    return m, rho


SPECULAR_FIELDS = ("m", "rho_s", "f0", "per_region")


def declare_specular(r: Reflection, lut: bool = True) -> None:
    """Declare what shaders/lib/specular_params.glsl reads; the Beckmann LUT only in its mode."""
    for f in SPECULAR_FIELDS:
        r.setting(f"specular.{f}")
    if lut and r.setting("specular.mode") == "beckmann_lut":
        r.input(BECKMANN_LUT)


def bind_specular(ec, prog, unit: int, spare_unit: int) -> int:
    """Set the uniforms of shaders/lib/specular_params.glsl; returns the next free unit.
    ``spare_unit`` backs samplers the current mode does not read."""
    scene = ec.scene
    m, rho = per_region_specular(SimpleNamespace(**{f: ec.setting(f"specular.{f}") for f in SPECULAR_FIELDS}))
    _set_array(prog, "u_spec_m", m)
    _set_array(prog, "u_spec_rho_s", rho)
    _set(prog, "u_spec_rho_s_table", float(ec.setting("specular.rho_s")))
    _set(prog, "u_f0", float(ec.setting("specular.f0")))
    scene.region_map.use(unit)
    _set(prog, "region_map", unit)
    scene.specular_map.use(unit + 1)
    _set(prog, "specular_map", unit + 1)
    unit += 2
    _set(prog, "u_spec_lut", 1 if ec.has_input(BECKMANN_LUT) else 0)
    return bind_optional(ec, prog, BECKMANN_LUT, "beckmann_tex", unit, spare_unit)


def bind_optional(ec, prog, resource: str, sampler: str, unit: int, spare_unit: int) -> int:
    """Bind ``resource`` to ``sampler`` when this frame declared it, else point the sampler at a
    spare unit (it is not read); returns the next free unit."""
    if ec.has_input(resource):
        ec.input(resource).use(unit)
        _set(prog, sampler, unit)
        return unit + 1
    _set(prog, sampler, spare_unit)
    return unit
