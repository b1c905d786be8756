// Burley normalized-diffusion disk sampling in screen space: Golubev 2018 (Unity HDRP; seed 001 §3.4,
// eq. 3.9-3.13) and the thesis's contrast-driven multi-level sampling (seed 001 ch. 4, Algorithm 1, eq. 4.1).
// The numpy twin is skinviewer/physics/burley.py (tests compare them).
//
// Defines injected by the pass (skinviewer/passes/burley.py):
//   N_SET0 base samples; N_SET1, N_SET2 samples of the extra levels (0 = no such level);
//   SETk_X, SETk_RCP, SETk_COS, SETk_SIN: float[N_SETk](...) tables (x = r/d, 8 pi/(e^-x + e^-x/3),
//     cos/sin of the golden-angle direction);  N_INNER: base samples 0..N_INNER-1 form the inner ring;
//   CONTRAST_MINMAX 0: eq. 4.1 between ring means, 1: (max-min)/(max+min) over every sample so far;
//   BURLEY_BUDGET 1: HDRP's adaptive count n <= floor(area / 4 px) (runtime tables below the base count);
//   BURLEY_ALWAYS 1: take every level without a contrast test (the pooled Golubev estimator).
// The includer defines  bool burley_fetch(ivec2 q, out vec3 E, out float z)  (false: not an SSS sample).
// Without the pass's defines (a plain compile check) it builds a one-sample Golubev set.
#ifndef SKINVIEWER_BURLEY_GLSL
#define SKINVIEWER_BURLEY_GLSL
#ifndef N_SET0
#define N_SET0 1
#define SET0_X_TABLE float[1](1.552183)
#define SET0_RCP_TABLE float[1](31.11039)
#define SET0_CS_TABLE vec2[1](vec2(1.0, 0.0))
#define N_INNER 1
#endif
#ifndef N_SET1
#define N_SET1 0
#endif
#ifndef N_SET2
#define N_SET2 0
#endif
#ifndef CONTRAST_MINMAX
#define CONTRAST_MINMAX 0
#endif
#ifndef BURLEY_BUDGET
#define BURLEY_BUDGET 0
#endif
#ifndef BURLEY_ALWAYS
#define BURLEY_ALWAYS 0
#endif
#ifndef BURLEY_REUSE
#define BURLEY_REUSE 0
#endif
#ifndef BURLEY_FILTER_RADIUS_UNIT
#define BURLEY_FILTER_RADIUS_UNIT 16.564399  // P^-1(0.997): the filter radius in units of d (physics/burley.py)
#endif

const float BURLEY_PI = 3.14159265358979;
const float BURLEY_GOLDEN_RATIO = 1.618033988749895;

uniform vec3 u_S;         // S_c = 1/d_c per channel, 1/mm
uniform float u_d;        // d = max_c d_c, mm (the channel that is importance-sampled)
uniform vec3 u_cutoff1;   // trigger level 1 iff C_c > cutoff_c for any channel (thesis: 0.25)
uniform vec3 u_cutoff2;   // the same for level 2
uniform float u_wide_px;     // kernels at least this wide (radius, px) use the cutoffs times u_wide_scale
uniform float u_wide_scale;  // (1: the same cutoff at every footprint)
uniform uint u_seed;      // added to the rotation hash (0; another value decorrelates a reference image)
#if BURLEY_REUSE
uniform float u_reuse_split;  // px: samples this far from the centre are pooled with the neighbours' (reuse)
#endif

// PCG-RXS-M-XS (Jarzynski & Olano 2020): a stable per-pixel hash for the rotation phase
uint burley_pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// psi = 2 pi hash(pixel, bits of floor(linear depth in mm)) / 2^32 (spec §5.3 step 4: stable while the
// view is still). The depth is floored to whole mm: its last bits differ between GPUs (one ulp from
// NVIDIA to llvmpipe re-rolled every pixel's rotation: 8-18 % image differences, issue 31)
float burley_phase(ivec2 p, float z) {
    uint h = burley_pcg(uint(p.x) + burley_pcg(uint(p.y) + burley_pcg(floatBitsToUint(floor(z)) + u_seed)));
    return 6.2831855 * (float(h) * 2.3283064e-10);
}

// x = s r with 1 - P(x) = u: seed 001 eq. 3.12-3.13 corrected (numerator 1 + G^(-1/3) + G^(1/3), spec E7)
float burley_x_of_u(float u) {
    float G = 1.0 + 4.0 * u * (2.0 * u + sqrt(1.0 + 4.0 * u * u));
    float g = pow(G, 1.0 / 3.0);
    return 3.0 * log((1.0 + 1.0 / g + g) / (4.0 * u));
}

struct BurleyState {
    vec3 acc;      // sum w E
    vec3 wsum;     // sum w
    vec3 in_sum;   // ring statistics of the base set (eq. 4.1)
    vec3 out_sum;
    float n_in;
    float n_out;
    vec3 lo;       // min / max of the valid samples (CONTRAST_MINMAX)
    vec3 hi;
    float count;   // samples taken (valid or not): what the frame pays
    vec3 acc_o;    // BURLEY_REUSE: the samples at >= u_reuse_split px (pooled with the neighbours'), not in acc
    vec3 wsum_o;
};

BurleyState burley_state() {
    return BurleyState(vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0), 0.0, 0.0, vec3(FLOAT_MAX), vec3(-FLOAT_MAX), 0.0, vec3(0.0),
                       vec3(0.0));
}

// One sample (spec §5.3 step 4): r = x d, direction rotated by psi, pixel offset rounded, bilateral
// distance r' = sqrt(r^2 + dz^2), per-channel weight w = S/(8 pi)(e^-Sr' + e^-Sr'/3) rcpPdf (f/p, polar form).
// ring: 1 inner, 2 outer, 0 not counted in the rings.
void burley_take(inout BurleyState st, ivec2 p, float zc, float ppm, vec2 rot, float x, float rcp, vec2 cs,
                 int ring) {
    float r = x * u_d;
    vec2 dir = vec2(cs.x * rot.x - cs.y * rot.y, cs.y * rot.x + cs.x * rot.y);
    ivec2 q = p + ivec2(floor(ppm * r * dir + 0.5));
    st.count += 1.0;
    vec3 E;
    float z;
    if (!burley_fetch(q, E, z))
        return;
    float dz = z - zc;
    float rp = sqrt(r * r + dz * dz);
    vec3 w = u_S / (8.0 * BURLEY_PI) * (exp(-u_S * rp) + exp(-u_S * rp / 3.0)) * (rcp * u_d);
#if BURLEY_REUSE
    if (ppm * r >= u_reuse_split) {
        st.acc_o += w * E;
        st.wsum_o += w;
    } else {
        st.acc += w * E;
        st.wsum += w;
    }
#else
    st.acc += w * E;
    st.wsum += w;
#endif
#if CONTRAST_MINMAX
    st.lo = min(st.lo, E);
    st.hi = max(st.hi, E);
#else
    if (ring == 1) { st.in_sum += E; st.n_in += 1.0; }
    else if (ring == 2) { st.out_sum += E; st.n_out += 1.0; }
#endif
}

// per-channel contrast (seed 001 eq. 4.1; spec §7.6 step 3: empty ring -> 0)
vec3 burley_contrast(BurleyState st) {
#if CONTRAST_MINMAX
    if (st.hi.x < st.lo.x)
        return vec3(0.0);
    return (st.hi - st.lo) / max(st.hi + st.lo, vec3(1e-6));
#else
    if (st.n_in < 0.5 || st.n_out < 0.5)
        return vec3(0.0);
    vec3 L_in = st.in_sum / st.n_in;
    vec3 L_out = st.out_sum / st.n_out;
    return abs(L_in - L_out) / max(L_in + L_out, vec3(1e-6));
#endif
}

const float SET0_X[N_SET0] = SET0_X_TABLE;
const float SET0_RCP[N_SET0] = SET0_RCP_TABLE;
const vec2 SET0_CS[N_SET0] = SET0_CS_TABLE;
#if N_SET1 > 0
const float SET1_X[N_SET1] = SET1_X_TABLE;
const float SET1_RCP[N_SET1] = SET1_RCP_TABLE;
const vec2 SET1_CS[N_SET1] = SET1_CS_TABLE;
#endif
#if N_SET2 > 0
const float SET2_X[N_SET2] = SET2_X_TABLE;
const float SET2_RCP[N_SET2] = SET2_RCP_TABLE;
const vec2 SET2_CS[N_SET2] = SET2_CS_TABLE;
#endif

// The whole per-pixel estimator: returns sum w E / sum w; count = samples taken, level = extra levels taken,
// cmax = the largest channel of the base contrast (-1 when no contrast was computed).
vec3 burley_sss(ivec2 p, float zc, float ppm, float n_avail, out float count, out float level, out float cmax,
                out BurleyState fin) {
    BurleyState st = burley_state();
    float psi = burley_phase(p, zc);
    vec2 rot = vec2(cos(psi), sin(psi));
    level = 0.0;
    cmax = -1.0;
#if BURLEY_BUDGET
    if (n_avail < float(N_SET0)) {
        // fewer samples than the base set: n = floor(area / 4) stratified samples evaluated here
        int n = int(n_avail);
        for (int i = 0; i < N_SET0; ++i) {
            if (i >= n)
                break;
            float u = (float(i) + 0.5) / float(n);
            float x = burley_x_of_u(1.0 - u);
            float phi = 2.0 * BURLEY_PI * fract(float(i) / BURLEY_GOLDEN_RATIO);
            float rcp = 8.0 * BURLEY_PI / (exp(-x) + exp(-x / 3.0));
            burley_take(st, p, zc, ppm, rot, x, rcp, vec2(cos(phi), sin(phi)), 0);
        }
        count = st.count;
        fin = st;
        return (st.acc + st.acc_o) / max(st.wsum + st.wsum_o, vec3(1.17549435e-38));
    }
#endif
    for (int i = 0; i < N_SET0; ++i)
        burley_take(st, p, zc, ppm, rot, SET0_X[i], SET0_RCP[i], SET0_CS[i], i < N_INNER ? 1 : 2);
#if N_SET1 > 0
    vec3 C = burley_contrast(st);
    cmax = max(C.r, max(C.g, C.b));
#if BURLEY_BUDGET
    bool room = n_avail >= float(N_SET0 + N_SET1 + N_SET2);
#else
    bool room = true;
#endif
#if BURLEY_ALWAYS
    bool go = room;
#else
    float cut_scale = ppm * u_d * BURLEY_FILTER_RADIUS_UNIT >= u_wide_px ? u_wide_scale : 1.0;
    bool go = room && any(greaterThan(C, u_cutoff1 * cut_scale));
#endif
    if (go) {
        level = 1.0;
        for (int j = 0; j < N_SET1; ++j)
            burley_take(st, p, zc, ppm, rot, SET1_X[j], SET1_RCP[j], SET1_CS[j], 0);
#if N_SET2 > 0
#if BURLEY_ALWAYS
        bool go2 = true;
#else
        bool go2 = any(greaterThan(burley_contrast(st), u_cutoff2 * cut_scale));
#endif
        if (go2) {
            level = 2.0;
            for (int k = 0; k < N_SET2; ++k)
                burley_take(st, p, zc, ppm, rot, SET2_X[k], SET2_RCP[k], SET2_CS[k], 0);
        }
#endif
    }
#endif
    count = st.count;
    fin = st;
    return (st.acc + st.acc_o) / max(st.wsum + st.wsum_o, vec3(1.17549435e-38));
}
#endif
