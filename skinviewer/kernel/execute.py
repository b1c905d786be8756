"""The ``ExecuteContext``: what ``Pass.execute`` may use — its declared settings, inputs, outputs and
programs, and the graph's GL services (draws, textures bound by sampler name, strict uniforms)."""
from __future__ import annotations

from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, cast

import moderngl
import numpy as np

from skinviewer.ground.settings import get_path
from skinviewer.kernel.gl import image_format
from skinviewer.kernel.gpu import write_uniform
from skinviewer.kernel.pass_api import (
    GraphError,
    Pass,
    Plan,
    Reflection,
    SettingsNode,
    SettingsView,
    ShapeState,
    TexSpec,
)
from skinviewer.kernel.report import FrameInputs

if TYPE_CHECKING:
    from skinviewer.ground.settings import Settings
    from skinviewer.kernel.gpu_scene import GpuScene
    from skinviewer.kernel.graph import RenderGraph
    from skinviewer.scene.camera import View


class ExecuteContext:
    """What ``Pass.execute`` may use: its declared settings, inputs, outputs and programs, and the
    graph's GL services.

    Drawing::

        prog = ec.program("phong")                    # the (only) declared variant of "phong"
        ec.uniforms(prog, u_ambient=0.03, u_eye=(0.0, 0.0, 5.0))
        ec.textures(prog, albedo_map=ec.scene.albedo, blurred="gosselin_blurred")
        ec.draw_mesh(prog, "lit")                     # depth test, both faces, cleared first
        ec.draw_fullscreen(prog, "image")             # or a scratch texture: ec.draw_fullscreen(p, tmp)

    * Textures are bound by sampler name; units are allocated per program for this execute and
      every binding is re-applied before each draw, so a pass never threads unit numbers. Samplers
      of the program that nothing bound read a 1x1 zero texture of their kind (never a stale unit).
    * ``set``/``uniforms``/``bind`` raise GraphError (pass, program, name) for a name the program's
      GLSL source does not declare; a name declared but dropped by the compiler (unused in this
      variant) is skipped silently; ``optional=True`` also skips a name the source lacks.
    """

    def __init__(self, graph: RenderGraph, p: Pass, refl: Reflection, frame: FrameInputs,
                 tile: tuple[int, int] = (0, 1), held: dict[str, Any] | None = None,
                 cover: tuple[Any, Any] | None = None):
        self.graph = graph
        # (need, have) of a pass that declared Reflection.cover: the cells its outputs must hold after this run
        # and those they already hold under its key (None: none, every cell is to be made); None: no cover
        self.cover = cover
        self.tile = tile  # (band, bands) of a tileable pass; (0, 1): the whole pass at once
        self._held = {} if held is None else held
        self._own_held = held is None  # not kept across bands: returned with the scratch
        self._banded: bool | tuple[int, int | None] = False  # band(): True, or (sub, subs)
        self.gl: moderngl.Context = graph.ctx
        self.pass_ = p
        self._refl = refl
        self._frame = frame
        self._scratch: list[moderngl.Texture] = []
        self.draws = 0
        self._bound: dict[int, dict[str, tuple[int, moderngl.Texture]]] = {}  # id(prog) -> sampler -> (unit, tex)
        self._reads: SettingsNode | None = None  # ec.settings, made on first use

    @property
    def plan(self) -> Plan:
        """What this pass's reflect decided this frame (``Reflection.plan``), read-only."""
        return self._refl.planned

    @property
    def scene(self) -> GpuScene:
        if not self.pass_.uses_scene:
            raise GraphError(f"pass {self.pass_.name} did not declare uses_scene")
        scene: GpuScene = self._frame.scene
        return scene

    @property
    def view(self) -> View:
        if not self.pass_.view_dependent:
            raise GraphError(f"pass {self.pass_.name} is view-independent: it may not read the camera")
        view: View = self._frame.view
        return view

    def _check_declared(self, path: str) -> None:
        if path in self._refl._declared_set:  # the common case, without scanning the list
            return
        declared = self._refl.declared
        if path not in declared and not any(path.startswith(d + ".") for d in declared):
            raise GraphError(f"pass {self.pass_.name} reads setting '{path}' it did not declare in reflect()")

    @property
    def settings(self) -> Settings:
        """The settings, read by attribute (``ec.settings.deon.mix``); each read must have been
        declared in reflect (a ``GraphError`` otherwise)."""
        if self._reads is None:
            self._reads = SettingsNode(self._frame.settings, "", self._check_declared)
        return cast("Settings", self._reads)

    @property
    def peeked(self) -> Settings:
        """The settings read for the graph's shape only (as ``Reflection.peeked``), not checked."""
        return cast("Settings", SettingsNode(self._frame.settings, "", None))

    def setting(self, path: str) -> Any:
        self._check_declared(path)
        return get_path(self._frame.settings, path)

    def peek(self, path: str) -> Any:
        """A setting read for the graph's shape only (as Reflection.peek), not declared."""
        return get_path(self._frame.settings, path)

    @property
    def state(self) -> ShapeState:
        """The graph's memory for shape decisions (Reflection.state)."""
        return self.graph.shape_state

    def has_input(self, resource: str) -> bool:
        """Whether this frame's reflect() declared ``resource`` (optional inputs)."""
        return resource in self._refl.inputs

    def input_version(self, resource: str) -> int:
        """The version of a declared input (bumps whenever its producer re-ran)."""
        self.input(resource)
        return self.graph.res.versions.get(resource, 0)

    def input(self, resource: str) -> moderngl.Texture:
        if resource not in self._refl.inputs:
            raise GraphError(f"pass {self.pass_.name} reads '{resource}' it did not declare")
        return self.graph.res.textures[resource]

    def _own(self, resource: str) -> str:
        if resource not in self._refl.outputs:
            raise GraphError(f"pass {self.pass_.name} writes '{resource}' it did not declare as an output")
        return resource

    def output(self, resource: str) -> moderngl.Texture:
        return self.graph.res.textures[self._own(resource)]

    def framebuffer(self, *resources: str) -> moderngl.Framebuffer:
        return self.graph.res.framebuffer(tuple(self._own(r) for r in resources))

    def program(self, name: str, **defines: object) -> moderngl.Program:
        """A declared program. Without ``defines``: the one variant of ``name`` reflect() declared."""
        declared = [d for n, d in self._refl.programs if n == name]
        key: tuple[tuple[str, object], ...] = tuple(sorted(defines.items()))
        if not defines and len(declared) == 1:
            key = declared[0]
        elif key not in declared:
            raise GraphError(f"pass {self.pass_.name} uses program '{name}'{dict(key) or ''} it did not declare"
                             + (f" (declared variants: {[dict(d) for d in declared]})" if declared else ""))
        return self.graph.shaders.get(name, dict(key) or None)

    def section(self, prefix: str, fields: Iterable[str]) -> SettingsView:
        """The declared settings ``prefix.f`` (for f in ``fields``) as a read-only view."""
        return SettingsView(prefix, {f: self.setting(f"{prefix}.{f}") for f in fields})

    # -- uniforms and textures -------------------------------------------------------------------
    def _check(self, prog: moderngl.Program, name: str, optional: bool) -> bool:
        """Whether ``name`` is live in ``prog``; GraphError when its source does not declare it."""
        if name in self.graph.shaders.members(prog):
            return True
        try:
            pname, declared = self.graph.shaders.describe(prog)
        except KeyError:
            raise GraphError(f"pass {self.pass_.name}: program not from the graph's shader library") from None
        if name in declared or optional:
            return False  # declared but dropped by the compiler (unused in this variant)
        raise GraphError(f"pass {self.pass_.name}: program '{pname}' declares no uniform '{name}'")

    def set(self, prog: moderngl.Program, name: str, value: Any, optional: bool = False) -> None:
        """Set a uniform: numbers, bools, tuples (vectors), numpy arrays (uniform arrays, cut to what
        the compiler kept) or bytes (e.g. a column-major matrix)."""
        if self._check(prog, name, optional):
            try:
                write_uniform(prog[name], value)
            except (ValueError, TypeError, moderngl.Error) as exc:
                raise GraphError(f"pass {self.pass_.name}: uniform '{name}': {exc}") from None

    def uniforms(self, prog: moderngl.Program, **values: Any) -> None:
        """``set`` for each keyword (all required to be declared)."""
        for name, value in values.items():
            self.set(prog, name, value)

    def bind(self, prog: moderngl.Program, sampler: str, texture: moderngl.Texture | str,
             optional: bool = False) -> None:
        """Bind ``texture`` (a texture, or the name of a declared input) to ``sampler`` of ``prog``;
        it stays bound for every draw of ``prog`` in this execute (rebinding replaces it)."""
        tex = self.input(texture) if isinstance(texture, str) else texture
        if not self._check(prog, sampler, optional):
            return
        bound = self._bound.setdefault(id(prog), {})
        unit = bound[sampler][0] if sampler in bound else len(bound)
        if unit >= self.graph.gpu.binding_units:
            raise GraphError(f"pass {self.pass_.name}: too many textures for one program")
        bound[sampler] = (unit, tex)

    def textures(self, prog: moderngl.Program, **samplers: moderngl.Texture | str) -> None:
        """``bind`` for each keyword: ``ec.textures(prog, source=tex, gutter="gutter_512")``."""
        for sampler, tex in samplers.items():
            self.bind(prog, sampler, tex)

    def _apply(self, prog: moderngl.Program) -> None:
        """Before a draw: this program's textures on their units, the other samplers on dummies."""
        bound = self._bound.get(id(prog), {})
        gpu = self.graph.gpu
        for name, gl_type in gpu.samplers(prog).items():
            if name in bound:
                unit, tex = bound[name]
                tex.use(unit)
            else:
                unit = gpu.dummy(gl_type)
            write_uniform(prog[name], unit)

    # -- draws ---------------------------------------------------------------------------------
    def _target(self, targets: tuple[str | moderngl.Texture, ...]) -> moderngl.Framebuffer:
        if not targets:
            raise GraphError(f"pass {self.pass_.name}: a draw needs a target")
        if all(isinstance(t, str) for t in targets):
            return self.framebuffer(*(t for t in targets if isinstance(t, str)))
        held = list(self._held.values())
        if any(isinstance(t, str) or (t not in self._scratch and t not in held) for t in targets):
            raise GraphError(f"pass {self.pass_.name}: draw targets are declared outputs or scratch textures")
        return self.graph.res.framebuffer_for(tuple(t for t in targets if not isinstance(t, str)))

    def draw_mesh(self, prog: moderngl.Program, *targets: str | moderngl.Texture,
                  clear: tuple[float, float, float, float] | None = (0.0, 0.0, 0.0, 0.0), depth_test: bool = True,
                  cull_back: bool = False, space: str | None = None, matrix: Any = None) -> None:
        """Rasterise the scene's mesh with ``prog`` into ``targets`` (declared outputs, with their
        depth buffer, or scratch textures): both faces unless ``cull_back`` (counter-clockwise is
        front), depth-tested unless ``depth_test=False`` (texture-space unwraps), after clearing
        colour to ``clear`` and depth to 1 (None: no clear). ``space``: where the vertex stage puts
        the mesh, "camera" (``u_view_proj`` = the view's), "light" (clip = ``matrix`` x position, a
        column-vector GL matrix: the shadow maps) or "uv" (the unwrap): in a band, only the triangles
        that reach its rows are drawn (GpuServices.band_vao); None: the whole mesh."""
        scene = self.scene
        fbo = self._target(targets)
        rect = self._scissor(fbo)
        fbo.use()
        if clear is not None:
            fbo.clear(*clear, depth=1.0, viewport=rect)
        if depth_test:
            self.gl.enable(moderngl.DEPTH_TEST)
        else:
            self.gl.disable(moderngl.DEPTH_TEST)
        if cull_back:
            self.gl.front_face = "ccw"
            self.gl.cull_face = "back"
            self.gl.enable(moderngl.CULL_FACE)
        else:
            self.gl.disable(moderngl.CULL_FACE)
        self._apply(prog)
        lod = self._frame.mesh_lod
        # the environment bake the vertex arrays bind: the program's own ENV_RAYS (lib/mesh_vs.glsl reads
        # the transfer vectors only when ENV_RAYS > 0), so no pass sets it on the scene
        env_rays = int(self.graph.shaders.program_defines(prog).get("ENV_RAYS", 0))
        if rect is not None and space is not None:
            if space == "camera":
                matrix = self.view.view_proj
            elif space != "light":
                matrix = None
            vao, count = self.graph.gpu.band_vao(prog, scene, lod, space, matrix, fbo.size[1],
                                                 (rect[1], rect[1] + rect[3]), env_rays=env_rays)
            if count:
                t0 = self.graph.shaders.first_draw(prog)
                vao.render(vertices=count)
                self.graph.shaders.first_draw_done(prog, t0)
        else:
            t0 = self.graph.shaders.first_draw(prog)
            self.graph.gpu.mesh_vao(prog, scene, lod, env_rays).render()
            self.graph.shaders.first_draw_done(prog, t0)
        self.gl.disable(moderngl.CULL_FACE)
        if rect is not None:
            fbo.scissor = None  # type: ignore[assignment]  # moderngl's stub omits None (documented: scissor off)
        if lod:
            self.graph._lod_notes[self.pass_.name] = self._frame.lod_note
        self.draws += 1

    def draw_fullscreen(self, prog: moderngl.Program, *targets: str | moderngl.Texture,
                        tiles: tuple[moderngl.Texture, int, float] | None = None,
                        tile_space: tuple[int, int] | None = None) -> None:
        """One full-screen triangle with ``prog`` (its vertex stage: shaders/vs/fullscreen.vert) into
        ``targets`` (declared outputs or scratch textures), no depth test, no clear.

        ``tiles``: (texture, count, edge) from texture_space.work_tiles, for a program compiled with
        ``TILED=1``: only those tiles are rasterised (issue 14: no work on gutter texels no blur can
        read); the texels drawn come out bit-identical, the others keep their previous contents."""
        fbo = self._target(targets)
        rect = self._scissor(fbo)
        fbo.use()
        self.gl.disable(moderngl.DEPTH_TEST)
        if tiles is not None:
            tex, count, edge = tiles
            self.bind(prog, "u_tiles", tex)
            w, h = tile_space or fbo.size
            self.uniforms(prog, u_tile=float(edge), u_target_size=(float(w), float(h)))
        self._apply(prog)
        t0 = self.graph.shaders.first_draw(prog)
        self.graph.gpu.fullscreen_vao(prog).render(vertices=3 if tiles is None else 6 * tiles[1])
        self.graph.shaders.first_draw_done(prog, t0)
        if rect is not None:
            fbo.scissor = None  # type: ignore[assignment]  # moderngl's stub omits None (documented: scissor off)
        self.draws += 1
        self.gl.disable(moderngl.DEPTH_TEST)

    def dispatch(self, prog: moderngl.Program, target: str | moderngl.Texture,
                 tiles: tuple[Any, ...] | None = None) -> None:
        """Run compute shader ``prog`` (``ec.program`` of a library program from ``name.comp`` including
        lib/compute_target.glsl; GL 4.3) over ``target`` (a declared output or a scratch/held texture),
        bound to image unit 0 and written with imageStore: the compute twin of ``draw_fullscreen``
        (issue 27). ``tiles``: (texture of RG tile origins row by row, count, edge[, the origins' y in
        ascending order]) for a program compiled with ``CS_TILES``, one workgroup per tile of ``edge`` =
        its CS_TILE texels (with the y's, a band dispatches only the tiles reaching its rows); None: the
        whole target (or this band's rows, as the draws' scissor). Textures and uniforms are bound as
        for draws; a memory barrier follows, so later draws, dispatches and reads see the writes."""
        tex = self._image_target(target)
        defines = self.graph.shaders.program_defines(prog)
        fmt = image_format(tex.components, tex.dtype)
        if fmt is None or defines.get("IMAGE_FORMAT") != fmt:
            raise GraphError(f"pass {self.pass_.name}: a dispatch into a {tex.components} x {tex.dtype} texture needs "
                             f"IMAGE_FORMAT {fmt or '(none: not image load/store compatible)'}, the program has "
                             f"{defines.get('IMAGE_FORMAT')}")
        edge = int(defines.get("CS_TILE", 0))
        if edge <= 0 or (tiles is not None) != ("CS_TILES" in defines) or (tiles is not None and tiles[2] != edge):
            raise GraphError(f"pass {self.pass_.name}: dispatch needs a program with CS_TILE (and CS_TILES with "
                             f"tiles of its edge); it has {defines}")
        w, h = tex.size
        band = self._band_of((w, h))
        rect = band or (0, 0, w, h)
        x0, y0 = rect[0], rect[1]
        x1, y1 = min(x0 + rect[2], w), min(y0 + rect[3], h)
        self.set(prog, "u_clip", (x0, y0, x1, y1))
        if tiles is not None:
            first, count = 0, int(tiles[1])
            if band is not None and len(tiles) > 3:  # the tiles whose rows [y, y + edge) reach the band's
                ys = tiles[3]
                first = int(np.searchsorted(ys, y0 - edge + 1, "left"))
                count = int(np.searchsorted(ys, y1, "left")) - first
            self.bind(prog, "u_tiles", tiles[0])
            self.uniforms(prog, u_tile_first=first, u_tile_count=count)
            cols = min(max(count, 1), int(tiles[0].width))
            groups = (min(count, cols), -(-count // cols))
        else:
            groups = (-(-(x1 - x0) // edge), -(-(y1 - y0) // edge))
        self._apply(prog)
        tex.bind_to_image(0, read=False, write=True)
        if groups[0] > 0 and groups[1] > 0 and x1 > x0 and y1 > y0:
            t0 = self.graph.shaders.first_draw(prog)  # a driver may finish compiling at the first run too
            cast(moderngl.ComputeShader, prog).run(*groups)
            self.graph.shaders.first_draw_done(prog, t0)
        self.gl.memory_barrier()  # every bit: the next pass may sample it, draw into it or read it back
        self.draws += 1

    def _image_target(self, target: str | moderngl.Texture) -> moderngl.Texture:
        if isinstance(target, str):
            return self.output(target)
        if target not in self._scratch and target not in list(self._held.values()):
            raise GraphError(f"pass {self.pass_.name}: dispatch targets are declared outputs or scratch textures")
        return target

    def refine(self, more: bool) -> None:
        """A progressive pass (e.g. temporal accumulation) asks for another frame even when nothing
        changed (``more``), or says it has converged: the graph does not idle while any pass asks."""
        (self.graph.refining.add if more else self.graph.refining.discard)(self.pass_.name)

    def note(self, text: str, **figures: Any) -> None:
        """A figure this run measured (e.g. samples counted on the GPU): shown with the pass in the
        frame report (``PassRecord.note`` / ``figures``), kept while the pass stays cached."""
        self.graph._notes[self.pass_.name] = (text, dict(figures))

    def scratch(self, spec: TexSpec) -> moderngl.Texture:
        """A temporary texture from the pool, returned when execute ends (ping-pong targets)."""
        tex = self.graph.res.take(spec)
        self._scratch.append(tex)
        return tex

    def clear_unwritten(self, resource: str, key: object) -> None:
        """Clear output ``resource`` to zero unless it was cleared for ``key`` since it was (re)allocated:
        a pass that draws only part of its output (texture-space tiles) leaves no pooled texture's, other
        scene's or other tile set's values in the rest (hard cases, the texture inspector, check_finite)."""
        g = self.graph
        if self.cover is not None and self.cover[1] is not None:
            return  # a run for the cells its outputs do not hold yet keeps those they hold (kernel/coverage)
        tag = (g.res.versions.get(resource), key)
        if g._cleared.get(resource) != tag:
            g.res.framebuffer((resource,)).clear(0.0, 0.0, 0.0, 0.0)
            g._cleared[resource] = tag

    # -- tiles (Pass.tileable): the same pass in row bands, across frames ----------------------
    @property
    def first_tile(self) -> bool:
        return self.tile[0] == 0

    @property
    def last_tile(self) -> bool:
        return self.tile[0] == self.tile[1] - 1

    def held(self, name: str, spec: TexSpec) -> tuple[moderngl.Texture, bool]:
        """A scratch texture kept across the bands of this run (work done once, in the first band,
        and read by every band): (texture, fresh) -- fresh: just taken, its content is to be made."""
        tex = self._held.get(name)
        if tex is not None and (tex.size, tex.components, tex.dtype) == (spec.size, spec.components, spec.dtype):
            return tex, False
        if tex is not None:
            self.graph.res.give(tex)
        tex = self._held[name] = self.graph.res.take(spec)
        return tex, True

    def band_rect(self, size: tuple[int, int]) -> tuple[int, int, int, int] | None:
        """The scissor rectangle (x, y, w, h) of this band in a target of ``size``; None: no band."""
        k, n = self.tile
        return None if n <= 1 else _rows(size, k, n)

    @contextmanager
    def band(self, sub: int | None = None, subs: int | None = None) -> Iterator[None]:
        """Draws inside only write this band's rows of their targets (a scissor; each fragment is
        computed as without it, so the bands together are bit-identical to one whole draw).
        ``sub``/``subs``: band ``sub`` of ``subs`` instead of the pass's own (see ``units``)."""
        self._banded = (sub, subs) if sub is not None else True
        try:
            yield
        finally:
            self._banded = False

    def units(self, draws: int) -> list[tuple[int, int, int]]:
        """A pass of ``draws`` full-target draws in sequence, each reading the ones before, split over
        its bands: the (draw, sub-band, sub-bands) this band runs, in order. Each draw is cut in
        ceil(bands / draws) row bands and a band runs a contiguous share of them, so every draw is
        complete before the next one starts; one band (no budget): every draw whole, in order."""
        k, n = self.tile
        self.graph._units[self.pass_.name] = max(int(draws), 1)  # the next split aligns its bands to them
        per = max(1, -(-n // max(draws, 1)))
        total = draws * per
        return [(u // per, u % per, per) for u in range((k * total) // n, ((k + 1) * total) // n)]

    def _band_of(self, size: tuple[int, int]) -> tuple[int, int, int, int] | None:
        """The rows (x, y, w, h) a draw or dispatch in the current band() writes in a target of ``size``."""
        if self._banded is True:
            return self.band_rect(size)
        if self._banded:
            sub, subs = self._banded
            assert subs is not None  # band() is given sub and subs together
            return None if subs <= 1 else _rows(size, sub, subs)
        return None

    def _scissor(self, fbo: moderngl.Framebuffer) -> tuple[int, int, int, int] | None:
        """Set the band's scissor on ``fbo`` before it is used (reset after the draw); None: none."""
        rect = self._band_of(fbo.size)
        if rect is not None:
            fbo.scissor = rect
        return rect

    def _finish(self) -> None:
        for t in self._scratch:
            self.graph.res.give(t)
        self._scratch.clear()
        if self._own_held:
            for t in self._held.values():
                self.graph.res.give(t)
            self._held.clear()


def _rows(size: tuple[int, int], k: int, n: int) -> tuple[int, int, int, int]:
    """Row band ``k`` of ``n`` of a target of ``size``: (x, y, w, h)."""
    w, h = size
    y0, y1 = (k * h) // n, ((k + 1) * h) // n
    return (0, y0, w, y1 - y0)
