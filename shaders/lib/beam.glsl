// Beam light over a texel's (or pixel's) footprint (issue 10 item 5). A point sample at the texel
// centre misses a beam narrower than a texel (zero power) or over-counts it (a lit texel carries
// its whole area); the exact average irradiance over the footprint is Lc (N.L) A_in / A_fp, with
// A_fp the footprint projected on the plane across the beam and A_in the part of it inside the
// beam's disk, so that sum_texels E * texel_area = pi r^2 Lc wherever the beam falls.
#ifndef SKINVIEWER_BEAM_GLSL
#define SKINVIEWER_BEAM_GLSL
vec3 g_footprint_dx = vec3(0.0);  // world position change per texel/pixel step (dFdx, dFdy)
vec3 g_footprint_dy = vec3(0.0);

// Call at the top of main() (uniform control flow) with dFdx/dFdy of the world position.
void set_light_footprint(vec3 dx, vec3 dy) {
    bool ok = !(any(isnan(dx)) || any(isinf(dx)) || any(isnan(dy)) || any(isinf(dy)));
    g_footprint_dx = ok ? dx : vec3(0.0);
    g_footprint_dy = ok ? dy : vec3(0.0);
}

float beam_cross(vec2 a, vec2 b) { return a.x * b.y - a.y * b.x; }
float beam_angle(vec2 a, vec2 b) {  // signed angle from a to b (0 for a degenerate pair)
    float c = beam_cross(a, b), d = dot(a, b);
    return (abs(c) + abs(d) > 0.0) ? atan(c, d) : 0.0;
}
// Signed area of the unit disk (radius 1, centre 0) intersected with the triangle (0, p, q).
float beam_disk_tri(vec2 p, vec2 q) {
    // a vertex at the disk's centre (a footprint corner on the beam's axis) makes the triangle
    // degenerate: area 0. Without this, the angle between two ~1e-7 vectors (the corner and its
    // rounded chord point) came out as +-pi on NVIDIA: a quarter disk too much (issue 31)
    if ((isnan(dot(p, p)) || dot(p, p) <= 1e-12) || (isnan(dot(q, q)) || dot(q, q) <= 1e-12)) return 0.0;
    vec2 d = q - p;
    float dd = dot(d, d);
    if ((isnan(dd) || dd <= 1e-24)) return 0.0;
    float a = dot(d, p) / dd, b = (dot(p, p) - 1.0) / dd;
    float det = a * a - b;
    if (det <= 0.0) return 0.5 * beam_angle(p, q);
    float sq = sqrt(det);
    float s = max(0.0, -a - sq), t = min(1.0, -a + sq);
    if (t < 0.0 || 1.0 <= s) return 0.5 * beam_angle(p, q);
    // the chord's ends; an end that is the vertex itself is taken exactly (p + d * 1 is not q in
    // float: the angle between q and its rounded copy is noise when q lies near the centre)
    vec2 u = (s <= 0.0) ? p : p + d * s, v = (t >= 1.0) ? q : p + d * t;
    return 0.5 * beam_angle(p, u) + 0.5 * beam_cross(u, v) + 0.5 * beam_angle(v, q);
}

// Fraction of the footprint around P that the beam (axis through O along L, radius r) covers.
// Without a footprint (zero derivatives) it falls back to the point test.
float beam_coverage(vec3 P, vec3 O, vec3 L, float r) {
    vec3 e1 = normalize(abs(L.x) < 0.9 ? cross(L, vec3(1.0, 0.0, 0.0)) : cross(L, vec3(0.0, 1.0, 0.0)));
    vec3 e2 = cross(L, e1);
    vec3 rel = P - O;
    vec2 c = vec2(dot(rel, e1), dot(rel, e2)) / r;  // in beam radii
    vec2 a = vec2(dot(g_footprint_dx, e1), dot(g_footprint_dx, e2)) / r;
    vec2 b = vec2(dot(g_footprint_dy, e1), dot(g_footprint_dy, e2)) / r;
    float area = abs(beam_cross(a, b));
    if ((isnan(area) || area <= 1e-12) || (isnan(r) || r <= 0.0)) return length(c) <= 1.0 ? 1.0 : 0.0;
    float reach = 0.5 * (length(a) + length(b));  // circumradius of the footprint
    float dc = length(c);
    if (dc >= 1.0 + reach) return 0.0;
    if (dc + reach <= 1.0) return 1.0;
    vec2 p0 = c - 0.5 * a - 0.5 * b, p1 = c + 0.5 * a - 0.5 * b;
    vec2 p2 = c + 0.5 * a + 0.5 * b, p3 = c - 0.5 * a + 0.5 * b;
    float inside = beam_disk_tri(p0, p1) + beam_disk_tri(p1, p2) + beam_disk_tri(p2, p3) + beam_disk_tri(p3, p0);
    return clamp(abs(inside) / area, 0.0, 1.0);  // clamp: rounding only (inside <= area exactly)
}
#endif
