"""The render engine: loads the scene onto the GPU (kernel/gpu_scene.GpuScene) and runs one pass graph per
technique, driven by Settings. It takes a moderngl context from its caller (a window's, or
``gl.headless_context()``)."""
from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import moderngl
import numpy as np
from numpy.typing import NDArray

from skinviewer import techniques
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.frame_view import FrameView
from skinviewer.kernel.gpu_scene import GpuScene
from skinviewer.kernel.graph import FrameInputs, FrameReport, RenderGraph, TexturePool
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.passes import rules
from skinviewer.scene.camera import View, framed_view
from skinviewer.scene.environment import environment_image
from skinviewer.scene.mesh import (
    MeshError,
    load_mesh,
    load_texture_maps,
)
from skinviewer.scene.scenes import build_scene


@dataclass
class LoadedScene:
    key: str
    gpu: GpuScene
    description: str
    notes: list[str]


class Renderer:
    """Renders Settings through the technique's graph. Scenes are loaded when their settings change;
    each technique's graph persists (with its cache) while others run."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary | None = None, env_bake_background: bool = False):
        self.ctx = ctx
        self._own_shaders = shaders is None  # a library we made is ours to release
        self._software: bool | None = None  # a software rasterizer (render.timing = auto), asked once
        self.shaders = shaders or ShaderLibrary(ctx)
        self.pool = TexturePool(ctx)
        self.graphs: dict[str, RenderGraph] = {}
        self.scene: LoadedScene | None = None
        self.scene_version = 0
        self._lod_state: dict[str, Any] = {}  # the mesh-LOD rule's hysteresis
        self._completed: Settings | None = None  # complete_view: the settings every tile was made for
        self.last_view: View | None = None  # the last frame's camera (last_frame_view.camera)
        self.last_frame_view: FrameView | None = None
        # bytes textures may use (None: what the system has, see available_memory); tests set it
        self.memory_limit: int | None = _env_bytes("SKINVIEWER_MEMORY_LIMIT")
        # the viewer's: an environment visibility bake not in the disk cache runs in the background
        # (GpuScene.env_bake_async); off, a render waits for it (the CLI's images are deterministic)
        self.env_bake_background = env_bake_background

    # -- scene -------------------------------------------------------------------------------
    @staticmethod
    def scene_key(s: Settings) -> str:
        sc = s.scene
        parts = [sc.mesh or f"builtin:{sc.name}", str(sc.mm_per_unit), sc.albedo_map, sc.normal_map,
                 sc.specular_map, sc.region_map, str(sc.head_detail if not sc.mesh and sc.name == "head" else "")]
        for p in (sc.mesh, sc.albedo_map, sc.normal_map, sc.specular_map, sc.region_map):
            if p:
                try:
                    parts.append(str(Path(p).stat().st_mtime_ns))
                except OSError:
                    parts.append("missing")
        # surrogateescape: a path from a non-UTF-8 file name (validation refuses unencodable ones)
        return hashlib.sha1("|".join(map(str, parts)).encode("utf-8", "surrogateescape")).hexdigest()

    def ensure_scene(self, s: Settings) -> LoadedScene:
        key = self.scene_key(s)
        if self.scene is not None and self.scene.key == key:
            return self.scene
        sc = s.scene
        notes: list[str] = []
        if sc.mesh:
            mesh = load_mesh(sc.mesh)
            notes += mesh.notes
            mm = sc.mm_per_unit
            if mm is None:
                mm = 1.0
                across = 2.0 * float(mesh.frame[1])  # the head's framing sphere (without the neck and shoulders)
                hint = (f" — its head is {across:.3g} mm across that way, a head ~260 mm: e.g. --set "
                        f"scene.mm_per_unit={260.0 / across:.3g}" if across > 0 and not 100.0 <= across <= 600.0 else "")
                notes.append("scene.mm_per_unit not set: assuming the mesh is in millimetres" + hint)
            desc = f"{Path(sc.mesh).name}"
        else:
            sdef = build_scene(sc.name, sc.head_detail)
            mesh = sdef.mesh
            notes += mesh.notes  # e.g. a cached head that did not validate and was regenerated
            mm = sc.mm_per_unit if sc.mm_per_unit is not None else mesh.mm_per_unit
            desc = sdef.description
        mesh.check_renderable()
        mesh = load_texture_maps(mesh, sc.albedo_map, sc.normal_map, sc.specular_map, sc.region_map)
        gpu = GpuScene(self.ctx, mesh, mm, env_bake_async=self.env_bake_background)
        if self.scene is not None:
            self.scene.gpu.release()
        self.scene = LoadedScene(key, gpu, desc, notes)
        self.scene_version += 1
        return self.scene

    # -- graphs ------------------------------------------------------------------------------
    def graph(self, technique: str, variant: str = "") -> RenderGraph:
        """The technique's graph; ``variant`` names another graph of the same technique with a cache
        of its own (the viewer's governor keeps each preview's maps there, so switching between a
        preview and the user's settings re-runs no once-per-mesh pass on either side)."""
        key = f"{technique}|{variant}" if variant else technique
        g = self.graphs.get(key)
        if g is None:
            passes, targets = techniques.build(technique)
            g = RenderGraph(self.ctx, self.shaders, passes, targets, self.pool)
            g.memory_available = self.available_memory
            if variant:  # a preview's first frame is budgeted by what its passes cost in the user's graph
                g.share_costs(self.graph(technique))
                # and a pass whose key is equal in the other graph is copied, not run (share_passes); not
                # between two previews: only the user's graph and each preview's
                g.share_passes(self.graph(technique))
            self.graphs[key] = g
        return g

    def available_memory(self) -> int:
        """Bytes a frame's new textures may take: ``memory_limit`` less what our textures already
        hold, else 90 % of the host's available memory (llvmpipe keeps textures in host memory; a
        discrete GPU reports no figure through GL 3.3, so this is the host bound there too)."""
        if self.memory_limit is not None:
            return max(int(self.memory_limit) - self.held_bytes(), 0)
        return int(_host_available() * 0.9)

    def held_bytes(self) -> int:
        """Bytes of textures held now: every graph's live textures, the pool's free ones, the scene's."""
        n = sum(spec.nbytes for g in self.graphs.values() for spec in g.resources().values())
        n += sum(int(t.extra.nbytes) for lst in self.pool._free.values() for t in lst)
        return n

    def frame_view(self, s: Settings) -> FrameView:
        """The frame's view of the scene and camera for ``s`` (kernel/frame_view.FrameView): the one
        place the rendered camera is built from settings (scene/camera.framed_view: the head of a bust
        framed). ``render`` builds one a frame and hands it to the passes and the scene rules alike."""
        return self.build_frame_view(s, self.ensure_scene(s).gpu)

    @staticmethod
    def build_frame_view(s: Settings, gpu: GpuScene) -> FrameView:
        """``frame_view`` on a loaded scene (no GL: the start's worker, ui/warm.py, calls it too)."""
        return FrameView(framed_view(s.camera, gpu, (s.render.width, s.render.height)), gpu, float(s.camera.fov_y))

    def view(self, s: Settings) -> View:
        """The camera ``render`` draws ``s`` with (frame_view's)."""
        return self.frame_view(s).camera

    def render(self, s: Settings, targets: list[str] | None = None, timing: str | None = None,
               force: bool = False, budget_ms: float | None = None, variant: str = "",
               interactive: bool = False) -> FrameReport:
        """Run one frame of ``s.technique``; returns the frame report (ran / cached / pruned, ms).
        ``budget_ms`` spreads a long frame over several calls (RenderGraph.run); ``variant``: the
        graph to run it in (Renderer.graph); ``interactive``: a governed preview (FrameInputs)."""
        scene = self.ensure_scene(s)
        scene.gpu.env_poll()  # a finished background bake: swapped in, the lit passes re-run
        env = rules.environment_light(s.lights)
        if env is not None:  # a bad environment file: one clear error before any pass runs
            environment_image(env[1].environment, env[1].layout)
        fv = self.build_frame_view(s, scene.gpu)  # once a frame: the passes' camera and the rules' view
        self.last_view, self.last_frame_view = fv.camera, fv
        g = self.graph(s.technique, variant)
        lod, lod_note = rules.mesh_lod(s, fv, self._lod_state)
        frame = FrameInputs(settings=s, scene=scene.gpu, scene_version=self.scene_version, view=fv.camera,
                            view_key=fv.key, mesh_lod=lod, lod_note=lod_note, frame_view=fv,
                            interactive=interactive)
        report = g.run(frame, targets=targets, timing=self.timing_mode(timing or s.render.timing), force=force,
                       budget_ms=budget_ms)
        self.ctx.screen.use() if self.ctx.screen is not None else None
        return report

    def timing_mode(self, mode: str) -> str:
        """``render.timing`` resolved: auto is sync on a software rasterizer (its timer queries are
        far too low), timer queries on a hardware GPU (a glFinish per pass would cost its overlap)."""
        if mode != "auto":
            return mode
        if self._software is None:
            from skinviewer.kernel.gl import software_renderer
            self._software = software_renderer(self.ctx)
        return "sync" if self._software else "gpu"

    def render_settled(self, s: Settings, max_frames: int = 65, **kw: Any) -> tuple[FrameReport, int]:
        """Render until no pass asks for another frame (progressive passes such as burley2.temporal
        refine a still view over several frames), at most ``max_frames``. Returns the last report and
        the number of frames rendered."""
        report = self.render(s, **kw)
        n = 1
        while self.graph(s.technique).refining and n < max_frames:
            report = self.render(s, **{k: v for k, v in kw.items() if k != "force"})
            n += 1
        return report, n

    def image(self, s: Settings) -> NDArray[np.uint8]:
        """The sRGB image of the last frame as uint8 (H, W, 3), top row first."""
        g = self.graph(s.technique)
        img = g.read("image")[..., :3]
        out: NDArray[np.uint8] = (np.clip(img, 0, 1) * 255.0 + 0.5).astype(np.uint8)[::-1]
        return out

    def read(self, s: Settings, resource: str) -> np.ndarray:
        return self.graph(s.technique).read(resource)

    def complete_view(self, s: Settings, budget_ms: float | None = 30.0) -> bool:
        """deon.view_cull: an idle frame's work -- the texture-space tiles the views so far did not need, made
        under ``budget_ms`` (a pass in row bands resumes in the next call), so that a later camera move
        finds them made (passes/view_cull.COMPLETE). The image is unchanged. True while work is left (a pass
        ran or the budget deferred it); once every tile is made, False at once for the same settings object."""
        from skinviewer.passes.view_cull import COMPLETE
        g = self.graphs.get(s.technique)
        if g is None or s.technique != "deon" or s.deon.view_cull != "view" or self._completed is s:
            return False
        g.shape_state[COMPLETE] = True
        try:
            rep = self.render(with_values(s, {}), budget_ms=budget_ms)
        finally:
            g.shape_state.pop(COMPLETE, None)
        if rep.complete and not rep.ran:
            self._completed = s
        return bool(rep.ran) or not rep.complete

    def warm(self, technique: str, budget_ms: float | None = 50.0) -> int:
        """Compile the likely next shader variants of ``technique`` (idle time); returns how many
        are left."""
        g = self.graphs.get(technique)
        return 0 if g is None else self.shaders.warm(g.likely_programs(), budget_ms)

    def trim(self) -> None:
        """Give GL back what no graph uses now: free pooled textures (every size ever rendered at)
        and depth buffers of sizes no longer drawn. Cached outputs stay."""
        for g in self.graphs.values():
            g.trim()
        self.pool.release()

    def release(self) -> None:
        for g in self.graphs.values():
            g.release()
        self.graphs.clear()
        self.pool.release()
        if self.scene is not None:
            self.scene.gpu.release()
            self.scene = None
        if self._own_shaders:
            self.shaders.release()


def _env_bytes(name: str) -> int | None:
    """An environment size such as 2G, 512M or 1000000 (bytes); None when unset. A value that is not
    a positive finite size is an OSError naming the variable (it was silently ignored, and "inf" was
    an OverflowError traceback)."""
    raw = os.environ.get(name, "")
    text = raw.strip().upper()
    if not text:
        return None
    mult = {"K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}.get(text.rstrip("B")[-1:], 1)
    try:
        value = float(text.rstrip("B").rstrip("KMGT") or "x") * mult
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 1 <= value <= 2**60):
        raise OSError(f"{name}={raw}: expected a positive size such as 2G, 512M or 1000000 (bytes)")
    return int(value)


def _host_available() -> int:
    """MemAvailable of /proc/meminfo (Linux), else physical memory from sysconf, else 8 GB."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 8 * 10**9


def render_settings(s: Settings, ctx: moderngl.Context | None = None) -> tuple[np.ndarray, FrameReport]:
    """Convenience: one headless frame of ``s`` (creates a context when none is given)."""
    from skinviewer.kernel.gl import headless_context
    own = ctx is None
    ctx = ctx or headless_context()
    r = Renderer(ctx)
    try:
        report = r.render(s)
        return r.image(s), report
    finally:
        r.release()
        if own:
            ctx.release()


__all__ = ["Renderer", "GpuScene", "render_settings", "MeshError"]
