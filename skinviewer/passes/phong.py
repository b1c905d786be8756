"""Phong/Lambert baseline (shadow map -> lit image), linear space."""
from __future__ import annotations

from skinviewer.core.graph import Pass, Reflection
from skinviewer.passes.common import (
    bind_surface,
    declare_lighting,
    declare_lit,
    draw_mesh,
    set_camera,
    set_lighting,
    set_uniform,
)


class PhongPass(Pass):
    name = "phong"
    view_dependent = True

    def reflect(self, r: Reflection) -> None:
        declare_lighting(r)
        r.setting("phong")
        declare_lit(r, "phong")

    def execute(self, ec) -> None:
        prog = ec.program("phong")
        set_camera(ec, prog)
        ph = ec.setting("phong")
        set_uniform(prog, "u_ambient", ph.ambient)
        set_uniform(prog, "u_specular", ph.specular)
        set_uniform(prog, "u_shininess", ph.shininess)
        unit = bind_surface(ec, prog, 0)
        set_lighting(ec, prog, unit)
        draw_mesh(ec, prog, "lit")
