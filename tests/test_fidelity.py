"""Texture-space fidelity (issue 10): the beam light integrated over each texel's footprint, ..."""
from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import small_settings

from skinviewer.physics import accuracy as A
from skinviewer.scene.scenes import build_scene

# ---------------------------------------------------------------------------------------------
# item 5: the laser beam keeps its power at every map size


def _beam_power_ratio(renderer, scene, tech, n, offset=(0.0, 0.0), radius=0.02):
    key = "deon.irradiance_size" if tech == "deon" else "gosselin.light_map_size"
    res = "deon_irradiance" if tech == "deon" else "gosselin_light_map"
    s = small_settings(scene, tech, 32, **{key: n, "deon.energy_conservation": False,
                                           "lights.0.position": [offset[0], offset[1], 0.0],
                                           "lights.0.beam_radius": radius})
    renderer.render(s)
    E = renderer.graph(tech).read(res)[..., :3].astype(np.float64)
    m = build_scene(scene).mesh
    _, _, area = A.plane_coords(m.positions, m.uvs, m.mm_per_unit, n)
    L = s.lights[0]
    return E.sum((0, 1)) * area / (math.pi * radius ** 2 * L.intensity)


@pytest.mark.parametrize("n", [256, 512, 1024])
@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.013, -0.007)])
def test_laser_power_at_every_map_size(renderer, n, offset):
    # the 0.02 mm beam at the slab's centre hits a texel corner: point-sampled it lit nothing at
    # 256^2 and 512^2 and carried 1.9x its power at 1024^2
    for tech in ("deon", "gosselin"):
        ratio = _beam_power_ratio(renderer, "laser", tech, n, offset)
        assert np.allclose(ratio, 1.0, atol=0.01), (tech, n, offset, ratio)


def test_beam_power_on_stretched_texels_and_wide_beams(renderer):
    # 4:1 texel footprints (stretch-plane), and a beam wider than many texels
    assert np.allclose(_beam_power_ratio(renderer, "stretch-plane", "deon", 256, (0.011, 0.03)), 1.0, atol=0.01)
    assert np.allclose(_beam_power_ratio(renderer, "laser", "deon", 256, (0.3, -0.2), radius=1.3), 1.0, atol=0.01)
