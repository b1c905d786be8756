"""d'Eon's final pass split in two (issue 27; notes/deon_light_move.md section 15): a view pass
(deon_final.frag with DEON_FINAL_PART = 1: the shading normal, the specular parameters, C^(1-mix) rho_dt(N.V),
the environment's specular and translucency as exact float32 per pixel) that the graph keeps across light
moves, and the light pass (DEON_FINAL_PART = 2) that adds the lights to them. The split renders the one-pass
shader's image bit for bit; SKINVIEWER_SPLIT_FINAL=0 (and every light off) runs the one-pass shader."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import small_settings

import skinviewer.passes.deon as deon_passes
from skinviewer.ground.settings import default_rig, with_values
from skinviewer.passes.deon import final_view_resource

VIEW = "deon_final_view"
ROLES = ("n", "f", "p", "s", "e", "x", "nrm")
RIG = [light.model_dump() for light in default_rig()]  # the studio environment (occluded) + a key light

CASES = {
    "default rig (environment)": {"lights": RIG},
    "default rig, no translucency (deon.tsm off)": {"lights": RIG, "deon.tsm": False},
    "three lights, a point light": {"lights.1.kind": "point", "lights.1.position": [0, 50, -300]},
    "two lights": {"lights.2.enabled": False},
    "a beam light": {"lights.0.kind": "beam", "lights.0.beam_radius": 20.0},
    "energy off, environment, mix 0.3": {"lights": RIG, "deon.energy_conservation": False, "deon.mix": 0.3},
    "back faces shown": {"lights": RIG, "scene.back_faces": "show"},
    "texture shadows, unoccluded environment, Beckmann LUT": {
        "lights": RIG, "deon.specular_shadows": "texture", "lights.1.occlusion": False,
        "specular.mode": "beckmann_lut"},
    "the blurs read per pixel (combine off)": {"deon.combine_blurs": False},
    "shadow maps in the specular, a point light": {"lights": RIG, "deon.specular_shadows": "pixel",
                                                    "lights.0.kind": "point", "lights.0.position": [0, 50, 300]},
}


def _render(ctx, s, split: str, monkeypatch) -> tuple[np.ndarray, set[str]]:
    from skinviewer.engine.renderer import Renderer
    monkeypatch.setattr(deon_passes, "SPLIT_FINAL", split)
    r = Renderer(ctx)
    try:
        rep = r.render(s)
        g = r.graph("deon")
        maps = {k for k in ROLES if final_view_resource(k) in g.resources()}
        return g.read("lit"), {p.name for p in rep.passes if p.status == "ran"} | {f"map_{k}" for k in maps}
    finally:
        r.release()


@pytest.mark.parametrize("case", list(CASES))
def test_the_split_final_pass_is_the_one_pass_image_bit_for_bit(gl_ctx, monkeypatch, case):
    s = small_settings("head", "deon", size=64, **{"deon.irradiance_size": 256}, **CASES[case])
    split, ran_split = _render(gl_ctx, s, "1", monkeypatch)
    one, ran_one = _render(gl_ctx, s, "0", monkeypatch)
    assert VIEW in ran_split and VIEW not in ran_one, (ran_split, ran_one)
    if case == "default rig (environment)":  # the environment's specular and translucency maps, full-screen
        assert {"map_e", "map_x", "map_p"} <= ran_split and not {"map_nrm", "map_s"} & ran_split, ran_split
    if case == "three lights, a point light":  # no environment: rho_s in a map of its own
        assert "map_s" in ran_split and "map_e" not in ran_split, ran_split
    if "beam" in case:  # the light part over the mesh (a beam's footprint is the mesh's dFdx)
        assert "map_p" not in ran_split, ran_split
    if "shadow maps" in case or "combine off" in case:  # the light part reads the vertex normal
        assert "map_nrm" in ran_split, ran_split
    assert split.tobytes() == one.tobytes(), (case, np.abs(split.astype(float) - one).max())
    assert np.abs(split[..., :3]).max() > 0  # lit: not two black images


def _ran(rep) -> set[str]:
    return {p.name for p in rep.passes if p.status == "ran"}


@pytest.fixture
def split_on(monkeypatch):
    monkeypatch.setattr(deon_passes, "SPLIT_FINAL", "1")


def test_a_light_move_reruns_only_the_light_part_and_a_camera_move_both(split_on, renderer, tmp_path):
    """The graph's run report: moving or recolouring the key light re-runs deon_final, never the view pass;
    the camera, the environment, deon.mix, the specular material (f0: the rho_dt tables), the albedo map and
    the back faces re-run
    it (and the light pass after it)."""
    s = small_settings("head", "deon", size=32, lights=RIG, **{"deon.irradiance_size": 256})
    first = _ran(renderer.render(s))
    assert VIEW in first and "deon_final" in first
    g = renderer.graph("deon")
    assert all(final_view_resource(k) in g.resources() for k in "nfe"), sorted(g.resources())  # + the environment
    for change in ({"lights.0.direction": [0.3, 0.2, 1.0]}, {"lights.0.intensity": 2.0},
                   {"lights.0.color": [1.0, 0.8, 0.7]}):
        ran = _ran(renderer.render(with_values(s, change)))
        assert "deon_final" in ran and VIEW not in ran, (change, ran)
        renderer.render(s)
    from PIL import Image
    albedo = tmp_path / "albedo.png"
    Image.fromarray(np.full((8, 8, 3), (200, 120, 90), np.uint8)).save(albedo)
    for change in ({"camera.yaw": 30.0}, {"camera.distance": 400.0},  # the camera
                   {"lights.1.intensity": 0.4}, {"lights.1.yaw": 40.0},  # the environment
                   {"deon.mix": 0.3}, {"specular.rho_s": 0.25}, {"specular.m": 0.4},  # the material
                   {"specular.f0": 0.04},  # the rho_dt tables (rho_dt(N.V), the environment's albedo)
                   {"scene.albedo_map": str(albedo)},  # a map
                   {"scene.back_faces": "show"}):
        ran = _ran(renderer.render(with_values(s, change)))
        assert VIEW in ran and "deon_final" in ran, (change, ran)
        renderer.render(s)


def test_without_an_environment_the_view_pass_writes_two_maps(split_on, renderer):
    s = small_settings("head", "deon", size=32, **{"deon.irradiance_size": 256})
    assert VIEW in _ran(renderer.render(s))
    res = renderer.graph("deon").resources()
    assert final_view_resource("f") in res and final_view_resource("e") not in res


def test_every_light_off_and_the_switch_fall_back_to_the_one_pass_shader(gl_ctx, monkeypatch):
    s = small_settings("head", "deon", size=32, **{"deon.irradiance_size": 256})
    dark = with_values(s, {f"lights.{i}.enabled": False for i in range(len(s.lights))})
    img, ran = _render(gl_ctx, dark, "1", monkeypatch)
    assert VIEW not in ran and "deon_final" in ran and not img[..., :3].any()
    _, ran = _render(gl_ctx, s, "0", monkeypatch)
    assert VIEW not in ran and "deon_final" in ran


def test_auto_splits_on_a_software_rasterizer_only(gl_ctx, monkeypatch):
    from skinviewer.kernel.gl import software_renderer
    s = small_settings("head", "deon", size=32, **{"deon.irradiance_size": 256})
    _, ran = _render(gl_ctx, s, "auto", monkeypatch)
    assert (VIEW in ran) == software_renderer(gl_ctx)


def test_the_switch_is_read_from_the_environment():
    """SKINVIEWER_SPLIT_FINAL=0 (read at import) is the one-pass shader, for before | after runs."""
    import importlib
    import os
    import subprocess
    import sys
    code = "import skinviewer.passes.deon as d; print(d.SPLIT_FINAL)"
    env = {**os.environ, "SKINVIEWER_SPLIT_FINAL": "0"}
    root = importlib.util.find_spec("skinviewer").submodule_search_locations[0]
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                         cwd=os.path.dirname(root))
    assert out.stdout.strip() == "0"
