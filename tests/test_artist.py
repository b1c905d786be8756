"""The artist model (physics/artist.py, engine/look.py): scatter colour and radius per channel mapped to
the techniques' own parameters."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from skinviewer.engine import look
from skinviewer.ground.settings import (
    Settings,
    SettingsError,
    to_dict,
    validate,
    with_values,
)
from skinviewer.physics import artist
from skinviewer.physics.profiles import Burley

SKIN1 = ((0.436, 0.227, 0.131), (3.749, 1.473, 0.785))  # Jensen's Skin1 as Burley A and dmfp


@pytest.mark.parametrize("color", [SKIN1[0], (0.8, 0.5, 0.3), (0.05, 0.95, 0.5), (1.0, 1.0, 1.0)])
def test_colour_is_the_total_diffuse_reflectance(color):
    v, W = artist.gaussians(color, SKIN1[1], 6, normalize=False)
    # each Gaussian integrates to 1 over the plane (eq. 20): R_d of the table = sum of weights ...
    np.testing.assert_allclose(W.sum(axis=0), color, rtol=1e-12, atol=1e-15)
    # ... and the same number by quadrature of 2 pi r R(r), equal to Burley's own R_d (= A, eq. 2.84)
    r = np.geomspace(1e-5, 400.0, 20000)
    Rd = 2 * math.pi * np.trapezoid(r[:, None] ** 2 * artist.profile_of_table(r, v, W), np.log(r), axis=0)
    np.testing.assert_allclose(Rd, Burley(color, SKIN1[1]).total_reflectance(), rtol=2e-3)
    # d'Eon's convention: normalised weights, the colour in the albedo map
    _, Wn = artist.gaussians(color, SKIN1[1], 6, normalize=True)
    np.testing.assert_allclose(Wn.sum(axis=0), 1.0, rtol=1e-12)


def test_radius_sets_the_profile_width_monotonically():
    color = SKIN1[0]
    radii = np.geomspace(0.05, 20.0, 25)
    mean_r, half_r = [], []
    for l in radii:
        v, W = artist.gaussians(color, (l, 1.0, 0.5), 6)
        mean_r.append(artist.mean_radius(v, W)[0])
        half_r.append(artist.energy_radius(v, W, 0.5)[0])
    assert np.all(np.diff(mean_r) > 0) and np.all(np.diff(half_r) > 0)
    # the mean radius is Burley's own, 2.5 d = 2.5 l / s(A) (eq. 2.88), at every radius
    d = radii / artist.burley_scale(color[0], artist.FIT)
    np.testing.assert_allclose(mean_r, 2.5 * d, rtol=1e-6)
    # the channel's half-energy radius follows Burley's (eq. 3.9: P(r_half) = 1/2) within 10 %
    from skinviewer.physics.profiles import burley_cdf
    x = np.geomspace(1e-3, 100, 200000)
    x_half = x[np.searchsorted(burley_cdf(x, 1.0), 0.5)]
    np.testing.assert_allclose(half_r, x_half * d, rtol=0.1)


def test_a_uniform_radius_change_scales_the_variances_only():
    v1, W1 = artist.gaussians(SKIN1[0], SKIN1[1], 6)
    v2, W2 = artist.gaussians(SKIN1[0], tuple(2 * x for x in SKIN1[1]), 6)
    np.testing.assert_allclose(v2, 4 * v1, rtol=1e-12)
    np.testing.assert_allclose(W2, W1, atol=1e-9)


@pytest.mark.parametrize("k", [4, 6, 8])
def test_the_table_follows_the_looks_radial_energy(k):
    err = artist.cdf_error(*SKIN1, k)
    assert np.all(err < {4: 0.15, 6: 0.03, 8: 0.02}[k]), err


@pytest.mark.parametrize("look_", [SKIN1, ((0.6, 0.3, 0.2), (8.0, 2.0, 0.3)), ((0.2, 0.2, 0.2), (0.1, 0.1, 0.1))])
def test_look_table_look_round_trip(look_):
    color, radius = look_
    v, W = artist.gaussians(color, radius, 6)
    np.testing.assert_allclose(artist.estimate_radius(v, W, color), radius, rtol=1e-6)
    _, Wu = artist.gaussians(color, radius, 6, normalize=False)
    np.testing.assert_allclose(artist.estimate_color(Wu, (0.5, 0.5, 0.5)), color, rtol=1e-9)


def test_bad_look_is_refused():
    with pytest.raises(ValueError):
        artist.gaussians((1.2, 0.5, 0.5), (1, 1, 1))
    with pytest.raises(ValueError):
        artist.gaussians((0.5, 0.5, 0.5), (1, 0, 1))
    with pytest.raises(SettingsError):
        with_values(Settings(), {"look.scatter_radius": [1, 1, 80]})


def test_settings_look_drives_every_technique_and_a_preset_round_trips_without_drift(tmp_path):
    s = look.set_look(Settings(), color=(0.5, 0.3, 0.2), radius=(3.0, 1.2, 0.6))
    assert s.look.source == "look"
    assert s.burley.albedo == (0.5, 0.3, 0.2) and s.burley.mfp == (3.0, 1.2, 0.6) and s.burley.fit == artist.FIT
    v = np.array([g.variance for g in s.deon.gaussians])
    w = np.array([g.weights for g in s.deon.gaussians])
    np.testing.assert_allclose(artist.estimate_radius(v, w, (0.5, 0.3, 0.2)), (3.0, 1.2, 0.6), rtol=1e-5)
    # save -> load -> re-derive -> save: the same bytes, ten times over
    from skinviewer.ground.settings import load_preset, save_preset
    p = tmp_path / "look.json"
    save_preset(s, p)
    first = p.read_text()
    for _ in range(10):
        s2 = look.apply_look(load_preset(p))
        save_preset(s2, p)
    assert p.read_text() == first
    assert look.shown_look(s2)[2] == "look"
    np.testing.assert_array_equal(look.shown_look(s2)[1], (3.0, 1.2, 0.6))


def test_a_hand_edit_of_the_table_hands_the_profile_back():
    s = look.set_look(Settings(), radius=(2.0, 1.0, 0.5))
    a = {"deon.gaussians.0.variance": 0.01}
    s2 = look.resolve(with_values(s, a), a)
    assert s2.look.source == "table" and s2.deon.gaussians[0].variance == 0.01
    # the shown look is then read back from the table (an estimate)
    assert look.shown_look(s2, "deon")[2].startswith("estimated")
    # and a look edit takes over again
    a = {"look.scatter_radius.0": 4.0}
    s3 = look.resolve(with_values(s2, a), a)
    assert s3.look.source == "look" and s3.burley.mfp[0] == 4.0


def test_defaults_are_untouched_and_the_default_look_matches_deons_table():
    s = Settings()
    assert s.look.source == "table" and look.apply_look(s) == s
    _color, radius, where = look.shown_look(s, "deon")
    assert where.startswith("estimated")
    np.testing.assert_allclose(radius, s.look.scatter_radius, rtol=3e-3)  # the default look is d'Eon's reach
    # burley shows its own parameters
    assert look.shown_look(s, "burley")[1].tolist() == list(s.burley.mfp)
    assert json.dumps(to_dict(validate(to_dict(s)))) == json.dumps(to_dict(s))


def test_cli_set_look_rederives(tmp_path):
    from argparse import Namespace

    from skinviewer.cli.args import settings_from_args
    args = Namespace(preset=None, scene=None, mesh=None, technique="deon", size=None, camera=None,
                     assign=["look.source=look", "look.scatter_radius=2,1,0.5"])
    s = settings_from_args(args)
    assert s.burley.mfp == (2.0, 1.0, 0.5)
    v = np.array([g.variance for g in s.deon.gaussians])
    w = np.array([g.weights for g in s.deon.gaussians])
    np.testing.assert_allclose(artist.estimate_radius(v, w, s.look.scatter_color), (2.0, 1.0, 0.5), rtol=1e-5)


def test_messages_one_gaussian_the_look_profile_and_edges():
    """Issue 36's mutation sample of artist.py. The user reads these messages whole (one clear line); a
    one-Gaussian table keeps the look's mean radius 2.5 d of the widest channel (quadrature of the 2-D
    Gaussian's radial energy, and of Burley's own profile for the 2.5 d); the look's profile is eq. 2.84
    and carries the colour A as its energy (quadrature); a channel with no energy has no half-energy
    radius inside the grid (its far end, 1 m)."""
    from scipy.integrate import quad
    for bad, msg in ((((1.2, 0.5, 0.5), (1, 1, 1)), r"scatter colour components must be in \[0, 1\]"),
                     (((0.5, 0.5, 0.5), (1, 0, 1)), r"scatter radius components must be > 0 mm")):
        with pytest.raises(ValueError, match=f"^{msg}$"):
            artist.gaussians(*bad)
    for k in (0, 65):
        with pytest.raises(ValueError, match="^the number of Gaussians must be between 1 and 64$"):
            artist.gaussians(*SKIN1, k=k)
    normalised = np.full((6, 3), 1.0 / 6.0)
    with pytest.raises(ValueError, match="^scatter colour must be finite$"):
        artist.estimate_color(normalised, (math.nan, 0.5, 0.5))
    # one Gaussian: its radial energy 2 pi r G(r) has the mean radius 2.5 d of the widest channel
    color, radius = SKIN1
    d = artist.shape_distance(color, radius)
    v, W = artist.gaussians(color, radius, k=1)
    assert v.shape == (1,) and W.shape == (1, 3)
    np.testing.assert_allclose(W, 1.0)
    g = lambda r: r * math.exp(-r * r / (2 * v[0])) / v[0]  # noqa: E731  (2 pi r G, G = e^(-r^2/2v) / (2 pi v))
    assert quad(lambda r: r * g(r), 0, np.inf)[0] == pytest.approx(2.5 * float(d.max()), rel=1e-9)
    # ... and 2.5 d is the mean radius of Burley's eq. 2.84 profile itself, R(r) of the look (energy A)
    for c in range(3):
        R = lambda r, c=c: artist.burley_profile(r, color, radius)[c]  # noqa: E731
        energy = quad(lambda r, R=R: 2 * math.pi * r * R(r), 0, np.inf, limit=200)[0]
        assert energy == pytest.approx(color[c], rel=1e-8)
        assert quad(lambda r, R=R: 2 * math.pi * r * r * R(r), 0, np.inf, limit=200)[0] / energy == pytest.approx(
            2.5 * d[c], rel=1e-8)
        r0 = 0.7
        assert R(r0) == pytest.approx(color[c] * (math.exp(-r0 / d[c]) + math.exp(-r0 / (3 * d[c])))
                                      / (8 * math.pi * d[c] * r0), rel=1e-12)
    # no energy in blue: no radius inside which half of it lies; the grid's far end (1e3 mm), not its last but one
    np.testing.assert_array_equal(artist.energy_radius([1.0, 4.0], [(0.5, 0.5, 0.0), (0.5, 0.5, 0.0)])[2], 1e3)
