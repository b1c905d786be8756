"""lib/beam.glsl on degenerate footprints (issue 31): a beam centred on the shared corner of four
pixels or texels — the laser scene's beam sits exactly on the image's and the irradiance map's
centre lines — must give the four footprints the disk's area between them, whatever the rounding
of the corner. NVIDIA's compiler rounds the chord points differently from llvmpipe: an angle taken
between two vectors of length ~1e-7 came out as +-pi there, and the laser carried 10-20 % too much
power (d'Eon's texel path, ssss's pixels)."""
from __future__ import annotations

import math

import moderngl
import numpy as np

from skinviewer.ground.paths import shaders_dir

FRAG = """#version 330 core
#include_beam
uniform sampler2D t_in;   // rows: c.xy (footprint centre, beam radii), half side s
out vec4 o;
void main() {
    vec4 q = texelFetch(t_in, ivec2(gl_FragCoord.xy), 0);
    g_footprint_dx = vec3(2.0 * q.z, 0.0, 0.0);
    g_footprint_dy = vec3(0.0, 2.0 * q.z, 0.0);
    float cov = beam_coverage(vec3(q.xy, 0.0), vec3(0.0), vec3(0.0, 0.0, 1.0), 1.0);
    o = vec4(cov * 4.0 * q.z * q.z, 0.0, 0.0, 1.0);  // the area of the footprint inside the disk
}
"""
VERT = """#version 330 core
void main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2); gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }
"""


def _inside_area(ctx, rows: np.ndarray) -> np.ndarray:
    src = FRAG.replace("#include_beam", (shaders_dir() / "lib" / "beam.glsl").read_text())
    prog = ctx.program(vertex_shader=VERT, fragment_shader=src)
    w = len(rows)
    data = np.zeros((w, 4), np.float32)
    data[:, :3] = rows
    tin = ctx.texture((w, 1), 4, data.tobytes(), dtype="f4")
    tin.filter = (moderngl.NEAREST, moderngl.NEAREST)
    out = ctx.texture((w, 1), 4, dtype="f4")
    fbo = ctx.framebuffer([out])
    fbo.use()
    fbo.viewport = (0, 0, w, 1)
    tin.use(0)
    prog["t_in"].value = 0
    vao = ctx.vertex_array(prog, [])
    vao.render(moderngl.TRIANGLES, vertices=3)
    res = np.frombuffer(out.read(), np.float32).reshape(-1, 4)[:, 0].astype(np.float64)
    for o in (vao, fbo, out, tin, prog):
        o.release()
    return res


def test_four_footprints_around_the_beam_share_its_disk(gl_ctx):
    s = 3.0  # half side: footprints 6 beam radii wide, as the laser's pixels and texels are
    rows = []
    eps = [0.0, 1e-7, -1e-7, 3e-8, -2.5e-7, 1e-6, 1e-5, -3e-5, 1e-4]  # NVIDIA's rounding reached ~1e-5
    for ex in eps:
        for ey in eps:
            for sx in (-1, 1):
                for sy in (-1, 1):  # the four footprints sharing the corner (ex, ey)
                    rows.append((ex + sx * s, ey + sy * s, s))
    area = _inside_area(gl_ctx, np.array(rows)).reshape(len(eps) * len(eps), 4)
    np.testing.assert_allclose(area.sum(axis=1), math.pi, rtol=1e-4)
    # each footprint holds a quarter of the disk (the corner within 1e-6 radii of the centre)
    np.testing.assert_allclose(area, math.pi / 4, rtol=2e-3)
