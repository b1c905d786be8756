"""The product promise "no NaN, no Inf, ever", tested beyond hand-picked cases: random settings
drawn across the whole valid range of the model (extremes included), every technique, every
built-in scene; every intermediate texture must stay finite. Seeded, so a failure reproduces."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import assert_all_finite, small_settings

from skinviewer import techniques
from skinviewer.ground.settings import REGIONS, SettingsError
from skinviewer.scene.scenes import SCENES

CASES_PER_TECHNIQUE = 10


def _logu(rng, lo, hi):
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _extreme(rng, lo, hi, p=0.25):
    """Mostly uniform, sometimes exactly an end of the range."""
    r = rng.random()
    if r < p / 2:
        return lo
    if r < p:
        return hi
    return float(rng.uniform(lo, hi))


def random_assignments(rng) -> dict:
    lights = []
    for _ in range(int(rng.integers(1, 5))):
        d = rng.normal(size=3)
        if rng.random() < 0.2:
            d = np.zeros(3)
            d[int(rng.integers(0, 3))] = rng.choice([-1.0, 1.0])  # axis-aligned, incl. straight up/down
        lights.append({
            "kind": str(rng.choice(["directional", "point", "beam"])),
            "direction": [float(x) for x in d] if np.linalg.norm(d) > 1e-6 else [0.0, 0.0, 1.0],
            "position": [float(x) for x in rng.normal(scale=rng.choice([1.0, 100.0, 1e4]), size=3)],
            "intensity": 0.0 if rng.random() < 0.1 else _logu(rng, 1e-3, 1e6),
            "color": [float(x) for x in rng.random(3) * rng.choice([1.0, 10.0])],
            "beam_radius": _logu(rng, 1e-3, 50.0),
            "cast_shadow": bool(rng.random() < 0.7),
            "enabled": bool(rng.random() < 0.9),
        })
    if not any(l["enabled"] for l in lights):
        lights[0]["enabled"] = True
    k = int(rng.integers(1, 9))
    gaussians = [{"variance": 0.0 if rng.random() < 0.1 else _logu(rng, 1e-4, 100.0),
                  "weights": [float(x) for x in rng.random(3) * rng.choice([0.0, 1.0, 2.0])]} for _ in range(k)]
    a = {
        "lights": lights,
        "camera.yaw": float(rng.uniform(-720, 720)),
        "camera.pitch": _extreme(rng, -89.0, 89.0),
        "camera.fov_y": _extreme(rng, 5.0, 120.0),
        "shadow.tol": _extreme(rng, 0.0, 0.5),
        "shadow.pcf": int(rng.integers(0, 4)),
        "render.exposure": _logu(rng, 1e-3, 1e3),
        "specular.m": _extreme(rng, 0.0, 1.0),
        "specular.f0": _extreme(rng, 0.0, 1.0),
        "specular.rho_s": _extreme(rng, 0.0, 10.0),
        "specular.mode": str(rng.choice(["direct", "beckmann_lut"])),
        "specular.lut_size": int(rng.choice([16, 64, 256])),
        "phong.shininess": _extreme(rng, 1.0, 4096.0),
        "gosselin.iterations": int(rng.integers(0, 9)),
        "gosselin.scale_x": 0.0 if rng.random() < 0.15 else _logu(rng, 1e-3, 1000.0),
        "gosselin.scale_y": _extreme(rng, 0.0, 50.0),
        "gosselin.specular_shadow": str(rng.choice(["visibility", "printed"])),
        "deon.gaussians": gaussians,
        "deon.mix": _extreme(rng, 0.0, 1.0),
        "deon.stretch": bool(rng.random() < 0.7),
        "deon.stretch_per_gaussian": bool(rng.random() < 0.3),
        "deon.tsm": bool(rng.random() < 0.7),
        "deon.tsm_form": str(rng.choice(["exact", "printed"])),
        "deon.energy_conservation": bool(rng.random() < 0.7),
        "deon.reuse_irradiance_below_texels": _extreme(rng, 0.0, 8.0),
    }
    region = str(rng.choice(REGIONS))
    a[f"specular.per_region.{region}"] = {"m": _extreme(rng, 0.0, 1.0), "rho_s": _extreme(rng, 0.0, 10.0)}
    a[f"gosselin.regions.{region}"] = {"kernel_size": _extreme(rng, 0.0, 1000.0), "scale_x": 1.0, "scale_y": 0.0}
    return a


@pytest.mark.parametrize("technique", ["phong", "gosselin", "deon"])
def test_random_settings_never_produce_non_finite_texels(renderer, technique):
    assert technique in techniques.names()
    rng = np.random.default_rng(20261121 + ["phong", "gosselin", "deon"].index(technique))
    for case in range(CASES_PER_TECHNIQUE):
        scene = str(rng.choice(SCENES))
        a = random_assignments(rng)
        try:
            s = small_settings(scene, technique, size=48, **{"shadow.map_size": 128, "gosselin.light_map_size": 256,
                                                            "deon.irradiance_size": 256, "deon.tsm_size": 128}, **a)
        except SettingsError as exc:  # the generator stays inside the model's ranges
            raise AssertionError(f"case {case}: generated invalid settings: {exc}") from None
        try:
            renderer.render(s)
            assert_all_finite(renderer, s)
        except AssertionError as exc:
            raise AssertionError(f"{technique} case {case} on {scene}: {exc}\nsettings: {a}") from None
