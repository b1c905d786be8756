"""A scene on the GPU: the mesh's buffers (and its levels of detail, UV covariance, curvature and
environment transfer vectors, each built on first use) and its texture maps. The graph kernel's
passes draw it (ExecuteContext.scene); the engine's Renderer loads it when the scene settings change."""
from __future__ import annotations

import functools
import hashlib
import threading
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import moderngl
import numpy as np
from numpy.typing import ArrayLike

from skinviewer.physics.arrays import Float32Array
from skinviewer.physics.color import srgb_to_linear
from skinviewer.physics.diffusion import max_shear_cos, max_uv_per_mm, uniform_uv_per_mm, vertex_uv_covariance
from skinviewer.physics.penner import vertex_curvature
from skinviewer.scene.camera import LightSpace, light_space
from skinviewer.scene.lod import decimate, level_targets
from skinviewer.scene.mesh import (
    CURVATURE_ATTR,
    ENV_VIS_ATTRS,
    UV_COVARIANCE_ATTR,
    VERTEX_ATTRS,
    VERTEX_FORMAT,
    MeshData,
    is_closed,
    position_ids,
)

# a mesh without an albedo map: a neutral skin tone (sRGB), so a bare scan reads as skin
DEFAULT_SKIN_SRGB = (0.80, 0.62, 0.53)


class LightPose(Protocol):
    """What a light's shadow-map space depends on: a LightSettings or its pose section."""
    @property
    def kind(self) -> str: ...
    @property
    def direction(self) -> Sequence[float]: ...
    @property
    def position(self) -> Sequence[float]: ...


@dataclass
class SceneCaches:
    """What the passes and the scene rules compute from a scene's mesh and keep for the scene's life
    (the mesh is fixed for it): their explicit home, owned by the GpuScene (``GpuScene.caches``), so
    that nothing outside the GpuScene sets an attribute on it (issue 28). Each table is keyed and
    bounded by its owner."""
    # texture-space CPU tables, by (kind, size, coverage digest): the gutter table and seam map
    # (passes/texture_space), d'Eon's border frame (passes/deon); GpuScene.texel_table fills it
    texel_tables: dict[tuple[Any, ...], bytes] = field(default_factory=dict)
    # the scene rules' memory (passes/rules.py): the Embree scene and face normals, rays and lit
    # pairs per light pose, vertex areas
    rules: dict[Any, Any] = field(default_factory=dict)
    # passes/rules.tsm_needed's answers per light pose, profile and view
    tsm_needed: dict[tuple[Any, ...], tuple[bool, str]] = field(default_factory=dict)


@dataclass
class _EnvState:
    """The background environment bake's swap count and last error (GpuScene.env_poll writes them)."""
    generation: int = 0
    error: str = ""


class GpuScene:
    """Mesh buffers and texture maps on the GPU. Immutable: a changed scene is a new GpuScene, and no
    attribute can be set once it is made (what passes keep for the scene's life goes in ``caches``)."""

    def __init__(self, ctx: moderngl.Context, mesh: MeshData, mm_per_unit: float, env_bake_async: bool = False):
        self.ctx = ctx
        self.mesh = mesh
        self.mm_per_unit = float(mm_per_unit)
        self.center = mesh.center.astype(np.float64)
        self.radius = mesh.radius
        self.frame = mesh.frame  # what the camera frames by default (the head of a bust)
        arrays = prepare_gpu_arrays(mesh)  # made by the start's worker already (ui/app.create_app), or now
        self.vbo = ctx.buffer(arrays["vertices"])
        self.ibo = ctx.buffer(arrays["indices"])
        self._lods: dict[int, tuple[moderngl.Buffer, moderngl.Buffer, int]] = {}  # level of detail -> (vbo, ibo, triangles)
        self._uv_cov: dict[int, moderngl.Buffer] = {}  # level of detail -> per-vertex UV covariance
        self._curvature: dict[int, moderngl.Buffer] = {}  # level of detail -> per-vertex curvature (mm^-1)
        self._env_vis: dict[tuple[int, int], moderngl.Buffer] = {}  # (level, rays) -> SH transfer vectors
        self.env_bake_seconds: dict[tuple[int, int], float] = {}  # (level, rays) -> seconds (0: from the cache)
        # the viewer's background bake (Renderer.env_bake_background): a bake not in the disk cache runs
        # in a thread while the vertex arrays hold the unoccluded transfer; env_poll swaps it in
        self.env_bake_async = bool(env_bake_async)
        self._env = _EnvState()
        self._env_jobs: dict[tuple[int, int], _EnvBakeJob] = {}
        self._env_provisional: set[tuple[int, int]] = set()  # buffers holding the unoccluded stand-in
        self._lod_meshes: dict[int, MeshData] = {}
        self.albedo = self._texture(arrays["albedo"], "f2")
        self.has_normal_map = mesh.normal_map is not None
        self.normal_map = self._texture(arrays["normal_map"], "f2")
        self.specular_map = self._texture(arrays["specular_map"], "f2")
        _forget_prepared(mesh)  # uploaded: the copies are not kept
        self.has_region_map = mesh.region_map is not None
        rm = mesh.region_map if mesh.region_map is not None else np.zeros((1, 1), np.uint8)
        self.region_map = ctx.texture((rm.shape[1], rm.shape[0]), 1, np.ascontiguousarray(rm).tobytes(),
                                      dtype="f1", alignment=1)
        self.region_map.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.region_ids = np.ascontiguousarray(rm)
        self._light_spaces: dict[tuple[str, tuple[float, ...], tuple[float, ...]], LightSpace] = {}
        self.caches = SceneCaches()
        object.__setattr__(self, "_sealed", True)

    def __setattr__(self, name: str, value: Any) -> None:
        if self.__dict__.get("_sealed", False):
            raise AttributeError(f"GpuScene is immutable: cannot set '{name}' (what a pass keeps for the "
                                 "scene's life goes in GpuScene.caches)")
        object.__setattr__(self, name, value)

    @property
    def env_generation(self) -> int:
        """+1 at each swap of a background bake: the lit passes' cache key (passes/environment)."""
        return self._env.generation

    @property
    def env_bake_error(self) -> str:
        return self._env.error

    def _texture(self, arr: np.ndarray, dtype: str) -> moderngl.Texture:
        arr = np.ascontiguousarray(arr, dtype=np.float16 if dtype == "f2" else np.float32)
        h, w = arr.shape[:2]
        c = 1 if arr.ndim == 2 else arr.shape[2]
        tex = self.ctx.texture((w, h), c, arr.tobytes(), dtype=dtype)
        tex.build_mipmaps()
        tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        return tex

    def light_space(self, light: LightPose) -> LightSpace:
        """The shadow map's / TSM's light space of ``light`` (a LightSettings or its pose section),
        fitted to this mesh (camera.light_space with its vertices), memoised per pose."""
        memo = self._light_spaces
        key = (light.kind, tuple(light.direction), tuple(light.position))
        if key not in memo:
            if len(memo) > 32:
                memo.clear()
            memo[key] = light_space(light, self.center, self.radius, self.mesh.positions)
        return memo[key]

    def texel_table(self, key: tuple[Any, ...], make: Callable[[], bytes]) -> bytes:
        """A texture-space CPU table of this scene (``caches.texel_tables``): the one made before under
        ``key`` (kind, size, coverage digest...), else ``make()``, kept. Its content depends on the mesh
        and the key only, so a forced re-run or a second technique at the same size only uploads it."""
        hit = self.caches.texel_tables.get(key)
        if hit is None:
            hit = self.caches.texel_tables[key] = make()
        return hit

    @functools.cached_property
    def has_open_border(self) -> bool:
        """The mesh has a border edge (scene/mesh.border_half_edges): d'Eon's open-border reflection
        has work to do (a closed mesh, such as the default head, pays nothing)."""
        from skinviewer.scene.mesh import border_half_edges
        return len(border_half_edges(self.mesh.positions, self.mesh.indices)) > 0

    @functools.cached_property
    def mean_uv_per_mm(self) -> float:
        """The atlas's mean UV per millimetre (sqrt of UV area / surface area): the isotropic
        stretch used when stretch correction is off, and the mean texel size in mm at n x n (1/(n*x))."""
        m = self.mesh
        return uniform_uv_per_mm(m.positions, m.uvs, m.indices, self.mm_per_unit)

    @functools.cached_property
    def max_uv_per_mm(self) -> float:
        """The largest per-axis stretch any triangle has (UV per mm; the stretch map's maximum)."""
        m = self.mesh
        return max_uv_per_mm(m.positions, m.uvs, m.indices, self.mm_per_unit)

    @functools.cached_property
    def closed(self) -> bool:
        """The mesh has no border edge (scene/mesh.is_closed): ``scene.back_faces = auto`` culls."""
        return is_closed(self.mesh.positions, self.mesh.indices)

    @functools.cached_property
    def max_shear_cos(self) -> float:
        """The largest |cos| between the UV axes on the surface (0: no texel is sheared)."""
        m = self.mesh
        return max_shear_cos(m.positions, m.uvs, m.indices, self.mm_per_unit)

    @functools.cached_property
    def lod_triangles(self) -> list[int]:
        """Triangles each level of detail aims at (scene/lod.py); level 0 is the mesh."""
        return level_targets(len(self.mesh.indices))

    def lod_mesh(self, level: int) -> MeshData:
        """The mesh at level of detail ``level`` (decimated on first use; level 0 is the mesh)."""
        if level <= 0:
            return self.mesh
        key = min(level, len(self.lod_triangles) - 1)
        if key not in self._lod_meshes:
            self._lod_meshes[key] = decimate(self.mesh, self.lod_triangles[key])
        return self._lod_meshes[key]

    def lod_buffers(self, level: int) -> tuple[moderngl.Buffer, moderngl.Buffer, int]:
        """Vertex and index buffers of level ``level`` (built on first use) and its triangle count."""
        if level <= 0:
            return self.vbo, self.ibo, len(self.mesh.indices)
        hit = self._lods.get(level)
        if hit is None:
            m = self.lod_mesh(level)
            hit = self._lods[level] = (self.ctx.buffer(m.interleaved().tobytes()),
                                       self.ctx.buffer(m.indices.astype(np.uint32).tobytes()), len(m.indices))
        return hit

    def mesh_bytes(self) -> int:
        """Bytes of the mesh buffers: the mesh and every level of detail built so far."""
        n: int = (self.vbo.size + self.ibo.size + sum(v.size + i.size for v, i, _ in self._lods.values())
                  + sum(b.size for b in (*self._uv_cov.values(), *self._curvature.values(), *self._env_vis.values())))
        return n

    def vertex_array(self, prog: moderngl.Program, lod: int = 0,
                     index_buffer: moderngl.Buffer | None = None, env_rays: int = 0) -> moderngl.VertexArray:
        """A new VAO of the mesh (at level of detail ``lod``) for ``prog`` (the graph's GpuServices
        caches it per program); ``index_buffer``: another index buffer over the same vertices (a
        band's triangles, GpuServices.band_vao); ``env_rays``: the environment bake whose transfer
        vectors it binds (the program's ENV_RAYS define, lib/mesh_vs.glsl), when it reads them."""
        vbo, ibo, _ = self.lod_buffers(lod)
        ibo = ibo if index_buffer is None else index_buffer
        attrs = [a for a in VERTEX_ATTRS if a in prog]
        fmt = " ".join(_fmt(f, a in prog) for f, a in zip(VERTEX_FORMAT.split(), VERTEX_ATTRS))
        content = [(vbo, fmt, *attrs)]
        if UV_COVARIANCE_ATTR in prog:  # only the stretch pass reads it (deon_stretch.frag VERTEX_METRIC)
            content.append((self.uv_covariance_buffer(lod), "3f", UV_COVARIANCE_ATTR))
        if CURVATURE_ATTR in prog:  # pre-integrated skin (penner.frag)
            content.append((self.curvature_buffer(lod), "1f", CURVATURE_ATTR))
        env_attrs = [a for a in ENV_VIS_ATTRS if a in prog]
        if env_attrs:  # the environment light's transfer vectors (lib/mesh_vs.glsl), those the compiler kept
            if env_rays <= 0:
                raise ValueError("a program that reads the environment's transfer vectors needs its bake's "
                                 "ray count (its ENV_RAYS define)")
            fmt = " ".join(_fmt("4f", a in prog) for a in ENV_VIS_ATTRS)
            content.append((self.env_visibility_buffer(lod, env_rays), fmt, *env_attrs))
        return self.ctx.vertex_array(prog, content, index_buffer=ibo, index_element_size=4)

    def uv_covariance_buffer(self, level: int = 0) -> moderngl.Buffer:
        """Per vertex, the UV covariance of a unit surface Gaussian (physics/diffusion.vertex_uv_covariance;
        issue 10 items 1-2), built on first use per level of detail."""
        hit = self._uv_cov.get(level)
        if hit is None:
            m = self.lod_mesh(level)
            cov = vertex_uv_covariance(m.positions, m.uvs, m.indices, self.mm_per_unit)
            hit = self._uv_cov[level] = self.ctx.buffer(np.ascontiguousarray(cov, np.float32).tobytes())
        return hit

    def env_visibility(self, level: int = 0, rays: int = 256) -> np.ndarray:
        """(N, 27) per vertex of level ``level``: the SH transfer vector of the environment light
        (physics/environment.bake_transfer with Embree: the ambient occlusion and bent normal are its
        first four coefficients), baked once per mesh and ray count, the thickness along -N and the
        back point's AO (bake_thickness, mesh units: the environment's translucency), cached on disk
        (``cache_dir()/envvis``, by a hash of the vertices, normals and triangles)."""
        import time

        from skinviewer.physics.environment import (
            THICK_MISS,
            TRANSFER_COUNT,
            bake_thickness,
            bake_transfer,
            transfer_unoccluded,
        )
        m = self.lod_mesh(level)
        n = len(m.positions)
        t_path = _env_cache_path(m, b"envtransfer2", str(int(rays)))
        k_path = _env_cache_path(m, b"envthick2", str(int(rays)))  # thickness, back AO (of this bake)
        vis, thick = _load_cached(t_path, (n, TRANSFER_COUNT)), _load_cached(k_path, (n, 2))
        if vis is not None:
            self.env_bake_seconds[(level, rays)] = 0.0
            if thick is not None:
                return np.concatenate([vis, thick], 1)

        def bake(progress: Any = None) -> np.ndarray:
            t, k = vis, thick
            if t is None:
                t0 = time.perf_counter()
                t = bake_transfer(m.positions, m.normals, m.indices, rays=int(rays), progress=progress)
                self.env_bake_seconds[(level, rays)] = time.perf_counter() - t0
                _save_cached(t_path, t)
            if k is None:
                k = bake_thickness(m.positions, m.normals, m.indices, transfer=t)
                _save_cached(k_path, k)
            return np.concatenate([t, k], 1).astype(np.float32)

        if not self.env_bake_async:
            return bake()
        key = (level, int(rays))
        if key not in self._env_jobs:
            self._env_jobs[key] = _EnvBakeJob(bake)
        # meanwhile: the unoccluded transfer A_l Y_lm(N) (R&H 2001 eq. 8), i.e. no occlusion at all,
        # and no translucency from the environment
        standin = vis if vis is not None else transfer_unoccluded(m.normals)
        return np.concatenate([standin, np.full((n, 1), THICK_MISS), np.zeros((n, 1))], 1).astype(np.float32)

    def env_poll(self) -> bool:
        """Swap finished background bakes into their vertex buffers (on the GL thread; the buffers are
        rewritten in place, so the vertex arrays stay). True when one was swapped in (env_generation
        changed: the lit passes re-run)."""
        swapped = False
        for key in sorted(self._env_provisional):
            job = self._env_jobs.get(key)
            if job is None or not job.done.is_set():
                continue
            self._env_provisional.discard(key)
            if job.error:  # keeps the unoccluded stand-in; one line in the status bar
                self._env.error = f"environment visibility bake failed: {job.error}"
                continue
            assert job.result is not None
            self._env_vis[key].write(_pad_transfer(job.result).tobytes())
            self._env.generation += 1
            swapped = True
        return swapped

    def env_bake_status(self) -> str:
        """The status bar's words while a background bake runs ("" when none does)."""
        pending = [self._env_jobs[k] for k in self._env_provisional if k in self._env_jobs]
        if not pending:
            return self.env_bake_error
        pct = 100.0 * float(np.mean([j.progress for j in pending]))
        return f"baking environment visibility... {pct:.0f} % (unoccluded meanwhile)"

    def env_wait(self, timeout: float | None = None) -> bool:
        """Wait for the background bakes to finish and swap them in; False on timeout."""
        for job in list(self._env_jobs.values()):
            if not job.done.wait(timeout):
                return False
        self.env_poll()
        return True

    def env_visibility_buffer(self, level: int = 0, rays: int = 256) -> moderngl.Buffer:
        """env_visibility on the GPU, padded to 28 floats (7 vec4) a vertex (one buffer per level of
        detail and ray count)."""
        key = (max(level, 0), int(rays))
        hit = self._env_vis.get(key)
        if hit is None:
            vis = self.env_visibility(key[0], key[1])
            hit = self._env_vis[key] = self.ctx.buffer(_pad_transfer(vis).tobytes())
            if key in self._env_jobs:  # env_visibility gave the stand-in: a background bake runs
                self._env_provisional.add(key)
        return hit

    def curvature_buffer(self, level: int = 0) -> moderngl.Buffer:
        """Per vertex, the surface's curvature in mm^-1 (physics/penner.vertex_curvature), one value per
        point of the surface; built on first use per level of detail."""
        hit = self._curvature.get(level)
        if hit is None:
            m = self.lod_mesh(level)
            k = vertex_curvature(m.positions, m.normals, m.indices, self.mm_per_unit, position_ids(m.positions))
            hit = self._curvature[level] = self.ctx.buffer(np.ascontiguousarray(k, np.float32).tobytes())
        return hit

    def release(self) -> None:
        for job in self._env_jobs.values():
            job.cancel()
        for job in self._env_jobs.values():  # stopped at its next chunk: no thread left in Embree at exit
            job.done.wait(timeout=30.0)
        for obj in (self.vbo, self.ibo, self.albedo, self.normal_map, self.specular_map, self.region_map):
            obj.release()
        for vbo, ibo, _ in self._lods.values():
            vbo.release()
            ibo.release()
        self._lods.clear()
        for buf in (*self._uv_cov.values(), *self._curvature.values(), *self._env_vis.values()):
            buf.release()
        self._uv_cov.clear()
        self._curvature.clear()
        self._env_vis.clear()
        self._lod_meshes.clear()


def _env_cache_path(m: MeshData, tag: bytes, extra: str) -> Path:
    """The disk cache file of an environment bake of mesh ``m`` (``tag``: what and which version)."""
    from skinviewer.ground.paths import cache_dir
    h = hashlib.sha1(tag)
    for a in (m.positions, m.normals, m.indices):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(extra.encode())
    return cache_dir() / "envvis" / f"{h.hexdigest()}.npy"


def _load_cached(path: Path, shape: tuple[int, ...]) -> np.ndarray | None:
    """A cached bake of ``shape``, finite; None when missing, unreadable or stale."""
    try:
        a = np.load(path, allow_pickle=False)
    except (OSError, ValueError):
        return None
    if a.shape != shape or not np.all(np.isfinite(a)):
        return None
    return np.asarray(a, dtype=np.float32)


def _save_cached(path: Path, a: np.ndarray) -> None:
    import io

    from skinviewer.ground.files import atomic_write_bytes
    buf = io.BytesIO()
    np.save(buf, a)
    try:
        atomic_write_bytes(path, buf.getvalue())
    except OSError:
        pass  # a read-only cache folder: bake again next time


def _pad_transfer(vis: np.ndarray) -> np.ndarray:
    """(N, 27) transfer vectors + thickness + back AO padded to the vertex stage's 7 vec4 a vertex
    (float32; the thickness is float 25, in_env_t6.y, the back AO float 26, in_env_t6.z)."""
    pad = np.zeros((len(vis), 4 * len(ENV_VIS_ATTRS)), np.float32)
    pad[:, :vis.shape[1]] = vis
    return pad


class _BakeCancelled(Exception):
    pass


class _EnvBakeJob:
    """One background transfer bake (GpuScene.env_visibility with env_bake_async): a daemon thread
    running ``bake(progress)`` (Embree's ray queries release the GIL), its progress, result or error.
    ``cancel()`` stops it at the next chunk (a released scene)."""

    def __init__(self, bake: Any):
        import threading
        self.progress = 0.0
        self.result: np.ndarray | None = None
        self.error = ""
        self.cancelled = False
        self.done = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(bake,), name="env-bake", daemon=True)
        self._thread.start()

    def _run(self, bake: Any) -> None:
        def progress(f: float) -> None:
            if self.cancelled:
                raise _BakeCancelled
            self.progress = float(f)
        try:
            self.result = bake(progress)
            self.progress = 1.0
        except _BakeCancelled:
            self.error = "cancelled"
        except Exception as exc:  # shown as one line; the unoccluded stand-in stays
            self.error = f"{type(exc).__name__}: {exc}"
        finally:
            self.done.set()

    def cancel(self) -> None:
        self.cancelled = True


def _fmt(f: str, used: bool) -> str:
    # "3f" -> "3f" when the attribute is used, "12x" (skip 12 bytes) when the compiler dropped it
    return f if used else f"{int(f[:-1]) * 4}x"


def prepare_gpu_arrays(mesh: MeshData) -> dict[str, Any]:
    """The CPU side of a GpuScene: the vertex and index bytes, the maps as the textures take them
    (linear albedo, finite values, float16), and the default framing. Kept on the mesh: the viewer's
    start makes them in a worker thread while its window ticks (numpy, no GL), the GpuScene on the GL
    thread then only uploads. Kept beside the mesh (``_prepared``, by identity, while it lives), not on it."""
    memo = prepared_gpu_arrays(mesh)
    if memo is not None:
        return memo
    albedo = mesh.albedo if mesh.albedo is not None else np.ones((1, 1, 3), np.float32) * np.asarray(DEFAULT_SKIN_SRGB, np.float32)
    nm = mesh.normal_map if mesh.normal_map is not None else np.array([[[0.5, 0.5, 1.0]]], np.float32)
    sm = mesh.specular_map if mesh.specular_map is not None else np.ones((1, 1, 1), np.float32)
    memo = {"vertices": mesh.interleaved().tobytes(), "indices": mesh.indices.astype(np.uint32).tobytes(),
            "albedo": np.ascontiguousarray(srgb_to_linear(_finite_map(albedo)).astype(np.float32), dtype=np.float16),
            "normal_map": np.ascontiguousarray(_finite_map(nm), dtype=np.float16),
            "specular_map": np.ascontiguousarray(_finite_map(sm), dtype=np.float16)}
    mesh.frame  # noqa: B018  (memoised on the mesh)
    key = id(mesh)

    def gone(ref: weakref.ReferenceType[MeshData]) -> None:  # the mesh was collected: its arrays go too
        with _prepared_lock:
            if key in _prepared and _prepared[key][0] is ref:
                del _prepared[key]

    with _prepared_lock:
        _prepared[key] = (weakref.ref(mesh, gone), memo)
    return memo


# prepare_gpu_arrays' results until the GpuScene uploads them: id(mesh) -> (weak reference, arrays)
_prepared: dict[int, tuple[weakref.ReferenceType[MeshData], dict[str, Any]]] = {}
_prepared_lock = threading.Lock()


def prepared_gpu_arrays(mesh: MeshData) -> dict[str, Any] | None:
    """The arrays prepare_gpu_arrays made for ``mesh`` and the GpuScene has not uploaded yet, or None."""
    with _prepared_lock:
        hit = _prepared.get(id(mesh))
    return hit[1] if hit is not None and hit[0]() is mesh else None


def _forget_prepared(mesh: MeshData) -> None:
    with _prepared_lock:
        hit = _prepared.get(id(mesh))
        if hit is not None and hit[0]() is mesh:
            del _prepared[id(mesh)]


def _finite_map(a: ArrayLike) -> Float32Array:
    out: Float32Array = np.nan_to_num(np.asarray(a, dtype=np.float32), nan=0.0, posinf=1.0, neginf=0.0)
    return out
