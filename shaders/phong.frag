#version 330 core
#pragma vertex_stage "vs/camera.vert"
#include "lib/color.glsl"
#include "lib/lights.glsl"
#include "lib/surface.glsl"
#include "lib/environment.glsl"
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
uniform vec3 u_eye;
uniform float u_ambient;
uniform float u_specular;
uniform float u_shininess;
out vec4 f_color;
void main() {
    set_light_footprint(dFdx(v_position), dFdy(v_position));  // beam lights: area coverage
    vec3 N = surface_normal(v_normal, v_tangent, v_uv);
    vec3 V = normalize(u_eye - v_position);
    if (!gl_FrontFacing) N = -N;  // the back of an open sheet (scene.back_faces: show)
    vec3 C = texture(albedo_map, v_uv).rgb;
    vec3 color = u_ambient * C;
    for (int i = 0; i < N_LIGHTS; ++i) {
        vec3 L;
        vec3 Lc = light_incident(i, v_position, L);
        float ndl = max(dot(N, L), 0.0);
        if (ndl <= 0.0) continue;
        float s = shadow_factor(i, v_position, normalize(v_normal));
        vec3 H = normalize(L + V);
        float spec = u_specular * pow(max(dot(N, H), 0.0), u_shininess);
        color += Lc * s * (C * ndl + spec * ndl);
    }
#if ENV_LIGHT
    ENV_VIS_IN();
    color += C * env_irradiance(N, v_normal) + env_phong_specular(N, V, u_shininess, u_specular);
#endif
    f_color = vec4(finite3(color), 1.0);
}
