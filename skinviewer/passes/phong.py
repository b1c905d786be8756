"""Phong/Lambert baseline (shadow map -> lit image), linear space."""
from __future__ import annotations

from skinviewer.kernel.pass_api import Pass, Reflection, declare
from skinviewer.passes.common import (
    LIT,
    bind_surface,
    declare_lighting,
    declare_lit,
    declare_view_mesh,
    draw_view_mesh,
    set_camera,
    set_lighting,
)
from skinviewer.passes.environment import declare_environment, set_environment


class PhongPass(Pass):
    name = "phong"
    view_dependent = True
    tileable = True  # one view-mesh draw: in row bands under the viewer's frame budget (issue 27)

    def reflect(self, r: Reflection) -> None:
        lighting = declare_lighting(r)
        ph = r.settings.phong
        declare(ph.ambient, ph.specular, ph.shininess)
        declare_lit(r, "phong", **lighting, **declare_environment(r))
        declare_view_mesh(r)

    def execute(self, ec) -> None:
        prog = ec.program("phong")
        set_camera(ec, prog)
        ph = ec.settings.phong
        ec.uniforms(prog, u_ambient=ph.ambient, u_specular=ph.specular, u_shininess=ph.shininess)
        bind_surface(ec, prog)
        set_lighting(ec, prog)
        set_environment(ec, prog)
        draw_view_mesh(ec, prog, LIT)
