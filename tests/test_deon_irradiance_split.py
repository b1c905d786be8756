"""d'Eon's irradiance split in two (issue 27; notes/deon_light_move.md section 9): a light-independent pass
(deon_irradiance_surface.frag: the shading normal, C^mix, the specular parameters and the environment's
term, exact float32) that the graph keeps across light moves, and the light pass that reads them
(deon_irradiance_texels.frag, DEON_CACHED). The split renders the one-pass shader's textures bit for bit;
where it cannot apply (4 samples a texel, the mesh unwrapped) the one-pass shader runs."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import small_settings

import skinviewer.passes.deon as deon_passes
from skinviewer.ground.settings import default_rig, with_values
from skinviewer.passes.deon import VISIBILITY, irradiance_surface_resource
from skinviewer.physics.diffusion import IRRADIANCE

SURFACE = "deon_irradiance_surface"
RIG = [light.model_dump() for light in default_rig()]  # the studio environment (occluded) + a key light

CASES = {
    "default rig (environment)": {"lights": RIG},
    "three lights, a point light": {"lights.1.kind": "point", "lights.1.position": [0, 50, -300]},
    "a beam light": {"lights.0.kind": "beam", "lights.0.beam_radius": 20.0},
    "no energy conservation, environment": {"lights": RIG, "deon.energy_conservation": False, "deon.mix": 0.3},
    "texture shadows, unoccluded environment": {"lights": RIG, "deon.specular_shadows": "texture",
                                                "lights.1.occlusion": False},
    "4 samples a texel (one pass)": {"deon.texel_samples": 4},
    "the mesh unwrapped (one pass)": {"render.texel_surface": False},
}
ONE_PASS = {"4 samples a texel (one pass)", "the mesh unwrapped (one pass)"}


def _render(ctx, s, split: bool, monkeypatch) -> tuple[dict[str, np.ndarray], set[str]]:
    from skinviewer.engine.renderer import Renderer
    monkeypatch.setattr(deon_passes, "SPLIT_IRRADIANCE", split)
    r = Renderer(ctx)
    try:
        rep = r.render(s)
        g = r.graph("deon")
        names = {p.name for p in rep.passes if p.status == "ran"}
        return {k: g.read(k) for k in (IRRADIANCE, VISIBILITY, "lit") if k in g.resources()}, names
    finally:
        r.release()


@pytest.mark.parametrize("case", list(CASES))
def test_the_split_irradiance_is_the_one_pass_irradiance_bit_for_bit(gl_ctx, monkeypatch, case):
    s = small_settings("head", "deon", size=48, **{"deon.irradiance_size": 256}, **CASES[case])
    split, ran_split = _render(gl_ctx, s, True, monkeypatch)
    one, ran_one = _render(gl_ctx, s, False, monkeypatch)
    assert SURFACE not in ran_one
    assert (SURFACE in ran_split) == (case not in ONE_PASS), ran_split  # the fallbacks run the one-pass shader
    assert set(split) == set(one) and IRRADIANCE in split
    for k in one:
        assert split[k].tobytes() == one[k].tobytes(), (case, k, np.abs(split[k].astype(float) - one[k]).max())
    assert np.abs(split[IRRADIANCE][..., :3]).max() > 0  # lit: not two black maps


def _ran(rep) -> set[str]:
    return {p.name for p in rep.passes if p.status == "ran"}


def test_a_light_move_reruns_only_the_light_pass_and_what_it_reads_reruns_the_surface_pass(renderer, tmp_path):
    """The graph's run report: moving or recolouring the key light re-runs deon_irradiance, never the
    light-independent pass; the environment, deon.mix, the specular material, the albedo map and the map
    size re-run it (and the light pass after it)."""
    s = small_settings("head", "deon", size=32, lights=RIG, **{"deon.irradiance_size": 256})
    first = _ran(renderer.render(s))
    assert SURFACE in first and "deon_irradiance" in first
    g = renderer.graph("deon")
    assert all(irradiance_surface_resource(k) in g.resources() for k in range(3))  # with the environment's map
    for change in ({"lights.0.direction": [0.3, 0.2, 1.0]}, {"lights.0.intensity": 2.0},
                   {"lights.0.color": [1.0, 0.8, 0.7]}):
        ran = _ran(renderer.render(with_values(s, change)))
        assert "deon_irradiance" in ran and SURFACE not in ran, (change, ran)
        renderer.render(s)
    from PIL import Image
    albedo = tmp_path / "albedo.png"
    Image.fromarray(np.full((8, 8, 3), (200, 120, 90), np.uint8)).save(albedo)
    for change in ({"lights.1.intensity": 0.4}, {"lights.1.yaw": 40.0},  # the environment
                   {"deon.mix": 0.3}, {"specular.rho_s": 0.25}, {"specular.m": 0.4},  # the material
                   {"specular.f0": 0.04},  # the rho_dt table the environment's term is weighted with
                   {"scene.albedo_map": str(albedo)},  # a map
                   {"deon.irradiance_size": 512}):  # the map size
        ran = _ran(renderer.render(with_values(s, change)))
        assert SURFACE in ran and "deon_irradiance" in ran, (change, ran)
        renderer.render(s)


def test_without_an_environment_the_surface_pass_writes_two_maps_and_f0_leaves_it(renderer):
    s = small_settings("head", "deon", size=32, **{"deon.irradiance_size": 256})
    renderer.render(s)
    res = renderer.graph("deon").resources()
    assert irradiance_surface_resource(1) in res and irradiance_surface_resource(2) not in res
    ran = _ran(renderer.render(with_values(s, {"specular.f0": 0.04})))  # f0: the rho_dt table, read by the light only
    assert "deon_irradiance" in ran and SURFACE not in ran, ran


def test_the_switch_turns_the_split_off(monkeypatch):
    """SKINVIEWER_SPLIT_IRRADIANCE=0 (read at import) is the one-pass shader, for before | after runs."""
    import importlib
    import os
    import subprocess
    import sys
    code = "import skinviewer.passes.deon as d; print(d.SPLIT_IRRADIANCE)"
    env = {**os.environ, "SKINVIEWER_SPLIT_IRRADIANCE": "0"}
    root = importlib.util.find_spec("skinviewer").submodule_search_locations[0]
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                         cwd=os.path.dirname(root))
    assert out.stdout.strip() == "False"
