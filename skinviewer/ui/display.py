"""Putting textures on the screen: the rendered image, any pass output (channel / exposure / float
aware) and the A/B split or difference view. One small full-screen program; letterboxed when the
texture's aspect differs from the viewport's."""
from __future__ import annotations

import moderngl

from skinviewer.core.gpu import write_uniform

CHANNELS = ("RGB", "R", "G", "B", "A")
# mode: 0 = show as-is (already display-encoded), 1 = inspect (exposure + sRGB encode + channel),
#       2 = A/B split at u_divider, 3 = |A-B| heat map
_VS = """
#version 330
uniform vec2 u_scale;
out vec2 v_uv;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    v_uv = p;
    gl_Position = vec4((p * 2.0 - 1.0) * u_scale, 0.0, 1.0);
}
"""
_FS = """
#version 330
uniform sampler2D u_tex;
uniform sampler2D u_tex_b;
uniform int u_mode;
uniform int u_channel;
uniform float u_exposure;
uniform float u_divider;
uniform float u_gain;
uniform int u_components;
in vec2 v_uv;
out vec4 frag;

vec3 srgb(vec3 c) {
    c = max(c, vec3(0.0));
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
vec3 heat(float t) {  // black -> blue -> red -> yellow -> white
    t = clamp(t, 0.0, 1.0);
    return clamp(vec3(3.0 * t - 1.0, 3.0 * t - 2.0, 0.0), 0.0, 1.0) + vec3(0.0, 0.0, clamp(3.0 * t, 0.0, 1.0) * (1.0 - clamp(3.0 * t - 1.5, 0.0, 1.0)));
}
void main() {
    vec4 a = texture(u_tex, v_uv);
    if (u_mode == 0) {
        frag = vec4(a.rgb, 1.0);
    } else if (u_mode == 1) {
        vec4 v = a;
        if (any(isnan(v)) || any(isinf(v))) { frag = vec4(1.0, 0.0, 1.0, 1.0); return; }
        vec3 c;
        if (u_channel == 0) c = (u_components == 1) ? vec3(v.r) : (u_components == 2 ? vec3(v.rg, 0.0) : v.rgb);
        else if (u_channel == 1) c = vec3(v.r);
        else if (u_channel == 2) c = vec3(v.g);
        else if (u_channel == 3) c = vec3(v.b);
        else c = vec3(v.a);
        frag = vec4(srgb(c * u_exposure), 1.0);
    } else if (u_mode == 2) {
        vec4 b = texture(u_tex_b, v_uv);
        vec3 c = v_uv.x < u_divider ? a.rgb : b.rgb;
        float px = abs(v_uv.x - u_divider) * float(textureSize(u_tex, 0).x);
        if (px < 1.0) c = vec3(1.0, 0.85, 0.2);
        frag = vec4(c, 1.0);
    } else {
        vec4 b = texture(u_tex_b, v_uv);
        float d = length(a.rgb - b.rgb);
        frag = vec4(heat(d * u_gain), 1.0);
    }
}
"""


class Display:
    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.prog = ctx.program(vertex_shader=_VS, fragment_shader=_FS)
        self.vao = ctx.vertex_array(self.prog, [])

    def _set(self, name, value):
        if name in self.prog:
            write_uniform(self.prog[name], value)

    def _draw(self, tex: moderngl.Texture, viewport: tuple[int, int, int, int], mode: int, letterbox: bool,
              tex_b: moderngl.Texture | None = None, **uniforms) -> None:
        ctx = self.ctx
        ctx.screen.use()
        ctx.viewport = viewport
        ctx.enable_only(moderngl.NOTHING)
        sx, sy = 1.0, 1.0
        if letterbox:
            vw, vh = viewport[2], viewport[3]
            ta, va = tex.size[0] / max(tex.size[1], 1), vw / max(vh, 1)
            if ta > va:
                sy = va / ta
            else:
                sx = ta / va
        self._set("u_scale", (sx, sy))
        self._set("u_mode", mode)
        tex.use(0)
        self._set("u_tex", 0)
        (tex_b or tex).use(1)
        self._set("u_tex_b", 1)
        for k, v in uniforms.items():
            self._set(k, v)
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def show(self, tex, viewport):
        self._draw(tex, viewport, 0, letterbox=True)

    def inspect(self, tex, viewport, channel: str = "RGB", exposure: float = 1.0, components: int = 4):
        self._draw(tex, viewport, 1, letterbox=True, u_channel=CHANNELS.index(channel),
                   u_exposure=float(exposure), u_components=int(components))

    def split(self, tex_a, tex_b, viewport, divider: float):
        self._draw(tex_a, viewport, 2, letterbox=True, tex_b=tex_b, u_divider=float(divider))

    def difference(self, tex_a, tex_b, viewport, gain: float):
        self._draw(tex_a, viewport, 3, letterbox=True, tex_b=tex_b, u_gain=float(gain))

    def release(self):
        self.vao.release()
        self.prog.release()
