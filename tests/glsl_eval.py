"""Evaluate a function of the real shader files on the GPU: a one-row render pass whose fragment shader
includes a file of ``shaders/`` (``paths.shaders_dir()``, so SKINVIEWER_SHADERS points it at a mutated
copy) and writes an expression of the input texel. Pins a GLSL formula against independent values
instead of a numpy re-typing of it."""
from __future__ import annotations

import tempfile
from pathlib import Path

import moderngl
import numpy as np

from skinviewer.ground import paths
from skinviewer.kernel.shaders import ShaderLibrary

_FRAG = """#version 330 core
#pragma vertex_stage "{root}/vs/fullscreen.vert"
uniform sampler2D u_in;
layout(location = 0) out vec4 o_out;
{preamble}
{includes}
void main() {{
    vec4 a = texelFetch(u_in, ivec2(gl_FragCoord.xy), 0);
    o_out = {expr};
}}
"""


def glsl_eval(ctx: moderngl.Context, include: str | list[str], expr: str, inputs, preamble: str = "",
              defines: dict | None = None) -> np.ndarray:
    """``expr`` (GLSL, a vec4 of the input texel ``a``) for each row of ``inputs`` (N, <=4), float32 on the
    GPU; ``include``: file(s) under shaders/ (e.g. "lib/burley.glsl"). Returns (N, 4) float64."""
    x = np.zeros((len(inputs), 4), np.float32)
    a = np.asarray(inputs, np.float32).reshape(len(inputs), -1)
    x[:, : a.shape[1]] = a
    root = paths.shaders_dir().resolve()
    incs = [include] if isinstance(include, str) else list(include)
    with tempfile.TemporaryDirectory() as d:
        Path(d, "eval.frag").write_text(_FRAG.format(
            root=root, preamble=preamble, expr=expr,
            includes="\n".join(f'#include "{root / i}"' for i in incs)))
        lib = ShaderLibrary(ctx, root=Path(d), include_roots=(root,))
        try:
            prog = lib.get("eval", defines)
            n = len(x)
            src = ctx.texture((n, 1), 4, x.tobytes(), dtype="f4")
            src.filter = (moderngl.NEAREST, moderngl.NEAREST)
            dst = ctx.texture((n, 1), 4, dtype="f4")
            fbo = ctx.framebuffer([dst])
            vao = ctx.vertex_array(prog, [])
            try:
                fbo.use()
                ctx.viewport = (0, 0, n, 1)
                src.use(0)
                if "u_in" in prog:
                    prog["u_in"].value = 0
                vao.render(moderngl.TRIANGLES, vertices=3)
                out = np.frombuffer(dst.read(), np.float32).reshape(n, 4).astype(np.float64)
            finally:
                vao.release()
                fbo.release()
                dst.release()
                src.release()
        finally:
            lib.release()
    return out
