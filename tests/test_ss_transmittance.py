"""Issue 27: the screen-space transmittance is split from the per-pixel lighting. ss_lighting
measures each shadow-casting light's thickness and weight; ss_transmittance applies the profile
T(d) (Jimenez 2010, seed 001 eq. 3.18; Burley's T(t), spec §5.4), so a profile edit re-runs a
full-screen pass, not the lighting. Its GLSL agrees with physics/transmittance.py and
physics/burley.py."""
from __future__ import annotations

import numpy as np
import pytest

from skinviewer.ground.settings import with_values
from skinviewer.passes.screen_space.lighting import DIFFUSE, DIRECT, transmitted_resource
from skinviewer.physics import burley as B
from skinviewer.physics.transmittance import profile_distance, transmittance
from tests.helpers import small_settings

BACKLIT = {"lights.0.direction": [-0.2, 0.1, -1.0]}  # the key light behind the head: light through the ears


def backlit(technique: str, **kw):
    return small_settings("head", technique, size=96, **BACKLIT, **kw)


@pytest.mark.parametrize("technique", ["ssss", "burley"])
def test_the_transmittance_pass_adds_the_profile_at_each_light_s_thickness(renderer, technique):
    s = backlit(technique)
    renderer.render(s)
    g = renderer.graph(technique)
    direct, out = g.read(DIRECT).astype(np.float64), g.read(DIFFUSE).astype(np.float64)
    k = sum(1 for l in s.lights if l.enabled and l.cast_shadow and l.intensity > 0)
    expected = direct[..., :3].copy()
    for j in range(k):
        t = g.read(transmitted_resource(j)).astype(np.float64)
        if technique == "burley":  # the closed form (burley.transmission default), thickness in mm
            T = B.transmittance(t[..., 3:4], B.profile_of_section(s.burley).S)
        else:
            gs = [(g_.variance, g_.weights) for g_ in s.deon.gaussians]
            T = transmittance(profile_distance(t[..., 3], s.transmittance.translucency), gs, s.transmittance.form)
        expected += np.where((t[..., :3] > 0).any(-1, keepdims=True), t[..., :3] * T, 0.0)
    added = expected - direct[..., :3]
    assert added.max() > 0.01 * direct[..., :3].max(), "no light came through: the test scene is not backlit"
    assert np.abs(out[..., :3] - expected).max() <= 1e-5 * expected.max()
    assert np.array_equal(out[..., 3], direct[..., 3])  # the SSS mask passes through


@pytest.mark.parametrize("technique,path,value", [("ssss", "transmittance.translucency", 0.6),
                                                  ("burley", "burley.scale", 1.3)])
def test_a_profile_edit_re_runs_the_transmittance_not_the_lighting(renderer, technique, path, value):
    s = backlit(technique)
    renderer.render(s)
    rep = renderer.render(with_values(s, {path: value}))
    assert "ss_transmittance" in rep.ran
    assert "ss_lighting" in rep.cached
    rep = renderer.render(with_values(s, {"transmittance.wrap": 0.4}))  # the wrap weighs the back light
    assert "ss_lighting" in rep.ran


def test_without_transmittance_the_lighting_writes_the_diffuse_itself(renderer):
    s = backlit("ssss", **{"transmittance.enabled": False})
    rep = renderer.render(s)
    assert "ss_transmittance" in rep.names("pruned") or "ss_transmittance" not in rep.ran
    assert "ss_transmittance" not in rep.ran and "ss_lighting" in rep.ran
    on = backlit("ssss")
    renderer.render(on)
    with_tr = renderer.graph("ssss").read("lit")
    renderer.render(s)
    assert not np.array_equal(renderer.graph("ssss").read("lit"), with_tr)
