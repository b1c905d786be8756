"""Shadow map per light (seed 000 §4.1.1, eq. 1-6): light-space z/w of the nearest surface."""
from __future__ import annotations

from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, whole
from skinviewer.passes.common import SHADOW_BOUNDS_BLOCK, declare_pose, shadow_bounds_resource, shadow_resource
from skinviewer.passes.rules import analytic_on, light_off_reason, shadow_map_size
from skinviewer.scene.camera import gl_bytes


class ShadowMapPass(Pass):
    """Re-runs on the mesh, this light's pose and the map size only (not its colour)."""

    # one mesh draw, but 20-70 ms at 1024² on llvmpipe (the first pass of every light-move frame):
    # in row bands of the map under the viewer's frame budget (issue 27), each band drawing only the
    # triangles that reach its rows in light space; bit-identical to the whole draw
    tileable = True

    def __init__(self, light_index: int):
        self.light_index = light_index
        self.name = f"shadow_map_{light_index}"

    def reflect(self, r: Reflection) -> None:
        i = self.light_index
        if len(r.peeked.lights) <= i or not r.peeked.lights[i].enabled:
            return
        if not analytic_on(whole(r.peeked.lights[i])):  # peeked: the map does not depend on the colour
            r.skip(light_off_reason(i, whole(r.peeked.lights[i])))
            return
        declare_pose(r.settings.lights[i])
        size = shadow_map_size(r)
        r.program("shadow_map")
        r.plan(map=shadow_resource(i))
        r.output(r.planned.map, TexSpec((size, size), 1, "f4", filter="nearest", depth=True))

    def execute(self, ec) -> None:
        i = self.light_index
        scene = ec.scene
        ls = scene.light_space(ec.settings.lights[i])
        prog = ec.program("shadow_map")
        ec.set(prog, "u_light_matrix", gl_bytes(ls.gl_matrix))
        with ec.band():
            ec.draw_mesh(prog, ec.plan.map, clear=(1.0, 1.0, 1.0, 1.0), space="light", matrix=ls.gl_matrix)


class ShadowBoundsPass(Pass):
    """Light i's shadow map bounded per block (shaders/shadow_bounds.frag, issue 27): a plane under every
    depth a PCF lookup from the block reads and the span above it, so the specialised shadow test
    (lib/lights.glsl SHADOW_BOUNDS) decides a lookup whose every tap is lit or shadowed without its
    taps, bit for bit. Re-runs with its shadow map (the light's pose, the mesh, the map size) and
    shadow.pcf (the window's margin); a camera move or a light's colour keeps it."""

    def __init__(self, light_index: int):
        self.light_index = light_index
        self.name = f"shadow_bounds_{light_index}"

    def reflect(self, r: Reflection) -> None:
        i = self.light_index
        if len(r.peeked.lights) <= i or not r.peeked.lights[i].enabled:
            return
        if not analytic_on(whole(r.peeked.lights[i])):
            r.skip(light_off_reason(i, whole(r.peeked.lights[i])))
            return
        size = shadow_map_size(r)
        nb = -(-size // SHADOW_BOUNDS_BLOCK)
        depth, bounds = shadow_resource(i), shadow_bounds_resource(i)
        r.input(depth)
        r.program("shadow_bounds", SHADOW_BOUNDS_BLOCK=SHADOW_BOUNDS_BLOCK)
        # margin: every texel a lookup from the block reads, +1
        r.plan(margin=int(r.settings.shadow.pcf) + 2, depth=depth, bounds=bounds)
        r.output(bounds, TexSpec((nb, nb), 4, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        prog = ec.program("shadow_bounds")
        ec.bind(prog, "depth", ec.plan.depth)
        ec.set(prog, "u_margin", int(ec.plan.margin))
        ec.draw_fullscreen(prog, ec.plan.bounds)
