"""Issue 32: translucency from the environment. The back side's SH irradiance E_SH(-Ng) through the
transmittance profile at the baked thickness along -N (physics/environment.env_transmitted), added in
the screen-space lighting pass (ssss, separable, burley, burley2) where its lights' transmittance is."""
import numpy as np
import pytest
from helpers import small_settings

from skinviewer.physics import environment as env
from skinviewer.physics.transmittance import profile_distance, transmittance
from skinviewer.scene.scenes import _flap_thickness, build_scene


def test_thickness_bake_measures_the_flap():
    m = build_scene("backlit-ear").mesh
    th = env.bake_thickness(m.positions, m.normals, m.indices)
    P, N = m.positions.astype(np.float64), m.normals.astype(np.float64)
    inner = (N[:, 2] > 0.9) & (np.abs(P[:, 0]) < 12) & (np.abs(P[:, 1]) < 17)  # the front, off the rim
    want = _flap_thickness(P[inner, 1]) / np.abs(N[inner, 2])  # along -N across the slanted flap
    np.testing.assert_allclose(th[inner], want, rtol=0.03)
    assert np.all(np.isfinite(th))
    # with the transfer: the back point's AO, 1 behind an open flap, lower where the back faces a wall
    T = env.bake_transfer(m.positions, m.normals, m.indices, rays=16)
    both = env.bake_thickness(m.positions, m.normals, m.indices, transfer=T)
    np.testing.assert_array_equal(both[:, 0], th)
    np.testing.assert_allclose(both[inner, 1], 1.0, atol=1e-6)
    wall = np.array([[-40, -40, -6], [40, -40, -6], [-40, 40, -6], [40, 40, -6]], np.float64)  # 2 mm behind
    P2 = np.concatenate([m.positions, wall])
    idx2 = np.concatenate([m.indices, len(m.positions) + np.array([[0, 2, 1], [1, 2, 3]])])
    N2 = np.concatenate([m.normals, np.tile([0.0, 0.0, 1.0], (4, 1))])
    T2 = env.bake_transfer(P2, N2, idx2, rays=16)
    walled = env.bake_thickness(P2, N2, idx2, transfer=T2)[: len(m.positions)]
    assert np.median(walled[inner, 1]) < 0.6  # the flap's back now faces the wall


def test_thickness_of_a_lone_sheet_is_a_miss():
    g = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float64)
    idx = np.array([[0, 1, 2], [1, 3, 2]])
    th = env.bake_thickness(g, np.tile([0.0, 0.0, 1.0], (4, 1)), idx)
    assert np.all(th == env.THICK_MISS)


def test_env_transmitted_is_the_back_irradiance_times_the_profile():
    img = np.ones((32, 64, 3))  # white: E = pi on any side
    E_lm = env.sh_irradiance_coefficients(env.sh_project(img))
    Ng = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    profile = lambda d: np.exp(-d)[:, None] * np.array([[1.0, 0.5, 0.25]])  # noqa: E731
    got = env.env_transmitted(E_lm, Ng, np.array([0.0, 2.0]), profile)
    np.testing.assert_allclose(got, np.pi * profile(np.array([0.0, 2.0])), rtol=5e-3)


@pytest.mark.parametrize("technique", ["ssss", "burley", "deon"])
def test_a_backlit_flap_glows_from_the_environment(renderer, technique):
    """Studio environment turned so the soft box is behind the flap: with transmittance on, the
    flap's front gains light that falls with the thickness (1.5 mm at the top, 6 mm at the bottom);
    for ssss it is the numpy twin's E_SH(-Ng) T(d) x albedo^mix at the centre."""
    from skinviewer.passes.environment import sh_uniform, transfer_uniform
    lights = [{"kind": "environment", "environment": "studio", "yaw": 180.0, "cast_shadow": False}]
    out = {}
    toggle, resource = ("deon.tsm", "lit") if technique == "deon" else ("transmittance.enabled", "ss_diffuse")
    for on in (False, True):
        s = small_settings("backlit-ear", technique, 64, **{"lights": lights, toggle: on, "render.tone_map": "linear"})
        renderer.render(s)
        out[on] = renderer.read(s, resource)[..., :3].astype(np.float64)
    gain = out[True] - out[False]
    h = gain.shape[0]
    col = gain[:, gain.shape[1] // 2, 0]  # red, down the middle column (row 0 at the bottom)
    top, bottom = col[int(0.75 * h)], col[int(0.3 * h)]
    assert top > 0 and top > 2.0 * bottom  # thin glows more
    assert np.abs(gain[..., 1:]).max() < gain[..., 0].max()  # red crosses most
    if technique != "ssss":
        return
    # the numpy twin at the centre pixel: y = 0 on the flap, thickness 3.75 mm, normal tilted by the taper
    s = small_settings("backlit-ear", technique, 64, **{"lights": lights})
    n = np.array([0.0, 0.5 * 4.5 / 40.0, 1.0])
    n /= np.linalg.norm(n)
    d_mm = _flap_thickness(np.array([0.0]))[0] / n[2]
    gs = [(float(g.variance), tuple(g.weights)) for g in s.deon.gaussians]
    prof = lambda d: transmittance(profile_distance(d, s.transmittance.translucency), gs, s.transmittance.form)  # noqa: E731
    want = env.env_transmitted(sh_uniform(s.lights[0]).astype(np.float64), n[None], np.array([d_mm]), prof)[0]
    # the front's own light (what the pass adds without transmittance): the unoccluded order-4 transfer
    front = env.transfer_irradiance(env.transfer_unoccluded(n[None]), transfer_uniform(s.lights[0]))[0]
    albedo_mix = out[False][h // 2, gain.shape[1] // 2] / front
    got = gain[h // 2, gain.shape[1] // 2]
    np.testing.assert_allclose(got, want * albedo_mix, rtol=0.05, atol=0.01 * float(want[0] * albedo_mix[0]))
