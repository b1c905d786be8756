"""Phong/Lambert baseline (shadow map -> lit image), linear space."""
from __future__ import annotations

from ..camera import gl_bytes
from ..graph import Pass, Reflection, TexSpec
from .common import bind_surface, declare_lighting, draw_mesh, set_lighting, set_uniform


class PhongPass(Pass):
    name = "phong"
    view_dependent = True

    def reflect(self, r: Reflection) -> None:
        declare_lighting(r)
        r.setting("phong")
        w, h = r.setting("render.width"), r.setting("render.height")
        r.program("phong")
        r.output("lit", TexSpec((w, h), 4, "f2", depth=True))

    def execute(self, ec) -> None:
        prog = ec.program("phong")
        view = ec.view
        prog["u_view_proj"].write(gl_bytes(view.view_proj))
        set_uniform(prog, "u_eye", tuple(view.eye))
        ph = ec.setting("phong")
        set_uniform(prog, "u_ambient", ph.ambient)
        set_uniform(prog, "u_specular", ph.specular)
        set_uniform(prog, "u_shininess", ph.shininess)
        unit = bind_surface(ec, prog, 0)
        set_lighting(ec, prog, unit)
        draw_mesh(ec, prog, "lit")
