#version 330 core
#pragma vertex_stage "vs/unwrap_metric.vert"
// Stretch texture (seed 000 eq. 27, seed 002 §14.5): texture-space units per millimetre along u
// and v, so a blur tap spacing in UV = stretch * sigma_mm (eq. 25 with size * stretch in texels).
// dP/du and dP/dv from the screen derivatives of the world position and of the UV (solving the
// 2x2 Jacobian, so it does not assume the unwrap's one-texel-per-pixel mapping). B: the shear,
// cos(angle between dP/du and dP/dv), for the blur's shear-corrected second pass (deon_blur.frag).
// VERTEX_METRIC (scene.stretch_metric = "vertex"): the same three from the UV covariance S = G^-1
// interpolated from the vertices (issue 10 items 1-2), smooth across triangles; else per triangle.
in vec3 v_position;
in vec2 v_uv;
in vec3 v_uv_cov;   // (S_uu, S_uv, S_vv), UV^2 per mm^2
uniform float u_mm_per_unit;
const float MAX_UV_PER_MM = 10.0;   // tiny/zero world area: 1 mm spans 10 textures (blur ~ off)
const float MIN_UV_PER_MM = 1e-7;   // huge world area per texel: taps collapse to the centre
const float MAX_SHEAR_COS = 0.95;   // degenerate (sliver) texels: the shear correction stays finite
out vec4 f_stretch;
float per_mm(vec3 dp) {
    float l = length(dp) * u_mm_per_unit;      // mm per UV unit
    if (isnan(l) || isinf(l)) return MIN_UV_PER_MM;
    if (isnan(l) || l <= 1.0 / MAX_UV_PER_MM) return MAX_UV_PER_MM;
    return clamp(1.0 / l, MIN_UV_PER_MM, MAX_UV_PER_MM);
}
#ifdef VERTEX_METRIC
// G = S^-1 = [[S_vv, -S_uv], [-S_uv, S_uu]] / det S: s_u = 1/sqrt(G_uu), s_v = 1/sqrt(G_vv), c = G_uv/sqrt(G_uu G_vv)
void main() {
    vec3 S = v_uv_cov;
    float det = S.x * S.z - S.y * S.y;
    vec2 s = vec2(MAX_UV_PER_MM);
    float c = 0.0;
    if (det > 0.0 && S.x > 0.0 && S.z > 0.0 && !isinf(det)) {
        s = clamp(sqrt(vec2(det / S.z, det / S.x)), vec2(MIN_UV_PER_MM), vec2(MAX_UV_PER_MM));
        c = clamp(-S.y * inversesqrt(S.x * S.z), -MAX_SHEAR_COS, MAX_SHEAR_COS);
        if (isnan(s.x) || isnan(s.y)) s = vec2(MAX_UV_PER_MM);
        if (isnan(c)) c = 0.0;
    }
    f_stretch = vec4(s, c, 1.0);
}
#else
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
#endif
