#version 330 core
#pragma vertex_stage "vs/unwrap.vert"
// Stretch texture (seed 000 eq. 27, seed 002 §14.5): texture-space units per millimetre along u
// and v, so a blur tap spacing in UV = stretch * sigma_mm (eq. 25 with size * stretch in texels).
// dP/du and dP/dv from the screen derivatives of the world position and of the UV (solving the
// 2x2 Jacobian, so it does not assume the unwrap's one-texel-per-pixel mapping). B: the shear,
// cos(angle between dP/du and dP/dv), for the blur's shear-corrected second pass (deon_blur.frag).
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
uniform float u_mm_per_unit;
const float MAX_UV_PER_MM = 10.0;   // tiny/zero world area: 1 mm spans 10 textures (blur ~ off)
const float MIN_UV_PER_MM = 1e-7;   // huge world area per texel: taps collapse to the centre
const float MAX_SHEAR_COS = 0.95;   // degenerate (sliver) texels: the shear correction stays finite
out vec4 f_stretch;
float per_mm(vec3 dp) {
    float l = length(dp) * u_mm_per_unit;      // mm per UV unit
    if (isnan(l) || isinf(l)) return MIN_UV_PER_MM;
    if (!(l > 1.0 / MAX_UV_PER_MM)) return MAX_UV_PER_MM;
    return clamp(1.0 / l, MIN_UV_PER_MM, MAX_UV_PER_MM);
}
void main() {
    vec3 px = dFdx(v_position), py = dFdy(v_position);
    vec2 tx = dFdx(v_uv), ty = dFdy(v_uv);
    float det = tx.x * ty.y - ty.x * tx.y;
    vec2 s = vec2(MAX_UV_PER_MM);
    float c = 0.0;  // B: cos of the angle between dP/du and dP/dv (shear; issue 10 item 2)
    if (abs(det) > 1e-20 && !isnan(det) && !isinf(det)) {
        vec3 pu = (px * ty.y - py * tx.y) / det;
        vec3 pv = (py * tx.x - px * ty.x) / det;
        s = vec2(per_mm(pu), per_mm(pv));
        float l = length(pu) * length(pv);
        c = (l > 0.0 && !isinf(l)) ? clamp(dot(pu, pv) / l, -MAX_SHEAR_COS, MAX_SHEAR_COS) : 0.0;
        if (isnan(c)) c = 0.0;
    }
    f_stretch = vec4(s, c, 1.0);
}
