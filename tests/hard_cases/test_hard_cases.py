"""Issue 13's named hard-case suite: every case of ``cases.py`` through every technique of the
registry (``techniques.names()``, so techniques added later are covered), at tiny sizes. For each
frame: every texture the graph holds is finite; every texture that carries light or a weight is
non-negative; a texture-space blur never makes a texel brighter than its input's brightest
(seed 000 eq. 21: a normalised kernel only moves light); a diffuse-only lit image is never brighter than the lights."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cases import CASES, DIFFUSE_ONLY  # noqa: E402
from meshes import make  # noqa: E402

from skinviewer import techniques  # noqa: E402
from skinviewer.ground.settings import Settings, with_values  # noqa: E402
from skinviewer.scene.scenes import scene_overrides  # noqa: E402

TINY = {"render.width": 24, "render.height": 24, "scene.head_detail": 0, "shadow.map_size": 64,
        "gosselin.light_map_size": 256, "deon.irradiance_size": 256, "deon.tsm_size": 64,
        "specular.lut_size": 16}

# resources that legitimately hold signed values (not light): gutter and seam maps store texel
# coordinates; the TSM stores light-space position and depth (seed 000 eq. 32); stretch maps hold the
# shear cosine in B; the Burley statistics texture flags skipped pixels with -1
SIGNED_PREFIXES = ("gutter", "seam", "deon_tsm", "deon_stretch", "stretch", "burley_stats", "texel_surface",
                   "deon_gather_surface", "deon_gather_blocks", "deon_border",  # deon_border: signed distances
                   # the summed step's kept weights: < 0 past a mesh border, -1 a block not summed (sign-coded)
                   "deon_gather_w",
                   # the irradiance's light-independent map 0: the shading normal N (xyz) and m
                   "deon_irradiance_surface_0",
                   # d'Eon's kept view maps (the final pass split): the shading normal N, the fragment's
                   # position, the vertex normal; the light's terms (e, x) and the factor (f) stay checked
                   "deon_final_view_n", "deon_final_view_p", "deon_final_view_nrm",
                   # Penner's environment: the scattered lobe's SH band factors (lambda_l / lambda_0), signed
                   # where a wide profile flattens the lobe (band 2 past zero); the irradiance made from
                   # them is clamped at 0 (lib/environment.glsl env_irradiance_scattered)
                   "penner_env_bands")
# inputs and outputs of a blur that are not light (lookup tables, geometry, statistics)
NOT_LIGHT_PREFIXES = SIGNED_PREFIXES + ("ss_depth", "rho_dt", "beckmann")


@pytest.fixture(scope="module")
def mesh_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("hard_meshes")


def case_settings(name: str, technique: str, mesh_dir: Path) -> Settings:
    scene, assign = CASES[name]
    values = dict(TINY)
    if scene.startswith("mesh:"):
        values.update({"scene.mesh": str(make(scene[5:], mesh_dir)), "scene.mm_per_unit": 1.0,
                       "camera.yaw": 0.0, "camera.pitch": 0.0})
    else:
        values.update({"scene.name": scene, **scene_overrides(scene)})
    values.update(assign)
    values["technique"] = technique
    return with_values(Settings(), values)


def _check_frame(renderer, s: Settings, report) -> list[str]:
    g = renderer.graph(s.technique)
    problems = []
    tex = {}
    for res in g.resources():
        a = g.read(res)
        tex[res] = a
        if not np.all(np.isfinite(a)):
            problems.append(f"{res}: {int((~np.isfinite(a)).sum())} non-finite values")
        elif not res.startswith(SIGNED_PREFIXES) and a.min() < -1e-6:
            problems.append(f"{res}: negative values (min {a.min():.3g})")
    if report.nonfinite:
        problems.append(f"frame report flags non-finite outputs: {report.nonfinite}")
    # energy: a blur is a convex combination of its source's texels (normalised kernel, weights
    # renormalised over covered texels at island borders), so no output texel is brighter, per
    # channel, than the brightest texel of its source (the first declared input): a blur never
    # makes light. (Its mean may rise slightly where renormalisation at a border reuses interior
    # light: that is the kernel's known edge behaviour, not energy from nowhere.)
    refl = g._last_refl
    for p in g.order:
        if "blur" not in p.name or p.name not in refl:
            continue
        r = refl[p.name]
        src = next((i for i in r.inputs if not i.startswith(NOT_LIGHT_PREFIXES)), None)  # the light it blurs
        for out in r.outputs:
            if out.startswith(NOT_LIGHT_PREFIXES):
                continue
            if src in tex and out in tex and np.all(np.isfinite(tex[src])):
                e_in = tex[src][..., :3].max(axis=(0, 1))
                e_out = tex[out][..., :3].max(axis=(0, 1))
                if np.any(e_out > e_in * 1.002 + 1e-6):
                    problems.append(f"{p.name}: {out} max {e_out} exceeds its input {src}'s {e_in}")
    return problems


def _diffuse_bound(s: Settings) -> float:
    """Largest radiance a diffuse-only frame can show: every enabled light's Lc at normal incidence,
    times the largest per-channel Gaussian weight sum (d'Eon) or 1, times 2 (front light plus
    translucency through a thin part), with albedo <= 1."""
    lc = sum(l.intensity * max(l.color) for l in s.lights if l.enabled)
    w = max(1.0, max(sum(g.weights[c] for g in s.deon.gaussians) for c in range(3)))
    return lc * w * 2.0 * 1.02 + 1e-4


# Light loss against Phong on the diffuse-only cases: a technique's normalised kernels move light, so its
# mean radiance is Phong's (Lambert, same lights and albedo): measured 1.00-1.03 (penner 1.028) at these
# sizes; the band is 3x that, below the 17 % of an albedo factor taken twice. Known losses (found by this
# check, issue 36; the entry must go when fixed): at huge intensity Gosselin keeps 39 % and d'Eon 63 % of
# Phong's light (likely their half-float maps saturating at 65504; not investigated here).
ENERGY_BAND = (0.9, 1.1)
KNOWN_LIGHT_LOSS = {("huge-intensity", "gosselin"), ("huge-intensity", "deon")}


@pytest.mark.parametrize("name", sorted(CASES))
def test_hard_case(renderer, mesh_dir, name):
    failures = []
    means: dict[str, float] = {}
    for technique in techniques.names():
        s = case_settings(name, technique, mesh_dir)
        report = renderer.render(s)
        problems = _check_frame(renderer, s, report)
        if name in DIFFUSE_ONLY:
            lit = renderer.read(s, "lit")[..., :3]
            means[technique] = float(lit.astype(np.float64).mean())
            if lit.max() > _diffuse_bound(s):
                problems.append(f"lit max {lit.max():.4g} above the lights' {_diffuse_bound(s):.4g}")
        failures += [f"{technique}: {p}" for p in problems]
    renderer.trim()
    if means.get("phong", 0.0) > 0.0:
        for technique, mean in means.items():
            ratio = mean / means["phong"]
            if (name, technique) in KNOWN_LIGHT_LOSS:
                if ratio >= ENERGY_BAND[0]:
                    failures.append(f"{technique}: no longer loses light ({ratio:.3f} of Phong): remove it from "
                                    "KNOWN_LIGHT_LOSS")
            elif not ENERGY_BAND[0] <= ratio <= ENERGY_BAND[1]:
                failures.append(f"{technique}: mean radiance {ratio:.3f} of Phong's (light "
                                f"{'lost' if ratio < 1 else 'made'})")
    assert not failures, f"{name}: " + "; ".join(failures)


def test_light_loss_check_has_cases():
    """The energy comparison runs on at least two diffuse-only cases with Phong in the registry."""
    assert len(DIFFUSE_ONLY) >= 2 and "phong" in techniques.names()


def test_the_suite_is_large_enough():
    assert len(CASES) >= 40
    assert len(techniques.names()) >= 3
