"""The environment light (issue 32) as every technique's lit passes read it (shaders/lib/environment.glsl):
``EnvironmentPass`` makes the pre-filtered specular environment and the rho_dt table it is weighted
with; ``declare_environment`` / ``set_environment`` declare and set what a lit program reads (the
SH irradiance coefficients as uniforms, the baked per-vertex visibility as a vertex attribute or a
texel surface map). Nothing here runs without an environment light."""
from __future__ import annotations

import functools
import math

import numpy as np

from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, declare, whole
from skinviewer.passes.rules import environment_light
from skinviewer.physics import environment as env
from skinviewer.scene.environment import environment_image

ENV_PREFILTERED = "env_prefiltered"
ENV_RHO_DT = "env_rho_dt"
ENV_BACKGROUND = "env_background"  # the environment at BACKGROUND_SIZE for render.background_environment = sharp
BACKGROUND_SIZE = (1024, 512)
BACKGROUND_BLUR_LEVEL = 1  # the pre-filtered level (m = 0.15) render.background_environment = blurred shows


def declare_env_fields(e):
    """Declare every field of the environment light ``e`` (``r.settings.lights[i]``) that
    shaders/lib/environment.glsl and the bake read; returns ``e``."""
    declare(e.kind, e.environment, e.layout, e.yaw, e.sh_order, e.occlusion, e.ao_rays, e.transfer_order, e.color,
            e.intensity, e.enabled)
    return e


def env_index(r) -> int | None:
    """The settings index of the environment light in use (peeked: the graph's shape), or None."""
    hit = environment_light(whole(r.peeked.lights))
    return None if hit is None else hit[0]


@functools.lru_cache(maxsize=4)
def _prefiltered(spec: str, layout: str) -> np.ndarray:
    """The pre-filtered levels as RGBA, cached on disk by the image's content (the pre-filter takes
    seconds: the default rig's first frame would wait for it at every start)."""
    import hashlib
    import io

    from skinviewer.ground.files import atomic_write_bytes
    from skinviewer.ground.paths import cache_dir
    img = environment_image(spec, layout)
    h = hashlib.sha1(b"envprefilter1")
    h.update(repr((img.shape, env.SPEC_SIZE, tuple(env.SPEC_LEVELS_M))).encode())
    h.update(np.ascontiguousarray(img, np.float32).tobytes())
    path = cache_dir() / "envprefilter" / f"{h.hexdigest()}.npy"
    w, hh = env.SPEC_SIZE
    try:
        rgba = np.load(path, allow_pickle=False)
        if rgba.shape[1:] == (w, 4) and rgba.shape[0] == hh * len(env.SPEC_LEVELS_M) and np.all(np.isfinite(rgba)):
            return np.ascontiguousarray(rgba, np.float32)
    except (OSError, ValueError):
        pass
    pre = env.prefilter_specular(img)
    rgba = np.ascontiguousarray(np.concatenate([pre, np.ones(pre.shape[:2] + (1,), np.float32)], 2), np.float32)
    buf = io.BytesIO()
    np.save(buf, rgba)
    try:
        atomic_write_bytes(path, buf.getvalue())
    except OSError:
        pass  # a read-only cache: pre-filter again next time
    return rgba


@functools.lru_cache(maxsize=16)
def _sh(spec: str, layout: str, yaw: float) -> np.ndarray:
    return env.sh_project(environment_image(spec, layout), yaw)


@functools.lru_cache(maxsize=16)
def _sh25(spec: str, layout: str, yaw: float) -> np.ndarray:
    return env.sh_project25(environment_image(spec, layout), yaw)


@functools.lru_cache(maxsize=2)
def _background(spec: str, layout: str) -> np.ndarray:
    """(H, W, 4) float32: the environment resampled to BACKGROUND_SIZE (box-filtered down first)."""
    w, h = BACKGROUND_SIZE
    img = env.downsample(environment_image(spec, layout), w)
    rgb = env.sample_equirect(img, env.equirect_directions(w, h).reshape(-1, 3)).reshape(h, w, -1)
    return np.ascontiguousarray(np.concatenate([rgb, np.ones((h, w, 1))], 2), np.float32)


def prefiltered_spec() -> TexSpec:
    w, h = env.SPEC_SIZE
    return TexSpec((w, h * len(env.SPEC_LEVELS_M)), 4, "f4", filter="linear")


class EnvironmentPass(Pass):
    """The environment's pre-filtered specular levels (physics.environment.prefilter_specular) and
    the rho_dt table of the split sum's specular albedo (seed 000 eq. 30). Re-runs when the image
    or specular.f0/rho_s change; the yaw is applied at lookup."""
    name = "environment"
    uses_scene = False

    def reflect(self, r: Reflection) -> None:
        i = env_index(r)
        if i is None:
            r.skip("no environment light")
            return
        e = r.settings.lights[i]
        declare(e.environment, e.layout, r.settings.specular.f0, r.settings.specular.rho_s)
        r.output(ENV_PREFILTERED, prefiltered_spec())
        r.output(ENV_RHO_DT, TexSpec((32, 32), 1, "f4", filter="linear"))
        sharp = r.settings.render.background_environment == "sharp"
        r.plan(environment=i, background=sharp)  # the light, and whether the sharp background is made
        if sharp:
            r.output(ENV_BACKGROUND, TexSpec(BACKGROUND_SIZE, 4, "f4", filter="linear"))

    def execute(self, ec) -> None:
        from skinviewer.physics.specular import rho_dt_table
        e = ec.settings.lights[ec.plan.environment]
        ec.output(ENV_PREFILTERED).write(_prefiltered(e.environment, e.layout).tobytes())
        table = rho_dt_table(ec.settings.specular.f0, ec.settings.specular.rho_s, n_cos=32, n_m=32)
        table = np.nan_to_num(np.clip(table, 0.0, 1.0), nan=1.0).astype(np.float32)
        ec.output(ENV_RHO_DT).write(np.ascontiguousarray(table).tobytes())
        if ec.plan.background:
            ec.output(ENV_BACKGROUND).write(_background(e.environment, e.layout).tobytes())


def declare_environment(r: Reflection, specular: bool = True) -> dict[str, int]:
    """Declare what shaders/lib/environment.glsl reads for a lit program; returns its defines
    (ENV_LIGHT = 1 and ENV_RAYS, the bake's ray count, so another count is another vertex array),
    or {} without an environment light. ``specular``: the program adds the split-sum specular.
    Plans ``environment``: the light's index or None (what ``set_environment`` reads)."""
    i = env_index(r)
    r.plan(environment=i)
    if i is None:
        return {}
    e = declare_env_fields(r.settings.lights[i])
    depend_on_bake(r, e)
    if specular:
        r.input(ENV_PREFILTERED)
        r.input(ENV_RHO_DT)
    return _defines(e)


def depend_on_bake(r, light) -> None:
    """The lit output depends on which transfer vectors the vertex arrays hold: the unoccluded
    stand-in while the viewer's background bake runs, then the bake (GpuScene.env_generation)."""
    if light.occlusion and hasattr(r, "depends") and r.scene is not None:
        r.depends("env_visibility", getattr(r.scene, "env_generation", 0), scene_generation=True)


def _defines(light) -> dict[str, int]:
    if not light.occlusion:
        return {"ENV_LIGHT": 1, "ENV_RAYS": 0}
    return {"ENV_LIGHT": 1, "ENV_RAYS": int(light.ao_rays), "ENV_TRANSFER": int(light.transfer_order)}


def env_defines(r) -> dict[str, int]:
    """The defines declare_environment returns, without declaring anything (shape only)."""
    i = env_index(r)
    if i is None:
        return {}
    return _defines(whole(r.peeked.lights[i]))


def sh_uniform(light) -> np.ndarray:
    """(9, 3) float32 A_l L_lm x colour x intensity at the light's yaw and SH order (u_env_sh)."""
    L_lm = _sh(light.environment, light.layout, float(light.yaw))
    E_lm = env.sh_irradiance_coefficients(L_lm, int(light.sh_order))
    return (E_lm * np.asarray(light.color, np.float64)[None] * float(light.intensity)).astype(np.float32)


def transfer_uniform(light) -> np.ndarray:
    """(25, 3) float32 L_lm x colour x intensity at the light's yaw, bands above its transfer_order
    zeroed (u_env_L: what lib/mesh_vs.glsl dots with the vertex's transfer vector)."""
    L_lm = np.array(_sh25(light.environment, light.layout, float(light.yaw)), np.float64)
    L_lm[env.TRANSFER_BAND > int(light.transfer_order)] = 0.0
    return (L_lm * np.asarray(light.color, np.float64)[None] * float(light.intensity)).astype(np.float32)


def set_environment(ec, prog, specular: bool = True) -> None:
    """Set the uniforms and textures of shaders/lib/environment.glsl (no-op without an environment): the
    light reflect planned (``declare_environment``, or ``environment=`` planned by the pass)."""
    i = ec.plan.environment
    if i is None:
        return
    e = ec.settings.lights[i]
    scale = np.asarray(e.color, np.float64) * float(e.intensity)
    yaw = math.radians(float(e.yaw))
    ec.set(prog, "u_env_sh", sh_uniform(e), optional=True)  # optional: a texel surface program without occlusion
    if e.occlusion:  # the vertex stage's transfer vectors (lib/mesh_vs.glsl)
        ec.set(prog, "u_env_L", transfer_uniform(e), optional=True)
    if specular:
        ec.uniforms(prog, u_env_scale=tuple(float(x) for x in scale), u_env_yaw=(math.cos(yaw), math.sin(yaw)),
                    u_env_level_m=np.asarray(env.SPEC_LEVELS_M, np.float32))
        ec.bind(prog, "env_prefiltered", ENV_PREFILTERED)
        ec.bind(prog, "env_rho_dt", ENV_RHO_DT)


def scene_luminance(settings, samples: int = 256) -> float:
    """The mean luminance of the irradiance reaching normals that face the camera (cosine-weighted
    about the view direction): every enabled analytic light (unshadowed) plus the environment's SH
    irradiance. What ``exposure_from_luminance`` divides by."""
    from skinviewer.passes.rules import analytic_on
    from skinviewer.scene.camera import orbit_eye
    lum = np.array([0.2126, 0.7152, 0.0722])
    view = orbit_eye((0.0, 0.0, 0.0), settings.camera.yaw, settings.camera.pitch, 1.0)  # towards the camera
    view = np.asarray(view, np.float64) / np.linalg.norm(view)
    rng = np.random.default_rng(0)
    loc = env.stratified_cosine_directions(samples, rng)
    t, b = env.tangent_frames(view[None])
    n = loc[:, :1] * t + loc[:, 1:2] * b + loc[:, 2:] * view[None]
    E = np.zeros((len(n), 3))
    for light in settings.lights:
        if light.kind in ("directional", "beam") and analytic_on(light):
            d = np.asarray(light.direction, np.float64)
            E += np.maximum(n @ (d / np.linalg.norm(d)), 0.0)[:, None] * (np.asarray(light.color) * light.intensity)
        elif light.kind == "point" and analytic_on(light):
            E += 0.5 * np.asarray(light.color) * light.intensity
    hit = environment_light(settings.lights)
    if hit is not None:
        E += env.sh_irradiance(sh_uniform(hit[1]).astype(np.float64), n)
    return float((E @ lum).mean())


def exposure_from_luminance(settings, reference_exposure: float = 0.9) -> float:
    """render.exposure for ``settings`` so its camera-facing luminance shows as the three-light rig's
    does at the default exposure (0.9): reference_exposure x L(three-light rig) / L(scene)."""
    from skinviewer.ground.settings import three_light_rig
    rig = settings.model_copy(update={"lights": three_light_rig()})
    return reference_exposure * scene_luminance(rig) / max(scene_luminance(settings), 1e-9)
