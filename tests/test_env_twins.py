"""The numpy twins of lib/environment.glsl that nothing else checked (issue 29: code used by nothing is
given a user or removed; these are the physics layer's statement of the shader's formulas, so they get
their judges): specular occlusion against the shader and its limits, the hemispherical mean of rho_dt
against closed-form moments and the shader's own nodes, the occluded diffuse against its definition."""
from __future__ import annotations

import re

import numpy as np
from glsl_eval import glsl_eval

from skinviewer.ground import paths
from skinviewer.physics import environment as env


def test_specular_occlusion_limits_and_the_shader(gl_ctx):
    rng = np.random.default_rng(3)
    nv, ao, m = rng.random(64), rng.random(64), rng.uniform(0.05, 1.0, 64)
    so = env.specular_occlusion(nv, ao, m)
    assert np.all((so >= 0) & (so <= 1))
    # no occlusion: everything reaches; full occlusion: nothing (below grazing), whatever m and N.V
    assert np.allclose(env.specular_occlusion(nv, np.ones(64), m), 1.0)
    assert np.allclose(env.specular_occlusion(nv[nv < 0.99], np.zeros((nv < 0.99).sum()), m[nv < 0.99]), 0.0)
    # Lagarde & de Rousiers 2014 eq. 9 at one hand-computed point: (0.5 + 0.5)^(2^-9) - 1 + 0.5 = 0.5
    assert abs(float(env.specular_occlusion(0.5, 0.5, 0.5)) - 0.5) < 1e-12
    # the shader's own function, cut out of lib/environment.glsl (the file needs a whole pass around it)
    src = (paths.shaders_dir() / "lib" / "environment.glsl").read_text(encoding="utf-8")
    fn = re.search(r"float env_specular_occlusion\(.*?\n\}", src, re.S)
    assert fn is not None
    glsl = glsl_eval(gl_ctx, [], "vec4(env_specular_occlusion(a.x, a.y, a.z), 0.0, 0.0, 0.0)",
                     np.stack([nv, ao, m], 1), preamble=fn.group(0))

    assert np.allclose(glsl[:, 0], so, atol=3e-6)


def test_rho_dt_mean_is_the_cosine_weighted_mean():
    # sum_k w_k f(mu_k) = int_0^1 f(mu) 2 mu dmu: exact for low-order polynomials in mu^2
    assert abs(float(env.rho_dt_mean(lambda mu: np.ones(3))[0]) - 1.0) < 1e-12
    assert abs(float(env.rho_dt_mean(lambda mu: np.full(3, mu * mu))[1]) - 0.5) < 1e-12
    assert abs(float(env.rho_dt_mean(lambda mu: np.full(3, mu ** 4))[0]) - 1.0 / 3.0) < 1e-12
    assert abs(float(env.rho_dt_mean(lambda mu: np.full(3, mu))[2]) - 2.0 / 3.0) < 3e-3  # sqrt(t): not exact
    # the shader's env_rho_dt_mean uses the same nodes and weights
    src = (paths.shaders_dir() / "lib" / "environment.glsl").read_text(encoding="utf-8")
    body = src[src.index("float env_rho_dt_mean"):]
    body = body[:body.index("}")]
    pairs = [(float(w), float(mu)) for w, mu in re.findall(r"([\d.]+) \* surface_rho_dt\(rho_tex, ([\d.]+), sp\)", body)]
    assert len(pairs) == len(env.RHO_MU) == 3
    assert np.allclose([mu for _, mu in pairs], env.RHO_MU, atol=1e-7)
    assert np.allclose([w for w, _ in pairs], env.RHO_W, atol=1e-7)


def test_env_diffuse_is_ambient_occlusion_times_the_bent_irradiance():
    rng = np.random.default_rng(5)
    E_lm = env.sh_irradiance_coefficients(rng.random((9, 3)))
    N = rng.normal(size=(32, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    assert np.allclose(env.env_diffuse(E_lm, N, N, None), env.sh_irradiance(E_lm, N))  # no bake: unoccluded
    ao = rng.random(32)
    vis = np.concatenate([N, ao[:, None]], 1)  # the bent normal is the vertex normal: only AO scales
    assert np.allclose(env.env_diffuse(E_lm, N, N, vis), ao[:, None] * env.sh_irradiance(E_lm, N))
    tilted = N + 0.3 * np.cross(N, [0.0, 0.0, 1.0])
    tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
    vis_b = np.concatenate([tilted, np.ones((32, 1))], 1)  # a bent normal turns the shading normal with it
    assert np.allclose(env.env_diffuse(E_lm, N, N, vis_b), env.sh_irradiance(E_lm, tilted))
