#version 330 core
// Neighbourhood reuse of Burley samples (a variant beyond seed 001 ch. 4): every pixel rotated its disk by
// its own hash, so the (2R+1)^2 pixels around p hold independent estimates of nearly the same kernel
// (centres <= R px apart). Their weighted sums are pooled with a tent weight, only between SSS pixels of
// similar depth (|dz| < u_reuse_dz mm), and only where the kernel is wide enough (>= u_min_radius px) that
// the R-px shift is negligible; elsewhere the pixel keeps its own estimate.
uniform sampler2D partial;    // rgb: own estimate sum wE / sum w; a: alpha of the irradiance
uniform sampler2D wsum;       // rgb: own sum w; a: 1 where the pixel was blurred
uniform sampler2D lin_depth;
uniform float u_proj_scale;
uniform float u_filter_radius;
uniform float u_reuse_dz;
uniform float u_min_radius;
out vec4 f_color;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 own = texelFetch(partial, p, 0);
    vec4 ws = texelFetch(wsum, p, 0);
    f_color = own;
    if (ws.a < 0.5)
        return;

    float zc = texelFetch(lin_depth, p, 0).r;
    if (u_filter_radius * u_proj_scale / max(zc, 1e-6) < u_min_radius)
        return;
    ivec2 size = textureSize(partial, 0);
    vec3 acc = vec3(0.0);
    vec3 wt = vec3(0.0);
    for (int dy = -REUSE_R; dy <= REUSE_R; ++dy) {
        for (int dx = -REUSE_R; dx <= REUSE_R; ++dx) {
            ivec2 q = p + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)))
                continue;
            vec4 wq = texelFetch(wsum, q, 0);
            if (wq.a < 0.5 || abs(texelFetch(lin_depth, q, 0).r - zc) > u_reuse_dz)
                continue;
            float g = float((REUSE_R + 1 - abs(dx)) * (REUSE_R + 1 - abs(dy)));
            acc += g * wq.rgb * texelFetch(partial, q, 0).rgb;
            wt += g * wq.rgb;
        }
    }
    f_color = vec4(acc / max(wt, vec3(1.17549435e-38)), own.a);
}
