"""The named hard cases (issue 13): settings + scene combinations that stress the numerics. Each is
run through every technique of the registry by ``test_hard_cases.py``.

A case is (scene, assignments) where scene is a built-in scene name or ``mesh:<kind>`` (a mesh
written by ``meshes.py``). Sizes are kept tiny by the test; a case may raise them."""
from __future__ import annotations

from skinviewer.passes.deon import MAX_GAUSSIANS

SKIN6 = [(0.0064, (0.233, 0.455, 0.649)), (0.0484, (0.100, 0.336, 0.344)), (0.187, (0.118, 0.198, 0.0)),
         (0.567, (0.113, 0.007, 0.007)), (1.99, (0.358, 0.004, 0.0)), (7.41, (0.078, 0.0, 0.0))]


def _g(table):
    return [{"variance": v, "weights": list(w)} for v, w in table]


def _light(**kw):
    base = {"kind": "directional", "direction": [0.3, 0.4, 1.0], "intensity": 1.5, "color": [1, 1, 1],
            "cast_shadow": True, "enabled": True}
    base.update(kw)
    return base


NO_SPECULAR = {"specular.rho_s": 0.0, "phong.specular": 0.0, "phong.ambient": 0.0}

CASES: dict[str, tuple[str, dict]] = {
    # light direction
    "grazing-light-on-plane": ("shadow-edge", {"lights": [_light(direction=[1.0, 0.0, 1e-3])]}),
    "grazing-light-on-head": ("head", {"lights": [_light(direction=[1.0, 1e-4, 0.0])], "camera.yaw": 0.0}),
    "light-straight-up": ("head", {"lights": [_light(direction=[0.0, 1.0, 0.0])]}),
    "light-straight-down": ("stretch-plane", {"lights": [_light(direction=[0.0, -1.0, 0.0])]}),
    "light-exactly-behind-thin-flap": ("backlit-ear", {"lights": [_light(direction=[0.0, 0.0, -1.0])]}),
    "point-light-behind-thin-flap": ("backlit-ear", {"lights": [_light(kind="point", position=[0.0, 0.0, -8.0])]}),
    "light-inside-the-mesh": ("head", {"lights": [_light(kind="point", position=[0.0, 0.0, 0.0])]}),
    "point-light-very-far": ("head", {"lights": [_light(kind="point", position=[1e9, 1e9, 1e9])]}),
    "coincident-lights": ("head", {"lights": [_light(), _light(), _light(), _light()]}),
    "coincident-point-lights-on-surface": ("laser", {"lights": [_light(kind="point", position=[0, 0, 0])] * 2}),
    "all-lights-disabled": ("head", {"lights": [_light(enabled=False)]}),
    "zero-intensity": ("head", {"lights": [_light(intensity=0.0)]}),
    "huge-intensity": ("head", {"lights": [_light(intensity=1e6)], **NO_SPECULAR}),
    "black-light-colour": ("head", {"lights": [_light(color=[0, 0, 0])]}),
    "tiny-beam": ("laser", {"lights.0.beam_radius": 1e-3}),
    "huge-beam": ("laser", {"lights.0.beam_radius": 1e6}),
    # diffusion profile (seed 000 eq. 20-35)
    "zero-variances": ("head", {"deon.gaussians": _g([(0.0, (0.5, 0.5, 0.5)), (0.0, (0.5, 0.5, 0.5))])}),
    "huge-variances": ("head", {"deon.gaussians": _g([(1e4, (1, 1, 1))])}),
    "zero-and-huge-variance": ("laser", {"deon.gaussians": _g([(0.0, (0.5, 0.5, 0.5)), (1e4, (0.5, 0.5, 0.5))])}),
    "all-zero-weights": ("head", {"deon.gaussians": _g([(0.1, (0, 0, 0)), (1.0, (0, 0, 0))])}),
    "one-gaussian": ("backlit-ear", {"deon.gaussians": _g([(0.5, (1, 1, 1))])}),
    "max-gaussians": ("head", {"deon.gaussians": _g([(0.001 * 4 ** i, (1 / MAX_GAUSSIANS,) * 3)
                                                     for i in range(MAX_GAUSSIANS)])}),
    "descending-variances": ("head", {"deon.gaussians": _g(list(reversed(SKIN6)))}),
    "weights-summing-to-one-per-channel-diffuse-only": ("head", {"deon.gaussians": _g(
        [(0.05, (0.5, 0.5, 0.5)), (1.0, (0.5, 0.5, 0.5))]), **NO_SPECULAR}),
    "mix-0-no-tsm-no-stretch": ("head", {"deon.mix": 0.0, "deon.tsm": False, "deon.stretch": False}),
    "mix-1-stretch-per-gaussian": ("stretch-plane", {"deon.mix": 1.0, "deon.stretch_per_gaussian": True}),
    "tsm-printed-no-energy-conservation": ("backlit-ear", {"deon.tsm_form": "printed",
                                                            "deon.energy_conservation": False}),
    # specular (seed 000 eq. 14-16)
    "f0-zero": ("head", {"specular.f0": 0.0}),
    "f0-one": ("head", {"specular.f0": 1.0, "specular.rho_s": 10.0}),
    "m-zero": ("head", {"specular.m": 0.0}),
    "m-one": ("head", {"specular.m": 1.0}),
    "m-zero-beckmann-lut-16": ("head", {"specular.m": 0.0, "specular.mode": "beckmann_lut", "specular.lut_size": 16}),
    "per-region-m-limits": ("regions-plane", {"specular.per_region.cheeks": {"m": 0.0, "rho_s": 10.0},
                                              "specular.per_region.nose": {"m": 1.0, "rho_s": 0.0}}),
    "phong-shininess-limits": ("head", {"phong.shininess": 4096.0}),
    # Gosselin kernels (seed 000 eq. 8-19)
    "gosselin-zero-iterations": ("head", {"gosselin.iterations": 0}),
    "gosselin-many-iterations-huge-kernel": ("head", {"gosselin.iterations": 16, "gosselin.scale_x": 1000.0}),
    "gosselin-zero-kernel": ("regions-plane", {"gosselin.scale_x": 0.0, "gosselin.scale_y": 0.0,
                                               "gosselin.regions.cheeks": {"kernel_size": 0.0}}),
    # shadows
    "shadow-tol-zero-pcf-max": ("shadow-edge", {"shadow.tol": 0.0, "shadow.pcf": 3}),
    "shadow-tol-max": ("shadow-edge", {"shadow.tol": 0.5, "shadow.pcf": 0}),
    # geometry
    "degenerate-triangles": ("mesh:degenerate", {}),
    "sliver-triangles": ("mesh:sliver", {}),
    "one-texel-uv-islands": ("mesh:one-texel-islands", {}),
    "mesh-at-1e-3-mm": ("mesh:plane-1e-3", {"scene.mm_per_unit": 1.0}),
    "mesh-at-1e4-mm": ("mesh:plane-1e4", {"scene.mm_per_unit": 1.0}),
    "thin-flap-mesh-backlit": ("mesh:flap", {"lights": [_light(direction=[0.0, 0.0, -1.0])]}),
    # camera and image
    "image-min-16x16": ("head", {"render.width": 16, "render.height": 16}),
    "image-8192x64": ("head", {"render.width": 8192, "render.height": 64}),
    "camera-pitch-limits": ("head", {"camera.pitch": 89.0, "camera.fov_y": 169.0}),
    "camera-inside-the-mesh": ("head", {"camera.distance": 1e-3, "camera.fov_y": 1.01}),
    "exposure-limits": ("head", {"render.exposure": 1e4}),
}

# cases whose diffuse output is bounded by the light: no specular, no ambient (energy check on "lit")
DIFFUSE_ONLY = {name for name, (_, a) in CASES.items() if all(a.get(k) == v for k, v in NO_SPECULAR.items())}
