"""Per-region Kelemen/Szirmay-Kalos parameters (specular.per_region) in every skin technique:
one GLSL snippet (shaders/lib/specular_params.glsl) serves Gosselin and d'Eon alike."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import small_settings

from skinviewer.ground.settings import with_values


def _lit_halves(renderer, s):
    renderer.render(s)
    lit = renderer.read(s, "lit")[..., :3]
    h, w = lit.shape[:2]
    # the plane's left half is region "cheeks" (x < 0), the right half "ears"; rows of the plane's
    # lower half (GL order: row 0 at the bottom), below the blade that hangs over y > 0
    rows = slice(h // 8, 3 * h // 8)
    return lit[rows, w // 8: 3 * w // 8], lit[rows, 5 * w // 8: 7 * w // 8]


@pytest.mark.parametrize("technique", ["gosselin", "deon"])
def test_region_without_specular_loses_only_its_highlight(renderer, technique):
    base = small_settings("regions-plane", technique, size=96, **{
        "camera.yaw": 0.0, "camera.pitch": 0.0, "camera.distance": 110.0,
        "lights.0.direction": [0.0, 0.0, 1.0], "specular.m": 0.35, "specular.rho_s": 0.5})
    left0, right0 = _lit_halves(renderer, base)
    dull = with_values(base, {"specular.per_region.ears": {"rho_s": 0.0}})
    left1, right1 = _lit_halves(renderer, dull)
    assert np.allclose(left0, left1, atol=2e-3), "the cheeks' specular must not change"
    # the ears lose their highlight (~3 % of the light at normal incidence, F0 = 0.028); with
    # d'Eon's energy conservation that energy goes to the diffuse instead (rho_dt -> 1)
    assert abs(right1.mean() - right0.mean()) > 0.01
    if technique == "gosselin":
        assert right1.mean() < right0.mean()
    # and the m of a region changes its highlight's shape, not its neighbour's
    rough = with_values(base, {"specular.per_region.ears": {"m": 0.9}})
    left2, right2 = _lit_halves(renderer, rough)
    assert np.allclose(left0, left2, atol=2e-3)
    assert np.abs(right2 - right0).max() > 1e-3


def test_rho_dt_follows_the_region_rho_s(renderer):
    """eq. 30 is linear in rho_s: a region with rho_s = 0 has rho_dt = 1 (all light enters the skin)."""
    base = small_settings("regions-plane", "deon", size=64, **{
        "lights.0.direction": [0.3, 0.0, 1.0], "specular.rho_s": 1.0, "deon.tsm": False})
    renderer.render(base)
    irr0 = renderer.read(base, "deon_irradiance")
    s = with_values(base, {"specular.per_region.ears": {"rho_s": 0.0}})
    renderer.render(s)
    irr1 = renderer.read(s, "deon_irradiance")
    region = renderer.scene.gpu.region_ids
    n = irr0.shape[0]
    ids = region[(np.arange(n) * region.shape[0] // n)][:, (np.arange(n) * region.shape[1] // n)]
    from skinviewer.ground.settings import REGIONS
    ears, cheeks = ids == REGIONS.index("ears"), ids == REGIONS.index("cheeks")
    ratio = irr1[..., 0][ears].mean() / irr0[..., 0][ears].mean()
    assert ratio > 1.01  # energy the specular no longer takes goes to the diffuse
    assert np.allclose(irr1[..., 0][cheeks], irr0[..., 0][cheeks], rtol=1e-5)


def test_per_region_tables_override_only_the_regions_that_set_a_value():
    """physics/specular.per_region_specular: the (m, rho_s) tables the lit passes upload and the ground
    truth indexes by region ID. A region that sets only m keeps the global rho_s, a region that sets
    nothing keeps both, and the IDs follow ground.constants.REGIONS."""
    from skinviewer.ground.constants import REGIONS
    from skinviewer.ground.settings import Settings
    from skinviewer.physics.specular import per_region_specular
    sp = with_values(Settings(), {"specular.m": 0.4, "specular.rho_s": 0.1,
                                  "specular.per_region": {"nose": {"m": 0.2}, "lips": {"rho_s": 0.3}}}).specular
    m, rho = per_region_specular(sp)
    assert m.dtype == rho.dtype == np.float32 and m.shape == rho.shape == (len(REGIONS),)
    want_m = np.full(len(REGIONS), 0.4)
    want_m[REGIONS.index("nose")] = 0.2
    want_rho = np.full(len(REGIONS), 0.1)
    want_rho[REGIONS.index("lips")] = 0.3
    np.testing.assert_allclose(m, want_m, rtol=1e-6)
    np.testing.assert_allclose(rho, want_rho, rtol=1e-6)
