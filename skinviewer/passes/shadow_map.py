"""Shadow map per light (seed 000 §4.1.1, eq. 1-6): light-space z/w of the nearest surface."""
from __future__ import annotations

from types import SimpleNamespace

from skinviewer.core.graph import Pass, Reflection, TexSpec
from skinviewer.passes.common import LIGHT_POSE_FIELDS, draw_mesh, shadow_resource
from skinviewer.scene.camera import gl_bytes, light_space


class ShadowMapPass(Pass):
    """Re-runs on the mesh, this light's pose and the map size only (not its colour)."""

    def __init__(self, light_index: int):
        self.light_index = light_index
        self.name = f"shadow_map_{light_index}"

    def reflect(self, r: Reflection) -> None:
        i = self.light_index
        if r.peek("lights.#") <= i or not r.peek(f"lights.{i}.enabled"):
            return
        for f in LIGHT_POSE_FIELDS:
            r.setting(f"lights.{i}.{f}")
        size = r.setting("shadow.map_size")
        r.program("shadow_map")
        r.output(shadow_resource(i), TexSpec((size, size), 1, "f4", filter="nearest", depth=True))

    def execute(self, ec) -> None:
        i = self.light_index
        scene = ec.scene
        pose = SimpleNamespace(**{f: ec.setting(f"lights.{i}.{f}") for f in LIGHT_POSE_FIELDS})
        ls = light_space(pose, scene.center, scene.radius)
        prog = ec.program("shadow_map")
        prog["u_light_matrix"].write(gl_bytes(ls.gl_matrix))
        draw_mesh(ec, prog, shadow_resource(i), clear=(1.0, 1.0, 1.0, 1.0))
