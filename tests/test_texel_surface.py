"""The texel surface map (issue 14, passes/texture_space.TexelSurfacePass): d'Eon's irradiance,
transmitted light and stretch shaded in one full-screen draw per texel from the mesh's attributes
rasterised once, instead of rasterising the mesh's small triangles every time. The same values as
the unwrap path up to float rounding, built once per mesh and size."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import small_settings

from skinviewer.ground.settings import with_values

MAPS = ("deon_irradiance", "deon_visibility", "deon_stretch", "deon_transmitted", "deon_diffuse", "lit")


def _maps(renderer, s):
    renderer.render(s)
    g = renderer.graph("deon")
    return {k: g.read(k).astype(np.float64) for k in MAPS if k in g.resources()}


@pytest.mark.parametrize("scene", ["head", "backlit-ear", "laser"])
def test_texel_surface_shades_what_the_unwrapped_mesh_shades(renderer, scene):
    base = small_settings(scene, "deon", 48)
    ref = _maps(renderer, with_values(base, {"render.texel_surface": False}))
    got = _maps(renderer, with_values(base, {"render.texel_surface": True}))
    assert set(got) == set(ref) and "deon_irradiance" in got
    if scene == "backlit-ear":
        assert "deon_transmitted" in got  # the TSM light's transmitted map took the texel path too
    for k, a in ref.items():
        b = got[k]
        assert np.isfinite(b).all(), k
        # the same inputs; only the texel-centre UV and the UV derivatives round differently (the
        # stretch within ~3e-5, which moves the blur taps of what is downstream of it by as much)
        tol = 1e-5 if k in ("deon_irradiance", "deon_stretch") else 1e-4
        if k == "deon_visibility":  # bilinear PCF: continuous in position, so it follows that rounding too
            tol = 2e-3
        if k == "lit":  # its specular reads deon_visibility: one float16 step of a value under 0.5 at most
            tol = 2.5e-4
        assert np.abs(a - b).max() <= tol * max(np.abs(a).max(), 1e-12), k


def test_texel_surface_is_built_once_per_mesh_and_size(renderer):
    s = small_settings("head", "deon", 48)
    rep = renderer.render(s, force=True)
    assert "deon_texel_surface" in rep.ran and "deon_irradiance" in rep.ran
    moved = with_values(s, {"lights.0.direction": (-0.3, 0.6, 0.8)})
    rep = renderer.render(moved)
    assert "deon_irradiance" in rep.ran and "deon_texel_surface" in rep.cached
    rep = renderer.render(with_values(moved, {"deon.irradiance_size": 512}))
    assert "deon_texel_surface" in rep.ran  # a new size is a new map
    off = renderer.render(with_values(s, {"render.texel_surface": False}))
    assert "deon_texel_surface" in off.pruned and "texel_surface_256_p" not in renderer.graph("deon").resources()


@pytest.mark.parametrize("radius_mode", ["printed", "mm"])
def test_gosselin_light_map_from_the_texel_surface(renderer, radius_mode):
    base = small_settings("head", "gosselin", 48, **{"gosselin.radius_mode": radius_mode})
    out = {}
    for on in (False, True):
        s = with_values(base, {"render.texel_surface": on})
        rep = renderer.render(s)
        g = renderer.graph("gosselin")
        out[on] = {k: g.read(k).astype(np.float64) for k in ("gosselin_light_map", "gosselin_stretch", "lit")
                   if k in g.resources()}
        assert ("gosselin_texel_surface" in rep.ran + rep.cached) == on
    for k, a in out[False].items():
        tol = 1e-5 if k == "gosselin_light_map" else 1e-4
        assert np.abs(a - out[True][k]).max() <= tol * max(np.abs(a).max(), 1e-12), k


@pytest.mark.parametrize("technique", ["deon", "gosselin"])
def test_gutter_and_seam_maps_from_the_texel_surface(renderer, technique):
    """With the texel surface map the gutter pass takes coverage and texel positions from it instead
    of two more rasters of the mesh: the gutter and seam maps are the same."""
    base = small_settings("head", technique, 48)
    out = {}
    for on in (False, True):
        s = with_values(base, {"render.texel_surface": on})
        renderer.render(s)
        renderer.scene.gpu.caches.texel_tables.clear()  # the CPU tables are rebuilt, not reused
        renderer.render(s, force=True)
        g = renderer.graph(technique)
        out[on] = {k: g.read(k) for k in g.resources() if k.startswith(("gutter_", "seam_"))}
    assert out[False] and set(out[False]) == set(out[True])
    for k, a in out[False].items():
        np.testing.assert_array_equal(a, out[True][k], err_msg=k)
