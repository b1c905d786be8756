"""Kelemen/Szirmay-Kalos specular (seed 000 eq. 14-16, seed 002 listings 14-1..14-3), the Beckmann LUT,
rho_dt (eq. 30-31), and the GLSL twin shaders/lib/kelemen.glsl against numpy."""
from pathlib import Path

import numpy as np
import pytest

from skinviewer.ground import paths
from skinviewer.physics import specular as S

ROOT = Path(__file__).resolve().parents[1]
KELEMEN = paths.shaders_dir() / "lib" / "kelemen.glsl"  # SKINVIEWER_SHADERS: a mutated copy (glsl_mutation.py)
Z = np.array([0.0, 0.0, 1.0])


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _random_dirs(rng, n, max_angle_deg):
    """Unit vectors within max_angle of +Z."""
    cos_max = np.cos(np.radians(max_angle_deg))
    c = rng.uniform(cos_max, 1.0, n)
    a = rng.uniform(0.0, 2.0 * np.pi, n)
    s = np.sqrt(1.0 - c * c)
    return np.stack([s * np.cos(a), s * np.sin(a), c], axis=-1)


def _listing_beckmann(c, m):
    """Listing 14-2 PHBeckmann literally (acos/tan), for interior c only."""
    ta = np.tan(np.arccos(c))
    return 1.0 / (m * m * c ** 4) * np.exp(-(ta * ta) / (m * m))


def _hard_cases():
    """(N, L, V, m) rows that must stay finite: N.H -> 0 and < 0, m -> 0 and 1, V.H <= 0, L = -V,
    zero / tiny / huge / unnormalised vectors, grazing opposite directions."""
    g = 1e-4
    rows = [
        (Z, [1, 0, g], [-1, 0, g], 0.3),             # L, V grazing opposite: h.h ~ 4 g^2, H = N
        (Z, [1, 0, 1e-3], [-1, 0, -1e-3], 0.3),      # L = -V exactly
        (Z, [0.6, 0, 0.8], [-0.6, 0, -0.8], 0.0),    # L = -V, m = 0
        (Z, [1, 0, 1e-6], [0, 1, -0.999], 0.3),      # N.H -> 0
        (Z, [1, 0, 0.2], [0.2, 0, -1], 0.3),         # N.H < 0
        (Z, [0, 0.1, 1], [0, -0.1, -0.5], 0.5),      # V below the surface, N.H > 0
        (Z, Z, Z, 0.0),                              # m = 0 at the delta's peak
        (Z, Z, Z, 1e-3),
        (Z, Z, Z, 1.0),                              # m = 1
        (Z, [0.3, 0, 1], [-0.3, 0.01, 1], 1e-9),     # m -> 0 off peak
        (Z, [0.3, 0, 1], [-0.3, 0.01, 1], 1.0),
        ([0, 0, 0], Z, Z, 0.3),                      # zero vectors
        (Z, [0, 0, 0], Z, 0.3),
        (Z, Z, [0, 0, 0], 0.3),
        ([0, 0, 1e-20], [1e-20, 0, 1e-20], Z, 0.3),  # tiny (float32-representable)
        ([0, 0, 1e30], [1e30, 0, 3e30], [0, 2e30, 1e30], 0.3),  # huge: dot() would overflow
        ([0, 0, 5], [2, 0, 3], [-1, 0, 7], 0.2),     # unnormalised
        (Z, [0, 0, -1], Z, 0.3),                     # N.L < 0
        (Z, [1, 0, 0], [-1, 0, 0], 0.3),             # both at the horizon, opposite
    ]
    n, l, v, m = (np.array([r[k] for r in rows], dtype=np.float64) for k in range(4))
    return n, l, v, m


# -- numpy: eq. 14-16 ----------------------------------------------------------------------------
def test_fresnel_and_beckmann_match_the_listings():
    assert S.schlick_fresnel(1.0, 0.028) == pytest.approx(0.028)
    assert S.schlick_fresnel(0.0, 0.028) == pytest.approx(1.0)
    assert S.schlick_fresnel(-0.5, 0.028) == pytest.approx(1.0)  # V.H <= 0: clamped base
    hv = np.linspace(0.0, 1.0, 11)
    np.testing.assert_allclose(S.schlick_fresnel(hv, 0.05), (1 - hv) ** 5 + 0.05 * (1 - (1 - hv) ** 5))
    c = np.linspace(0.05, 0.999, 200)[:, None]
    m = np.array([0.1, 0.3, 1.0])[None, :]
    np.testing.assert_allclose(S.beckmann(c, m), _listing_beckmann(c, m), rtol=1e-9, atol=1e-300)
    np.testing.assert_allclose(S.beckmann(1.0, m), 1.0 / m ** 2)
    assert np.all(S.beckmann([0.0, -0.3, -1.0], 0.3) == 0.0)
    assert S.beckmann(1.0, 0.0) == S.beckmann(1.0, S.M_MIN) == pytest.approx(1e6)


def test_beckmann_is_pi_times_the_normalised_ndf():
    # documented normalisation: int P_H (N.H) dw_H = pi (listing 14-2 has no 1/pi)
    th = (np.arange(20000) + 0.5) * (0.5 * np.pi / 20000)
    for m in (0.1, 0.3, 0.6):
        dth = 0.5 * np.pi / 20000
        total = 2 * np.pi * np.sum(S.beckmann(np.cos(th), m) * np.cos(th) * np.sin(th)) * dth
        assert total == pytest.approx(np.pi, rel=1e-4)


def test_brdf_is_reciprocal_specular_is_brdf_times_ndotl():
    rng = np.random.default_rng(1)
    n = _unit(_random_dirs(rng, 500, 20) + rng.normal(0, 0.05, (500, 3)))
    l = _random_dirs(rng, 500, 95)  # some below the horizon too: the formula stays symmetric
    v = _random_dirs(rng, 500, 95)
    m = rng.uniform(0.1, 0.8, 500)
    rho = rng.uniform(0.1, 2.0, 500)
    f_lv = S.ks_brdf(n, l, v, m, rho, 0.028)
    f_vl = S.ks_brdf(n, v, l, m, rho, 0.028)
    np.testing.assert_allclose(f_lv, f_vl, rtol=1e-12, atol=0)
    assert np.count_nonzero(f_lv > 1e-3) > 100
    nl, nv = np.sum(n * l, -1), np.sum(n * v, -1)
    spec_lv = S.ks_specular(n, l, v, m, rho, 0.028)
    np.testing.assert_allclose(spec_lv, f_lv * np.maximum(nl, 0), rtol=1e-12)
    # with the cosine multiplied in it is not reciprocal
    spec_vl = S.ks_specular(n, v, l, m, rho, 0.028)
    both = (nl > 0.1) & (nv > 0.1) & (np.abs(nl - nv) > 0.1) & (f_lv > 1e-3)
    assert both.sum() > 20
    assert np.all(np.abs(spec_lv[both] - spec_vl[both]) > 1e-6 * spec_lv[both])
    # a zero L or V is no direction: 0 either way round (reciprocity holds there too)
    z = np.zeros(3)
    assert S.ks_brdf(n[0], z, v[0], 0.3, 1.0) == 0.0 == S.ks_brdf(n[0], v[0], z, 0.3, 1.0)


def test_specular_against_listing_14_3_literally():
    rng = np.random.default_rng(2)
    n, l, v = _random_dirs(rng, 200, 30), _random_dirs(rng, 200, 70), _random_dirs(rng, 200, 70)
    m, rho, f0 = 0.25, 0.18, 0.028
    h = l + v
    H = _unit(h)
    ndotl = np.sum(n * l, -1)
    ph = _listing_beckmann(np.sum(n * H, -1), m)
    b = 1.0 - np.sum(H * v, -1)
    F = b ** 5 + f0 * (1 - b ** 5)
    ref = np.where(ndotl > 0, ndotl * rho * np.maximum(ph * F / np.sum(h * h, -1), 0), 0)
    np.testing.assert_allclose(S.ks_specular(n, l, v, m, rho, f0), ref, rtol=1e-9, atol=1e-300)


def test_hard_cases_are_finite_numpy():
    n, l, v, m = _hard_cases()
    for fn in (S.ks_specular, S.ks_brdf):
        out = fn(n, l, v, m, 10.0, 1.0)  # worst-case rho_s and f0
        assert np.all(np.isfinite(out)) and np.all(out >= 0)
        assert np.all(np.isfinite(out * 1e5))
        assert out.max() <= 10.0 * 1e6 / S.HH_EPS
    lut = S.beckmann_lut(64)
    assert np.all(np.isfinite(S.ks_specular_lut(n, l, v, m, 10.0, 1.0, lut) * 1e5))
    spec = S.ks_specular(n, l, v, m, 0.18, 0.028)
    assert spec[1] == spec[2] == 0.0  # L = -V
    assert spec[4] == 0.0  # N.H < 0
    assert spec[6] == spec[7] == pytest.approx(1e6 * 0.18 * 0.028 / 4)  # m = 0 -> M_MIN
    assert spec[11] == spec[12] == spec[13] == 0.0  # zero vectors
    assert spec[17] == 0.0  # N.L < 0
    unit_row = S.ks_specular(_unit([0, 0, 5]), _unit([2, 0, 3]), _unit([-1, 0, 7]), 0.2, 0.18)
    np.testing.assert_allclose(spec[16], unit_row)  # unnormalised inputs are normalised
    # NaN / Inf inputs do not propagate
    assert np.isfinite(S.ks_specular([np.nan, 0, 1], Z, [0, np.inf, 1], np.nan, 0.18))


# -- the Beckmann texture (listing 14-2) -------------------------------------------------------
def test_beckmann_lut_layout_and_encoding():
    size = 64
    lut = S.beckmann_lut(size)
    assert lut.shape == (size, size) and lut.dtype == np.float32
    for j, i in ((10, 60), (32, 50), (63, 63), (5, 63)):
        x, m = (i + 0.5) / size, (j + 0.5) / size  # columns: N.H, rows: m, texel centres
        assert lut[j, i] == pytest.approx(0.5 * _listing_beckmann(x, m) ** 0.1, rel=1e-6)
    # the lookup hits the texel centres exactly, and decoding inverts the encoding
    x = S.texel_centres(size)
    np.testing.assert_allclose(S.sample_bilinear(lut, x[None, :], x[:, None]), lut, rtol=1e-15)
    np.testing.assert_allclose(S.decode_beckmann(0.5 * S.beckmann(0.97, 0.3) ** 0.1), S.beckmann(0.97, 0.3),
                               rtol=1e-12)
    assert S.decode_beckmann(-0.1) == 0.0


def _mirror_configs(c, m):
    """N = Z, fixed V at 30 deg, L the mirror of V about the H with N.H = c (c, m broadcast)."""
    c, m = np.broadcast_arrays(np.asarray(c, float), np.asarray(m, float))
    th = np.arccos(c)
    H = np.stack([np.sin(th), np.zeros_like(th), np.cos(th)], axis=-1)
    v = np.broadcast_to(_unit([-0.5, 0.0, np.sqrt(0.75)]), H.shape)
    l = 2 * np.sum(v * H, -1, keepdims=True) * H - v
    return np.broadcast_to(Z, H.shape), l, v, m


def test_lut_mode_matches_direct_within_the_measured_tolerance():
    lut = S.beckmann_lut(512)
    c = np.linspace(0.9, 1.0, 8001)[None, :]  # below 0.9 the specular is < 1e-3 of its peak here
    m = np.linspace(0.15, 0.5, 36)[:, None]
    n, l, v, mm = _mirror_configs(c, m)
    direct = S.ks_specular(n, l, v, mm, 0.18, 0.028)
    fast = S.ks_specular_lut(n, l, v, mm, 0.18, 0.028, lut)
    peak = direct.max(axis=1, keepdims=True)
    sig = direct >= 1e-3 * peak
    assert np.all(np.sum(l * n, -1)[sig] > 0)
    rel = np.abs(fast - direct)[sig] / direct[sig]
    assert rel.max() <= S.LUT_512_REL_TOL
    assert rel.max() > 0.8 * S.LUT_512_REL_TOL  # the stated figure is the measured one
    interior = (np.broadcast_to(c, direct.shape) <= 1 - 0.5 / 512)[sig]
    assert rel[interior].max() <= S.LUT_512_REL_TOL_INTERIOR
    assert rel[interior].max() > 0.5 * S.LUT_512_REL_TOL_INTERIOR


# -- rho_dt (eq. 30-31) --------------------------------------------------------------------------
def test_rho_dt_table_layout_range_and_direct_function():
    t = S.rho_dt_table(0.028, 0.18, n_cos=32, n_m=16)
    assert t.shape == (16, 32) and t.dtype == np.float32
    assert np.all((t >= 0) & (t <= 1))
    c, m = S.texel_centres(32), S.texel_centres(16)
    np.testing.assert_allclose(S.rho_dt(c[None, :], m[:, None], 0.028, 0.18), t, rtol=0, atol=1e-6)
    # d'Eon: for skin the specular takes little: rho_dt ~ 0.9-1 except towards grazing light
    assert np.all(t[:, c > 0.3] > 0.9) and t[:, -1].min() > 0.97
    # more energy enters as the light rises (up to cos ~0.9; the KS integral has a real shallow
    # minimum near cos 0.92: the table dips by < 1e-4 towards normal incidence)
    assert np.all(np.diff(t[:, c < 0.9], axis=1) >= -1e-6)
    assert np.all(np.diff(t, axis=1) >= -1e-4)
    assert np.all(S.rho_dt_table(0.028, 0.0) == 1.0)
    assert np.all(S.rho_dt_table(0.1, 0.18) <= S.rho_dt_table(0.028, 0.18))  # more Fresnel, less diffuse
    strong = S.rho_dt_table(1.0, 10.0)
    assert strong.min() == 0.0 and np.all(np.isfinite(strong))  # clamped, not negative


def test_rho_dt_monotone_in_rho_s_and_tends_to_one():
    vals = [float(S.rho_dt(0.5, 0.3, 0.028, r)) for r in (1.0, 0.5, 0.18, 0.05, 0.01, 1e-4, 0.0)]
    assert all(a < b for a, b in zip(vals, vals[1:]))
    assert vals[-1] == 1.0 and vals[-2] > 0.9999


@pytest.mark.parametrize("cos_i,m_j", [(0, 3), (2, 9), (9, 20), (20, 5), (31, 31), (16, 12)])
def test_rho_dt_table_matches_bruteforce_eq_31(cos_i, m_j):
    rho_s, f0 = 1.0, 0.028  # rho_s = 1: the integral itself is compared
    t = S.rho_dt_table(f0, rho_s)
    cos_t, m = (cos_i + 0.5) / 32, (m_j + 0.5) / 32
    ref = S.rho_dt_bruteforce(cos_t, m, f0, rho_s, n_theta=512, n_phi=1024)
    assert t[m_j, cos_i] == pytest.approx(np.clip(ref, 0, 1), abs=1e-3)


def test_rho_dt_edits_rescale_cached_tables():
    """F0 / rho_s edits reuse the two cached base tables (timed in benchmarks/bench_luts.py)."""
    S._rho_tables.cache_clear()
    S.rho_dt_table(0.028, 0.18)
    misses = S._rho_tables.cache_info().misses
    for k in range(10):
        S.rho_dt_table(0.02 + 0.001 * k, 0.1 + 0.01 * k)  # UI edits of F0 / rho_s
    assert S._rho_tables.cache_info().misses == misses


# -- GLSL twin (shaders/lib/kelemen.glsl) ----------------------------------------------------------
_VERT = """#version 330
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""
_FRAG = """#version 330
#include "lib/kelemen.glsl"
uniform sampler2D tN, tL, tV, tP, tS;
uniform sampler2D beckmann_tex, rho_tex;
layout(location = 0) out vec4 o0;
layout(location = 1) out vec4 o1;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 N = texelFetch(tN, p, 0).xyz, L = texelFetch(tL, p, 0).xyz, V = texelFetch(tV, p, 0).xyz;
    vec4 P = texelFetch(tP, p, 0);  // m, rho_s, f0, -
    vec4 s = texelFetch(tS, p, 0);  // n_dot_h, h_dot_v, cos_theta, -
    float ks = ks_specular(N, L, V, P.x, P.y, P.z);
    float kl = ks_specular_lut(N, L, V, P.x, P.y, P.z, beckmann_tex);
    o0 = vec4(ks, kl, rho_dt_lookup(rho_tex, s.z, P.x), beckmann_ph(s.x, P.x));
    o1 = vec4(fresnel_schlick(s.y, P.z), ks * 1e5, kl * 1e5, 0.0);
}
"""


@pytest.fixture(scope="module")
def gl(gl_ctx):
    # the session's context (conftest: one GL platform per test process). A private EGL context
    # here made the later GLX contexts fail (X_GLXMakeCurrent BadAccess: the process exits).
    return gl_ctx


def _program(ctx, tmp_path):
    (tmp_path / "lib").symlink_to(KELEMEN.parent, target_is_directory=True)
    (tmp_path / "kelemen_test.vert").write_text(_VERT)
    (tmp_path / "kelemen_test.frag").write_text(_FRAG)
    try:
        from skinviewer.kernel.shaders import ShaderLibrary
    except ImportError:  # no shader library yet: splice the include by hand
        return ctx.program(vertex_shader=_VERT,
                           fragment_shader=_FRAG.replace('#include "lib/kelemen.glsl"', KELEMEN.read_text()))
    return ShaderLibrary(ctx, root=tmp_path, include_roots=(KELEMEN.parent.parent,)).get("kelemen_test")


def _run_glsl(ctx, tmp_path, n, l, v, params, scalars, lut, rho):
    """Evaluate the GLSL functions for rows of inputs; returns (rows, 8) float64."""
    import moderngl

    rows = len(n)
    w = 64
    h = -(-rows // w)

    def tex(a):
        a = np.asarray(a, np.float32)
        full = np.zeros((w * h, 4), np.float32)
        full[:rows, : a.shape[1]] = a
        t = ctx.texture((w, h), 4, full.tobytes(), dtype="f4")
        t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return t

    prog = _program(ctx, tmp_path)
    texs = [tex(a) for a in (n, l, v, params, scalars)] + [S.upload_table(ctx, lut), S.upload_table(ctx, rho)]
    for unit, (name, t) in enumerate(zip(("tN", "tL", "tV", "tP", "tS", "beckmann_tex", "rho_tex"), texs)):
        t.use(unit)
        prog[name].value = unit
    outs = [ctx.texture((w, h), 4, dtype="f4") for _ in range(2)]
    fbo = ctx.framebuffer(color_attachments=outs)
    fbo.use()
    fbo.viewport = (0, 0, w, h)
    vao = ctx.vertex_array(prog, [])
    vao.render(moderngl.TRIANGLES, vertices=3)
    res = [np.frombuffer(o.read(), np.float32).reshape(-1, 4)[:rows] for o in outs]
    for obj in [vao, fbo, *outs, *texs]:
        obj.release()
    return np.concatenate(res, axis=1).astype(np.float64)


def test_glsl_matches_numpy(gl, tmp_path):
    rng = np.random.default_rng(3)
    rows = 64 * 48
    n = _unit(_random_dirs(rng, rows, 25) + rng.normal(0, 0.03, (rows, 3)))
    l = _random_dirs(rng, rows, 75)
    v = _random_dirs(rng, rows, 75)
    # half the rows near the mirror configuration so the highlight itself is compared
    k = rows // 2
    v[:k] = 2 * np.sum(l[:k] * n[:k], -1, keepdims=True) * n[:k] - l[:k] + rng.normal(0, 0.05, (k, 3))
    v[:k] = _unit(v[:k])
    m = rng.choice([0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0], rows)
    params = np.stack([m, rng.uniform(0.05, 2.0, rows), rng.uniform(0.02, 0.2, rows)], axis=-1)
    scalars = np.stack([rng.uniform(-0.2, 1.0, rows), rng.uniform(-0.2, 1.0, rows), rng.uniform(0, 1, rows)],
                       axis=-1)  # n_dot_h, h_dot_v, cos_theta
    # numpy sees exactly the float32 inputs the shader sees
    n32, l32, v32, p32, s32 = (np.asarray(a, np.float32).astype(np.float64)
                               for a in (n, l, v, params, scalars))
    ok = (np.sum(n32 * l32, -1) > 0.05) & (np.sum(_unit(n32) * _unit(v32), -1) > 0.05)
    lut = S.beckmann_lut(512)
    rho = S.rho_dt_table(0.028, 0.18)
    out = _run_glsl(gl, tmp_path, n32, l32, v32, p32, s32, lut, rho)
    assert np.all(np.isfinite(out))
    mm, rs, f0 = p32[:, 0], p32[:, 1], p32[:, 2]

    direct = S.ks_specular(n32, l32, v32, mm, rs, f0)
    assert np.count_nonzero(direct[ok] > 1e-2) > 500
    np.testing.assert_allclose(out[ok, 0], direct[ok], rtol=1e-4, atol=1e-30)
    np.testing.assert_allclose(out[ok, 5], 1e5 * direct[ok], rtol=1e-4, atol=1e-25)

    # LUT mode: same table, GPU bilinear vs numpy's (float weights on llvmpipe)
    via_lut = S.ks_specular_lut(n32, l32, v32, mm, rs, f0, lut)
    np.testing.assert_allclose(out[ok, 1], via_lut[ok], rtol=2e-4, atol=1e-30)
    # ... and against direct within the measured LUT tolerance where the specular is visible
    vis = ok & (mm >= 0.15) & (mm <= 0.5) & (direct >= 1e-3 * rs / mm ** 2)
    assert vis.sum() > 200
    assert np.all(np.abs(out[vis, 1] - direct[vis]) <= (S.LUT_512_REL_TOL + 2e-4) * direct[vis])

    np.testing.assert_allclose(out[:, 3], S.beckmann(s32[:, 0], mm), rtol=1e-4, atol=1e-30)
    np.testing.assert_allclose(out[:, 4], S.schlick_fresnel(s32[:, 1], f0), rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(out[:, 2], np.clip(S.sample_bilinear(rho, s32[:, 2], mm), 0, 1), atol=2e-5)
    # the 32 x 32 table's interpolation error vs. direct rho_dt: 1.2e-3 for cos >= 0.2 (it grows to
    # ~0.1 at grazing light with small m, where rho_dt is steep and N.L ~ 0 anyway)
    up = s32[:, 2] >= 0.2
    np.testing.assert_allclose(out[up, 2], S.rho_dt(s32[up, 2], mm[up], 0.028, 0.18), atol=1.5e-3)


def test_glsl_hard_cases_are_finite(gl, tmp_path):
    n, l, v, m = _hard_cases()
    rows = len(n)
    params = np.stack([m, np.full(rows, 10.0), np.full(rows, 1.0)], axis=-1)  # worst rho_s, f0
    scalars = np.stack([np.linspace(-1, 1, rows), np.linspace(-1, 1, rows), np.linspace(-0.5, 1.5, rows)], -1)
    lut = S.beckmann_lut(64)
    rho = S.rho_dt_table(1.0, 10.0)
    out = _run_glsl(gl, tmp_path, n, l, v, params, scalars, lut, rho)
    assert np.all(np.isfinite(out)), out
    assert np.all(out[:, :2] >= 0)
    assert np.all(out[[1, 2, 4, 11, 12, 13, 17], :2] == 0.0)  # L = -V, N.H < 0, zero vectors, N.L < 0
    assert np.all((out[:, 2] >= 0) & (out[:, 2] <= 1))
    numpy_spec = S.ks_specular(n, l, v, m, 10.0, 1.0)
    both_regular = [0, 5, 6, 7, 8, 9, 10, 15, 16]
    np.testing.assert_allclose(out[both_regular, 0], numpy_spec[both_regular], rtol=2e-3, atol=1e-30)


def test_non_finite_components_count_as_zero():
    """safe_normalize's contract (issue 36's mutation sample): NaN, +Inf and -Inf components count as 0."""
    got = S.safe_normalize(np.array([[np.nan, 0.0, 2.0], [np.inf, 3.0, 0.0], [-np.inf, 0.0, -4.0]]))
    np.testing.assert_array_equal(got, [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])


def test_clamps_of_the_lookup_and_fresnel_and_a_float64_table_uploads(gl):
    """Issue 36's second specular sample: f0 is clamped to [0, 1] (f0 = 1 is a perfect mirror, F = 1
    everywhere; 1.5 is no brighter); sample_bilinear is CLAMP_TO_EDGE -- a lookup left of the first texel
    centre reads column 0, right of the last reads the last (no wrap-around, no IndexError), as the GPU's
    sampler does; upload_table takes a float64 table (stored as R32F, read back exactly as float32)."""
    for hv in (0.0, 0.3, 1.0):
        assert S.schlick_fresnel(hv, 1.5) == pytest.approx(1.0, abs=1e-15)
        assert S.schlick_fresnel(hv, 1.0) == pytest.approx(1.0, abs=1e-15)
    t = np.array([[1.0, 2.0, 3.0, 4.0], [10.0, 20.0, 30.0, 40.0]])  # (height 2, width 4)
    # x < 0.5/4: column 0, x > 3.5/4: column 3, whatever y (rows interpolate: y = 0.5 is between the centres)
    for x, col in ((-0.5, 0), (-1.0, 0), (0.05, 0), (0.95, 3), (1.2, 3), (2.0, 3)):
        assert S.sample_bilinear(t, x, 0.25) == pytest.approx(t[0, col]), x
        assert S.sample_bilinear(t, x, 0.5) == pytest.approx(0.5 * (t[0, col] + t[1, col])), x
    table = np.linspace(0.0, 1.0, 12, dtype=np.float64).reshape(3, 4) + 1e-9  # not float32-exact
    tex = S.upload_table(gl, table)
    try:
        assert tex.size == (4, 3) and tex.dtype == "f4"
        got = np.frombuffer(tex.read(), np.float32).reshape(3, 4)
        np.testing.assert_array_equal(got, table.astype(np.float32))
    finally:
        tex.release()
