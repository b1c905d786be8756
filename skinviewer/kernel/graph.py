"""The pass graph's executor: passes declare what they read and write in ``reflect`` and do GL work in
``execute`` (the Falcor model). The graph orders them, allocates and reuses textures, prunes passes
nobody consumes, caches outputs whose inputs did not change, and times every pass.

A pass re-runs only when one of these changed: a setting it declared, the version of an input
texture, the source of a shader program it declared, the scene (mesh, maps, units) if it reads it,
the camera if it is view-dependent, or the spec (size/format) of one of its outputs.

Passes do no GL plumbing of their own: the ExecuteContext gives them draws (``draw_mesh``,
``draw_fullscreen``), textures bound by sampler name with units allocated per execute
(``bind``/``textures``; samplers left unbound read a 1x1 dummy), uniforms that fail loudly on a
name the program's source does not declare (``set``/``uniforms``), and read-only views of the
settings they declared (``section``). The graph owns the GL objects behind them (kernel/gpu.py).

The pass API, the frame report and the texture pool are re-exported here (``import X as X``).
Its parts: kernel/compiler.py (order, pruning, why a key changed, what an edit re-runs),
kernel/resources.py (textures, framebuffers, the memory check) and this executor (cache keys,
running, bands under a budget, timing).
"""
from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import moderngl
import numpy as np

from skinviewer.ground.paths import shaders_dir
from skinviewer.ground.settings import Settings, get_path, value_key
from skinviewer.kernel.compiler import affected, order_passes, pixels, prune_reason, why
from skinviewer.kernel.execute import ExecuteContext
from skinviewer.kernel.gpu import GpuServices, write_uniform
from skinviewer.kernel.margin import ANY, ErrorQuantiles
from skinviewer.kernel.pass_api import MISSING, OPAQUE, ShapeState, read_value, state_value
from skinviewer.kernel.pass_api import GraphError as GraphError
from skinviewer.kernel.pass_api import Pass as Pass
from skinviewer.kernel.pass_api import Reflection as Reflection
from skinviewer.kernel.pass_api import ResourceLimitError as ResourceLimitError
from skinviewer.kernel.pass_api import SettingsView as SettingsView
from skinviewer.kernel.pass_api import TexSpec as TexSpec
from skinviewer.kernel.report import TIMING_NOTES as TIMING_NOTES
from skinviewer.kernel.report import FrameInputs as FrameInputs
from skinviewer.kernel.report import FrameReport as FrameReport
from skinviewer.kernel.report import PassRecord as PassRecord
from skinviewer.kernel.resources import ResourceCache
from skinviewer.kernel.shaders import ShaderCompileError, ShaderLibrary
from skinviewer.kernel.texture_pool import TexturePool as TexturePool

PACE_WEIGHT = 0.25  # the running mean of actual / predicted cost: the newest pass's (or band's) share
PACE_MAX = 2.0  # the look-ahead scales its predictions by the pace, between 1 and this
STARVE_MIN_MS = 10.0  # own time below this never ends a frame before its first pass (a tiny budget still progresses)
PACE_ERR_K = 2.0  # and adds this many of the predictions' mean error (pace_err) as a margin,
PACE_ERR_MAX = 0.5  # at most this share of the prediction (a loaded machine's error would halve every frame)
# sampled sync (issue 27, release -> final): under a budget with sync timing, a band whose cost the
# look-ahead predicts well (pace_err at most SAMPLE_ERR) and after which another band of the pass is
# predicted to fit skips its glFinish; the chain of such bands is timed as a whole by the next band that
# syncs (at most SYNC_EVERY bands a chain), its time shared out by their predictions. The draws are the
# same, in the same order: the image is bit-identical. False: a glFinish around every band (A/B)
SAMPLED_SYNC = True
SAMPLE_ERR = 0.15
SYNC_EVERY = 4
# the look-ahead's margin from the distribution of its errors (issue 27, session 10: every frame within the
# budget; kernel/margin.py): a predicted cost is budgeted at the MARGIN_Q quantile of its draw's recent
# actual / predicted ratios (the budget's p99, not its mean), its pass's or every pass's while the draw has
# fewer than MARGIN_MIN_N; before that the pace and PACE_ERR_K mean errors. False: the pace rule alone (A/B)
QUANTILE_MARGIN = True
MARGIN_Q = 0.99
MARGIN_WINDOW = 48
MARGIN_MIN_N = 6
MARGIN_MAX = PACE_MAX + PACE_ERR_MAX  # at most the pace rule's widest (a load spike would stall every frame's work)
# only costs predicted at this or more are kept for the margin: a band predicted at 1-4 ms is mostly fixed
# latency (a glFinish's wake-up, its draw calls), its ratio 2-4x under load, and it cannot take a frame far
# past its budget; kept, they set every pass's p99 at the cap (load 7-8: the margin of every pass was 4)
MARGIN_MIN_MS = 5.0
# the frame's first pass that does not fit what its own time left of the budget, but would fit a frame of
# its own, waits for the next frame (once): a release's first frame (its own time 15-20 ms, reflecting every
# pass for the new light) then a 70 ms pass took it to 110 ms (issue 27, session 10). False: only an own
# time over half the budget ends a frame before its first pass (the rule before; A/B)
DEFER_UNFIT_FIRST = True
# a pass's last reflection is reused while nothing it read changed (RenderGraph._still_holds); False:
# every pass reflects every frame (the cost before; benchmarks/bench_cpu_overhead.py compares both)
REUSE_REFLECTIONS = True
# a pass with no texture input whose key another graph of the technique holds is copied from it
# (RenderGraph.share_passes); False: every graph runs its own (bench_interaction.py --share both)
SHARE_PASSES = True
# a pass of dependent draws is split into a multiple of them (_align_units); False: as counted (A/B)
ALIGN_UNITS = True
# issue 27, a cached frame's CPU (session 10): a frame whose passes all kept their reflections reuses
# the last frame's order, live set and prune reasons (RenderGraph._compile), checks each pass's key by
# what can change between two such frames (_clean) and NaN/Inf-scans into kept targets
# (_scan_target); the same passes run, in the same order, with the same draws. False
# (SKINVIEWER_GRAPH_FAST=0): every frame compiles, keys and allocates as before (A/B: bench_cpu_overhead.py)
FAST_CACHED = os.environ.get("SKINVIEWER_GRAPH_FAST", "1") != "0"
# issue 27, session 11: a pass's last cost is also kept per output size (RenderGraph._ms_at, the last
# SIZES_KEPT sizes), and a pass predicted at a size it ran at uses that size's cost, not the last run's scaled
# by the pixels: a drag's smaller view of your graph (a governor rung's scale) ran ssss's ss_lighting at 1/16
# of the pixels in ~70 ms -- mostly its mesh, which does not shrink with the view -- and the release predicted
# the whole view at 16x that, 990-1,160 ms against ~300: 128 bands (at 1.3-3.5 ms of fixed cost a band here,
# 1.7-2.5x the pass's cost) and its margins learned from bands predicted 3x too dear. False: scaled (A/B)
COST_PER_SIZE = True
SIZES_KEPT = 4
# issue 27, session 11: the floor on a band's average cost (MIN_BAND_SHARE of the budget) is taken on the pass's
# predicted cost, not on its paced upper bound: at a 2.5x margin (a loaded machine) the floor allowed 2.5x the
# bands, and a profile a stalled band had made uneven (a share no count shrinks) took the pass to that many --
# ss_lighting in 77-128 bands of 1.3-3.5 ms fixed cost each, about twice its whole cost; each such run's sum
# then predicted the next dearer still. The costliest band is still sized at its paced cost. False: the floor
# on the paced cost (the rule before; A/B)
MIN_BAND_BY_COST = True
MAX_TILES = 128  # row bands a tileable pass is split into at most (8 rows of a 1024² map)
UNMEASURED_TILES = 4
# issue 27, session 12: under sync timing the NaN/Inf check's GPU scans (render.check_finite, after each pass of a
# frame that is not a preview) are waited for where they are drawn, so what they cost is kept as the check's
# (_check_ms, the look-ahead's _check_after). Left queued, the next pass's opening glFinish waited for them: 10-28 ms
# a pass in a refinement's frames counted in no pass and no prediction, the render's overrun past its budget
# (the frames of 105-125 ms of release -> final). False: left queued (the rule before; A/B)
SYNC_CHECKS = True
# and a check's cost is predicted by the median of its last CHECKS_KEPT (a check stalled once -- 174-208 ms at load
# 8-10 -- no longer makes its pass's next last band wait a frame); 1: the last check's cost (the rule before)
CHECKS_KEPT = 5
MIN_BAND_SHARE = 0.1  # a pass is not split into bands that cost less than this share of the budget on average  # bands of a tileable pass never timed yet, under a budget


@dataclass
class TileProgress:
    """A tileable pass part-way through its bands (issue 27): resumed next frame while its cache key
    is unchanged, cancelled (held textures freed, outputs left unkeyed) as soon as it differs."""
    key: dict[str, Any]
    count: int
    done: int = 0
    ms: float = 0.0
    held: dict[str, Any] = field(default_factory=dict)  # name -> texture kept across its bands (ExecuteContext.held)
    band_ms: list[float] = field(default_factory=list)  # what each band done so far cost
    cover: Any = None  # ExecuteContext.cover of its run (kernel/coverage): (need, have) or None


def _covering(cover: Any) -> dict[str, Any]:
    """_execute's ``cover`` keyword when a pass runs with one (kernel/coverage), else none."""
    return {} if cover is None else {"cover": cover}


def _elapsed_ms(query: moderngl.Query) -> float | None:
    """A timer query's GPU time in ms (waits for it), the query released; None when it has none."""
    ns = query.elapsed
    query.release() if hasattr(query, "release") else None
    if ns is None or ns >= 0xFFFFFFFF or ns < 0:  # llvmpipe's first query answers 0xFFFFFFFF
        return None
    return ns / 1e6


_SPEC_KEYS: dict[TexSpec, str] = {}  # repr of an output's spec, made once per spec (part of every key)


def _spec_key(spec: TexSpec) -> str:
    k = _SPEC_KEYS.get(spec)
    if k is None:
        if len(_SPEC_KEYS) > 4096:
            _SPEC_KEYS.clear()
        k = _SPEC_KEYS[spec] = repr(spec)
    return k


def fast_value_key(settings: Settings, path: str) -> str:
    """``value_key`` of a setting, the same text, without JSON for a plain number, bool or None (most
    declared settings; JSON encoding was most of the cost of a pass's cache key)."""
    v = get_path(settings, path)
    t = type(v)
    if t is float:
        if math.isfinite(v):
            return repr(v)
    elif t is int:
        return repr(v)
    elif t is bool:
        return "true" if v else "false"
    elif v is None:
        return "null"
    return value_key(settings, path)


def band_shares(profile: np.ndarray | None, count: int) -> np.ndarray:
    """The share of a pass's cost in each of ``count`` equal row bands, from ``profile``: its cost
    over the rows at its last run, as a cumulative distribution at equal row steps (0 ... 1);
    None: cost even over the rows. Bands of a face cost more than bands of background."""
    edges = np.linspace(0.0, 1.0, count + 1)
    if profile is None or len(profile) < 2:
        return np.diff(edges)
    return np.diff(np.interp(edges, np.linspace(0.0, 1.0, len(profile)), profile))


class RenderGraph:
    """Orders, prunes, caches and times passes. One graph per technique; textures come from a
    shared pool so switching technique reuses allocations."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderLibrary, passes: Iterable[Pass],
                 targets: Iterable[str], pool: TexturePool | None = None):
        self.ctx = ctx
        self.shaders = shaders
        self.passes: list[Pass] = list(passes)
        names = [p.name for p in self.passes]
        if len(set(names)) != len(names):
            raise GraphError(f"duplicate pass names in {names}")
        self.targets = list(targets)
        self.pool = pool or TexturePool(ctx)
        self.res = ResourceCache(ctx, self.pool)  # textures, framebuffers, memory (kernel/resources.py)
        self._keys: dict[str, dict[str, Any]] = {}  # pass name -> last cache key parts
        # pass -> the tile cells (kernel/coverage.TileCover) its outputs hold under its key; absent: every cell
        self._covered: dict[str, Any] = {}
        self.frame = 0
        self.last_report: FrameReport | None = None
        self.order: list[Pass] = []
        self._last_refl: dict[str, Reflection] = {}
        self._idle: tuple[object, ...] | None = None  # what the last complete frame was made of (fast idle frames)
        self._last_ms: dict[str, float] = {}  # last time each pass actually ran
        self._last_px: dict[str, int] = {}  # the pixels of its largest output then (costs scale with them)
        self._ms_at: dict[str, dict[int, float]] = {}  # pass -> its output pixels -> its last cost there (COST_PER_SIZE)
        self._band_profile: dict[str, np.ndarray] = {}  # a banded pass's cost over its rows (band_shares)
        self._cleared: dict[str, tuple[int | None, object]] = {}  # resource -> (version, key) of its last clear
        self._notes: dict[str, tuple[str, dict[str, Any]]] = {}  # pass name -> (text, figures) of its last run
        self.refining: set[str] = set()  # passes that asked for another frame (progressive refinement)
        self._lod_notes: dict[str, str] = {}  # pass name -> the mesh LOD its last run drew at ("" = full)
        self._produced: dict[str, set[str]] = {}  # pass -> outputs it last declared (freed when pruned)
        self.shape_state: ShapeState = {}
        self._last_draws = 0  # memory of scene-driven rules (e.g. map-size hysteresis)
        self.gpu = GpuServices(ctx)  # VAOs, dummy textures: released with the graph
        shaders.on_release(self.gpu.forget_program)
        self._nonfinite: dict[str, list[str]] = {}  # pass -> outputs found non-finite when it last ran
        # passes that ran in a governed preview (FrameInputs.interactive: no NaN/Inf check then), checked
        # by the first frame that is not a preview and finds them cached; what a pass's check last cost
        self._unchecked: set[str] = set()
        self._check_ms: dict[str, float] = {}
        self._check_hist: dict[str, list[float]] = {}  # each pass's last CHECKS_KEPT check costs (_check_ms: their median)
        # this frame's NaN/Inf scans, drawn after their pass, read back after the last (_collect_checks)
        self._pending_checks: list[tuple[str, list[tuple[str, moderngl.Texture]], float]] = []
        self._timing = "sync"  # this run()'s timing mode
        self._pending_queries: list[tuple[Any, PassRecord, str, int, float | None]] = []  # _collect_queries
        self._checking = False  # this frame checks outputs (render.check_finite, not a preview)
        self._value_keys: dict[str, str] = {}  # settings path -> value_key, this run()'s (_kept_value_keys)
        self._value_paths: dict[str, list[str]] = {}  # top-level section -> the paths _value_keys got under it
        # pass -> (its last reflection, (env bake, preview flag), the scene it saw): reused while it holds
        # per pass: (its last reflection, env token, scene, the top-level settings sections it read)
        self._reflected: dict[str, tuple[Reflection, Any, Any, frozenset[str]]] = {}
        self._reflect_settings: Settings | None = None  # the settings of the last reflected and keyed frame
        self._key_parts: dict[str, tuple[Reflection, int, dict[str, Any]]] = {}  # pass -> (reflection, shaders' revision, key parts)
        # the graph's own time in its last run (ms): the frame's wall time outside every pass's execute
        # (reflect and the scene rules, cache keys, NaN/Inf checks); the viewer's governor counts it
        self.own_ms = 0.0
        self.run_ms = 0.0  # its last run's wall time (ms): the viewer budgets the renderer's work around it
        self._exec_s = 0.0
        self.check_ms = 0.0  # the last run's NaN/Inf checks: their scans drawn (and waited for) and read back
        # how the passes' costs compare with what the look-ahead predicted from their last runs (a
        # running mean of actual / predicted): a machine that got busier since then is >1, and the
        # look-ahead scales its predictions by it (1..PACE_MAX) so the frame's last pass does not overrun
        self.pace = 1.0
        # how far single costs stray from that pace (a running mean of |actual / predicted - pace|):
        # the look-ahead leaves a margin of PACE_ERR_K of it, so a band as often off as llvmpipe's on a
        # shared machine still ends the frame within its budget (issue 27: the whole frame)
        self.pace_err = 0.0
        self._starved = False  # the last run ran nothing: its own time had taken the budget (run)
        self.margins = ErrorQuantiles(MARGIN_WINDOW, MARGIN_Q, MARGIN_MIN_N)  # _paced's per-draw error quantiles
        # a run since the last _keep_pace drew a program for the first time: its cost is the driver's
        # compile (llvmpipe: 0.1-2.5 s without Mesa's shader cache), no measure of the draw's (_keep_pace)
        self._first_drawn = False
        self._cost_fallback: RenderGraph | None = None  # share_costs
        self._check_lib: ShaderLibrary | None = None
        self._progress: dict[str, TileProgress] = {}  # tileable passes part-way through their bands
        # graphs of the same technique (the viewer's governor previews, Renderer.graph): a pass that
        # reads no texture and whose cache key one of them holds is copied from it, not run (share_passes)
        self.peers: list[RenderGraph] = []
        self.cancelled: list[str] = []  # passes whose unfinished bands the last frame abandoned
        self.frame_ms: dict[str, float] = {}  # what each pass (its bands) cost in the last run, this frame only
        # a pass of dependent whole-target draws (ExecuteContext.units): how many it made last run
        self._units: dict[str, int] = {}
        # the last compile (_compile): (every pass's reflection, targets, order, live set, prune reasons,
        # the resources the order writes)
        self._compiled: tuple[tuple[Reflection, ...], tuple[str, ...], list[Pass], set[str], dict[str, str],
                              set[str]] | None = None
        # the NaN/Inf scans' flag targets, kept across frames (_scan_target): per grid size, the textures and
        # their framebuffers, and how many of them this frame's scans took so far
        self._scan_targets: dict[tuple[int, int], list[tuple[moderngl.Texture, moderngl.Framebuffer]]] = {}
        self._scan_used: dict[tuple[int, int], int] = {}
        self._check_src: ShaderLibrary | None = None  # the library finite_check comes from (_check_program)
        self._stamps: dict[str, tuple[dict[str, Any], tuple[Any, ...]]] = {}  # pass -> (its kept key, _stamp)
        # the compile whose pruned passes the last frame dropped (outputs freed, keys and flags popped) and
        # their records: a frame of the same compile finds them so (run)
        self._settled: tuple[Any, dict[str, PassRecord]] | None = None
        self._prev_memo: tuple[dict[Any, Any], Any, Any] | None = None  # the last frame's memo (_recall)
        self._rec_outputs: dict[str, tuple[Reflection, dict[str, dict[str, Any]]]] = {}  # _record_outputs

    # -- the resource cache's (kernel/resources.py) ---------------------------------------------
    @property
    def memory_available(self) -> int | Callable[[], int] | None:
        return self.res.memory_available

    @memory_available.setter
    def memory_available(self, value: int | Callable[[], int] | None) -> None:
        self.res.memory_available = value

    def texture(self, resource: str) -> moderngl.Texture:
        return self.res.textures[resource]

    def resources(self) -> dict[str, TexSpec]:
        return dict(self.res.specs)

    def read(self, resource: str) -> np.ndarray:
        """A texture read back as float32 (H, W, C), row 0 at the bottom (GL order)."""
        return self.res.read(resource)

    # -- the frame ---------------------------------------------------------------------------
    def _reflect_all(self, settings: Settings, scene: Any = None, view: Any = None,
                     interactive: bool = False, same: set[str] | None = None,
                     reuse: bool = True) -> dict[str, Reflection]:
        """Every pass's reflection; ``same``: the top-level sections unchanged since the last frame
        (_same_sections), under which a reflection may be reused."""
        refl = {}
        memo: dict[Any, Any] = {}  # Reflection.memo: rules many passes ask, answered once this frame
        token = (getattr(scene, "env_generation", 0), interactive)
        for p in self.passes:
            prev = self._reflected.get(p.name)
            if reuse and prev is not None and self._still_holds(prev, same, token, scene if p.uses_scene else None, memo,
                                                      settings, scene, view, interactive):
                r, sections = prev[0], prev[3]  # what its reflect read is unchanged: it would declare the same again
            else:
                r = Reflection(settings, scene if p.uses_scene else None, self.shape_state,
                               view=view if p.uses_scene else None, interactive=interactive)
                r._frame_memo = memo
                p.reflect(r)
                sections = frozenset(path.split(".", 1)[0] for path in (*r.declared, *r._peek_paths))
            if FAST_CACHED and prev is not None and r is prev[0]:
                # kept: its skip already cleared, its outputs' names as kept (unless pruned since: run)
                if r.outputs and p.name not in self._produced:
                    self._produced[p.name] = set(r.outputs)
                refl[p.name] = r
                continue
            self._reflected[p.name] = (r, token, scene if p.uses_scene else None, sections)
            if r.skip_reason is not None:  # a skipped pass declares nothing
                r.inputs, r.outputs, r.programs, r._plan = [], {}, [], {}
            elif r.outputs:
                for res in self._produced.get(p.name, set()) - set(r.outputs):
                    self.res.free(res)  # e.g. a gutter map of a map size no longer used
                self._produced[p.name] = set(r.outputs)
            refl[p.name] = r
        self._prev_memo = (memo, token, scene)  # the rules asked this frame: what _recall answers from next
        return refl

    def _kept_value_keys(self, same: set[str] | None) -> dict[str, str]:
        """This frame's value keys to start from: the last frame's, for the paths under a top-level
        section equal (==) to the last frame's (``same``, from _same_sections; None: none kept).
        A camera move or a light drag then re-encodes only the camera's or the lights' paths (the
        JSON of a whole section such as ``lights`` or ``deon.gaussians`` was most of a key's cost)."""
        old = self._value_keys
        if same is None or not old:
            self._value_paths.clear()
            return {}
        dropped = [self._value_paths.pop(section) for section in set(self._value_paths) - same]
        if FAST_CACHED:  # the changed sections' paths dropped in place (a camera move: the camera's few)
            for paths in dropped:
                for path in paths:
                    old.pop(path, None)
            return old
        return {path: k for path, k in old.items() if path.split(".", 1)[0] in same}

    def _same_sections(self, settings: Settings) -> set[str] | None:
        """The top-level settings sections equal (==) to the last run's (once a run: the reflections'
        reuse and the value keys both follow it); None: none known.
        (A section equal by == but not in every bit, 0.0 against -0.0, counts as unchanged.)"""
        last, self._reflect_settings = self._reflect_settings, settings
        if last is None or type(last) is not type(settings):
            return None
        names = type(settings).model_fields
        if last is settings:
            return set(names)
        return {name for name in names if getattr(settings, name) == getattr(last, name)}

    def _still_holds(self, prev: tuple[Reflection, Any, Any, frozenset[str]], same: set[str] | None, token: Any,
                     pass_scene: Any,
                     memo: dict[Any, Any], settings: Settings, scene: Any, view: Any, interactive: bool) -> bool:
        """Whether a pass's last reflection holds this frame, so that its reflect need not run (issue 27:
        a camera move re-reflected every pass of the technique): REUSE_REFLECTIONS, the same scene object
        (its environment bake and the preview flag alike), every setting it declared or peeked in an
        unchanged top-level section, no read of the view, the shape state or the raw settings but through
        a memoised rule, and every such rule answering as last frame (asked again, once a frame, in a
        reflection of the graph's own: same value, same settings read, same notes and drops)."""
        r, last_token, last_scene, sections = prev
        if not REUSE_REFLECTIONS or same is None or r._untracked or r._frame_memo is None \
                or last_token != token or last_scene is not pass_scene:
            return False
        if not sections <= same:  # the sections of every setting it declared or peeked (made once)
            return False
        last_memo = r._frame_memo
        for key, rule, scene_less in r._memos:
            if key not in memo and not self._recall(key, memo, same, token, scene, view):
                asker = Reflection(settings, None if scene_less else scene, self.shape_state,
                                   view=None if scene_less else view, interactive=interactive)
                asker._frame_memo = memo
                asker.memo(key, rule)
            now, then = memo[key], last_memo.get(key)
            if now is not then and now[:4] != (then or ())[:4]:  # its answer, settings read, notes and drops
                return False
        return True

    def _recall(self, key: Any, memo: dict[Any, Any], same: set[str], token: Any, scene: Any, view: Any) -> bool:
        """A memoised rule's answer taken from the last frame's memo without asking it again (FAST_CACHED),
        when nothing it read differs now: the same scene, environment bake and preview flag, every setting
        it declared or peeked in an unchanged section, no read of the raw settings, the view's
        attributes and the shape state it read as they were, and the rules it asked answering as then
        (Reflection.memo's Reads); its state writes are made again. On a camera orbit d'Eon's blur plans
        and map sizes are recalled (the kernel rule, asked again for the head's new distance, answers the
        same); the TSM's light, which reads the camera, is asked."""
        last = self._prev_memo
        if not FAST_CACHED or last is None or last[1] != token or last[2] is not scene:
            return False
        entry = last[0].get(key)
        if entry is None or len(entry) < 5:
            return False
        if any(path.split(".", 1)[0] not in same for path in entry[1]):
            return False
        state = self.shape_state
        writes = []
        for read in entry[4]:
            kind = read[0]
            if kind == "peek":
                if read[1].split(".", 1)[0] not in same:
                    return False
            elif kind == "view":
                if view is None or read_value(read[1], getattr(view, read[1])) != read[2]:
                    return False
            elif kind == "state":
                if read[2] is OPAQUE or state_value(state.get(read[1], MISSING)) != read[2]:
                    return False
            elif kind == "write":
                writes.append(read)
            elif kind == "memo":  # a rule it asked: answering as then (asked or recalled this frame)
                if read[1] not in memo and not self._recall(read[1], memo, same, token, scene, view):
                    return False
                if memo[read[1]][:4] != read[2]:
                    return False
            else:  # the raw settings: a rule that reads them may read anything (the TSM rule's background worker)
                return False
        for _, k, v in writes:
            if v is MISSING:  # a delete (_StateReads.__delitem__)
                state.pop(k, None)
            else:
                state[k] = v
        memo[key] = entry
        return True

    def _key(self, p: Pass, r: Reflection, frame: FrameInputs) -> dict[str, Any]:
        # a reflection reused from an earlier frame (_still_holds: every section it read unchanged since)
        # with no shader replaced since: the key's parts made from it then are made again the same
        cached = self._key_parts.get(p.name)
        if cached is not None and cached[0] is r and cached[1] == self.shaders.revision:
            key = dict(cached[2])
        else:
            vk = self._value_keys  # this frame's value keys: passes declare many of the same paths
            for path in r.declared:
                if path not in vk:
                    vk[path] = fast_value_key(frame.settings, path)
                    self._value_paths.setdefault(path.split(".", 1)[0], []).append(path)
            key = {
                "settings": {path: vk[path] for path in r.declared},
                "programs": {f"{n}{d}": self.shaders.version(n, dict(d) or None) for n, d in r.programs},
                "outputs": {res: _spec_key(spec) for res, spec in r.outputs.items()},
            }
            if r.depends_on:
                key["depends"] = {k: repr(v) for k, v in r.depends_on.items()}
            if r._plan:  # what reflect decided for execute (Reflection.plan)
                key["plan"] = {k: repr(v) for k, v in r._plan.items()}
            self._key_parts[p.name] = (r, self.shaders.revision, dict(key))
        versions = self.res.versions
        key["inputs"] = {res: versions.get(res, 0) for res in r.inputs}
        if p.uses_scene:
            key["scene"] = (frame.scene_version, frame.mesh_lod)
        if p.view_dependent:
            key["camera"] = frame.view_key
        return key

    def run(self, frame: FrameInputs, targets: list[str] | None = None, timing: str = "sync",
            force: bool = False, budget_ms: float | None = None) -> FrameReport:
        """Render one frame: everything needed for ``targets`` (default: the graph's targets).

        ``budget_ms``: once at least one pass ran and this much wall time has passed, the passes
        still to run are deferred (status "deferred", cache keys untouched); the next frame resumes
        where this one stopped, since the passes that did run are then cached. Targets are written
        last, so a deferred frame leaves the previous image intact. A ``tileable`` pass runs in row
        bands (as many as its last cost needs to fit half the budget) and may stop between bands: it
        resumes next frame while its key is unchanged, and is cancelled (started over) when it
        changed. While its bands are part-way its outputs are under no cache key, so a pass cancelled
        mid-way is never found cached, whatever the settings return to."""
        # an idle frame: the very same settings object, scene, camera, targets and shaders as the last
        # complete frame -> nothing can re-run; skip reflecting every pass and building cache keys
        # (env_generation: the viewer's background environment bake swapped in, passes/environment)
        idle = (frame.settings, (frame.scene_version, frame.mesh_lod, getattr(frame.scene, "env_generation", 0)),
                frame.view_key, tuple(targets or self.targets),
                self.shaders.revision, timing, frame.interactive)
        last = self.last_report
        if not force and self._idle is not None and last is not None and last.complete and not self.refining \
                and all(a is b or a == b for a, b in zip(idle, self._idle)) and idle[0] is self._idle[0]:
            self.frame += 1
            self.own_ms = 0.0
            self.check_ms = 0.0
            self.run_ms = 0.0
            self.frame_ms = {}
            self.last_report = FrameReport(self.frame, timing, [
                PassRecord(p.name, "cached" if p.status == "ran" else p.status, None,
                           "" if p.status == "ran" else p.reason, p.inputs, p.outputs,
                           note=p.note, figures=p.figures, nonfinite=p.nonfinite)
                for p in last.passes])
            return self.last_report
        if self._pending_checks:  # the last frame raised before reading its scans back
            self._collect_checks(None)
        for query, *_ in self._pending_queries:
            query.release() if hasattr(query, "release") else None
        self._pending_queries = []
        t_start = time.perf_counter()
        any_ran = False
        self._exec_s = 0.0
        self.check_ms = 0.0
        same = self._same_sections(frame.settings)
        self._value_keys = self._kept_value_keys(same)
        if timing not in TIMING_NOTES:
            raise GraphError(f"timing mode must be one of {list(TIMING_NOTES)}")
        self.frame += 1
        self._timing = timing
        self.gpu.keep_scene(frame.scene)
        # force: every pass reflected afresh too (tests and benchmarks that change a pass's own state)
        refl = self._reflect_all(frame.settings, frame.scene, frame.frame_view, frame.interactive, same,
                                 reuse=not force)
        order, live, prune_reasons, written = self._compile(refl, list(targets or self.targets))
        self.res.check_memory(refl, order)
        self.order = order
        self._last_refl = refl
        # render.check_finite: checked after each pass runs, but not in a governed preview (a frame of a
        # drag): those passes are checked when a frame that is not a preview finds them cached, so the
        # final image and every render/bench frame are checked as before
        check_finite = bool(getattr(frame.settings.render, "check_finite", False))
        self._checking = check_finite and not frame.interactive
        records: dict[str, PassRecord] = {}
        self.frame_ms = {}
        partial: set[str] = set()  # outputs of passes part-way through their bands this frame
        self.cancelled = []
        for p in order:
            r = refl[p.name]
            realloc = False
            for res, spec in r.outputs.items():
                realloc |= self.res.ensure(res, spec)
            if realloc:  # garbage under any key: run before it may be found cached
                self._keys.pop(p.name, None)
            old = self._keys.get(p.name)
            stamp = self._stamp(p, r, frame) if FAST_CACHED and not force else None
            key = old if old is not None and self._clean(p.name, old, stamp) else self._key(p, r, frame)
            if old != key:
                self._covered.pop(p.name, None)  # cells made under another key hold nothing now
            # kernel/coverage: a pass valid on part of its outputs (Reflection.cover) runs again, on the cells
            # still missing, when this frame needs more of them (need None: every cell)
            need, have = r.cover_need, self._covered.get(p.name)
            extend = old == key and have is not None and (need is None or not have.covers(need))
            cover = (need, have if need is not None else None) if need is not None or extend else None
            if extend and need is None:  # every cell wanted again: a whole run, as after a key change
                self._keys.pop(p.name, None)
                self._covered.pop(p.name, None)
                old, extend, cover = None, False, None
            rec = PassRecord(p.name, "cached", inputs=list(r.inputs), outputs=self._record_outputs(p.name, r))
            progress = self._progress.get(p.name)
            if progress is not None and (force or progress.key != key or (need is not None and (
                    progress.cover is None or progress.cover[0] != need))):
                # what its bands were computing is no longer wanted; a run for cells it did not hold wrote only
                # those: under an unchanged key it still holds the cells it held (kernel/coverage)
                self._cancel(p.name, keep=not force and progress.key == key)
                progress = None
                old, have = self._keys.get(p.name), self._covered.get(p.name)
                extend = old == key and have is not None and need is not None and not have.covers(need)
                if old == key and have is not None and need is None:  # every cell wanted: a whole run
                    self._keys.pop(p.name, None)
                    self._covered.pop(p.name, None)
                    old = None
                cover = (need, have if extend else None) if need is not None else None
            if progress is not None:
                cover = progress.cover
                extend = cover is not None and cover[1] is not None
            changed = key is not old and old != key
            if not force and changed and progress is None and cover is None \
                    and self._copy_from_peer(p, r, key, rec, timing):
                self._keep_stamp(p.name, key, stamp)
                records[p.name] = rec  # an equal key in a peer graph: its outputs copied (the same result)
                continue
            if force:
                extend = False
                cover = (need, None) if need is not None else None
            if force or realloc or changed or extend:
                # a freshly (re)allocated output holds garbage under no key (popped above): deferred,
                # it runs next frame like any other pass (its consumers wait) -- a first frame is spread
                # over several under the budget instead of freezing the viewer for all its passes
                waits = partial & set(r.inputs)
                # spent: what this pass (or its next band) last cost would take the frame past the budget
                nxt = 0.0 if budget_ms is None else self._paced(
                    self._next_ms(p, r, progress, budget_ms), p.name, self._draw_of(p.name, progress))
                spent = budget_ms is not None and (time.perf_counter() - t_start) * 1000.0 + nxt > budget_ms
                # the frame's first pass runs whatever it costs (progress), unless the graph's own time
                # (reflecting every pass afresh: 20-45 ms in a release's first frame) already took half the
                # budget and the pass would overrun it: then the frame ends here, once (next frame's own
                # time is small), instead of one band on top of it (issue 27: the longest frames)
                own_ms = (time.perf_counter() - t_start) * 1000.0
                if budget_ms is not None and spent and not any_ran and progress is None and p.tileable:
                    # a tileable pass starting in a frame whose own time took part of the budget (a
                    # release's first frame): its bands made smaller, so its first fits what is left
                    fitted = self._fitted_progress(p, r, key, budget_ms, own_ms)
                    if fitted is not None:
                        progress, spent = fitted, False
                starve = budget_ms is not None and not any_ran and spent and not self._starved \
                    and (own_ms > max(0.5 * budget_ms, STARVE_MIN_MS)
                         or self._fits_a_frame_of_its_own(nxt, own_ms, budget_ms))
                if waits or (any_ran and spent) or starve:
                    rec.status = "deferred"
                    rec.reason = "waits for " + ", ".join(sorted(waits)) if waits else "frame time budget spent"
                    rec.nonfinite = list(self._nonfinite.get(p.name, []))
                    records[p.name] = rec
                    partial.update(r.outputs)  # its consumers wait too (a cheaper one may fit after it)
                    continue
                any_ran = True
                rec.status = "ran"
                rec.reason = "forced" if force else ("allocated" if realloc and old == key else why(old, key))
                if extend:
                    rec.reason = "the view needs tiles it has not made"
                if p.tileable and budget_ms is not None:
                    if progress is not None and progress.done:
                        rec.reason = f"resumed at band {progress.done + 1}/{progress.count}"
                    progress = progress or TileProgress(key, self._tile_count(p, r, budget_ms), cover=cover)
                    self._progress[p.name] = progress
                    self._keys.pop(p.name, None)  # its outputs are being overwritten band by band
                    rec.ms = self._run_bands(p, r, frame, timing, progress, t_start, budget_ms)
                    self.frame_ms[p.name] = rec.ms or 0.0
                    rec.draws = self._last_draws
                    if progress.done < progress.count:
                        rec.status = "deferred"
                        rec.reason = f"{rec.reason}; band {progress.done}/{progress.count} done, resumed next frame"
                        records[p.name] = rec
                        partial.update(r.outputs)
                        continue
                    self._finish_bands(p.name)
                    rec.ms = progress.ms
                    if progress.count > 1:
                        rec.reason += f"; in {progress.count} bands"
                else:
                    predicted = self._expected_ms(p, r)
                    if timing == "gpu" and budget_ms is None:  # read after the frame (_collect_queries)
                        query = self._execute(p, r, frame, timing, defer=True, **_covering(cover))
                        self._pending_queries.append((query, rec, p.name, pixels(r), predicted))
                    else:
                        rec.ms = self._execute(p, r, frame, timing, **_covering(cover))
                        self.frame_ms[p.name] = rec.ms or 0.0
                        self._keep_pace(predicted, rec.ms, (p.name, 0))
                rec.draws = self._last_draws
                if r.notes:
                    rec.reason = "; ".join([rec.reason] + r.notes)
                if rec.ms is not None:
                    self._keep_ms(p.name, rec.ms, pixels(r))
                if extend and cover is not None:  # the cells held are as they were: consumers extend theirs
                    self._covered[p.name] = cover[1] | cover[0]
                else:
                    for res in r.outputs:
                        self.res.versions[res] = self.res.versions.get(res, 0) + 1
                    if need is not None:
                        self._covered[p.name] = need
                    else:
                        self._covered.pop(p.name, None)
                self._keys[p.name] = key
                self._keep_stamp(p.name, key, stamp)
                self._unchecked.discard(p.name)
                if self._checking:
                    self._check(p.name, r.outputs)
                else:
                    self._nonfinite[p.name] = []
                    if check_finite:
                        self._unchecked.add(p.name)
            else:
                self._keep_stamp(p.name, old, stamp)
                if self._checking and p.name in self._unchecked and p.name not in self._progress:
                    self._unchecked.discard(p.name)  # ran in a preview; its outputs are as it left them
                    self._check(p.name, r.outputs)
            rec.nonfinite = list(self._nonfinite.get(p.name, []))  # a cached output keeps its flag
            if p.name in self._notes:
                rec.note, rec.figures = self._notes[p.name]
            if rec.status == "cached" and r.notes:
                rec.reason = "; ".join(r.notes)
            if self._lod_notes.get(p.name):  # it drew the mesh at a coarser level (rules.mesh_lod)
                rec.reason = "; ".join(x for x in (rec.reason, self._lod_notes[p.name]) if x)
            records[p.name] = rec
        self._collect_queries()  # the passes' timer queries, read once every pass is issued
        self._collect_checks(records)  # the frame's NaN/Inf scans, read back once every pass is issued
        # pruned: passes of the technique nobody consumes this frame; their outputs go back to the pool
        # (not a resource another pass writes now: ss_diffuse is ss_transmittance's or ss_lighting's)
        settled = self._settled if FAST_CACHED and self._settled is not None \
            and self._settled[0] is self._compiled else None
        for p in self.passes:
            if p.name not in live and settled is not None:
                # pruned last frame under this very compile, its outputs freed and its state dropped then:
                # only the reflection's output names to forget again (_reflect_all keeps them) and its record
                self._produced.pop(p.name, None)
                records[p.name] = settled[1][p.name]
            elif p.name not in live:
                records[p.name] = PassRecord(p.name, "pruned", reason=prune_reasons[p.name],
                                             inputs=list(refl[p.name].inputs))
                for res in (set(refl[p.name].outputs) | self._produced.pop(p.name, set())) - written:
                    if res in self.res.textures:
                        self.res.free(res)
                self._keys.pop(p.name, None)
                self._covered.pop(p.name, None)
                self._nonfinite.pop(p.name, None)
                self._unchecked.discard(p.name)
                self.refining.discard(p.name)
                if p.name in self._progress:
                    self._cancel(p.name)
        self._settled = (self._compiled, {name: records[name] for name in prune_reasons}) if self._compiled else None
        self._starved = bool(budget_ms is not None and not any_ran and any(
            rec.status == "deferred" and rec.reason == "frame time budget spent" for rec in records.values()))
        report = FrameReport(self.frame, timing, [records[p.name] for p in order] +
                             [records[p.name] for p in self.passes if p.name not in live])
        self.last_report = report
        self.run_ms = (time.perf_counter() - t_start) * 1000.0  # this run's wall time
        self.own_ms = max(self.run_ms - self._exec_s * 1000.0, 0.0)
        # programs first compiled during this frame bumped the revision: record it as it is now
        self._idle = idle[:4] + (self.shaders.revision, timing, frame.interactive) if report.complete else None
        return report

    def _record_outputs(self, name: str, r: Reflection) -> dict[str, dict[str, Any]]:
        """A pass's outputs as its record lists them; made once per reflection (FAST_CACHED: the frame
        report's, read only)."""
        kept = self._rec_outputs.get(name)
        if FAST_CACHED and kept is not None and kept[0] is r:
            return kept[1]
        outputs = {k: {"size": list(v.size), "components": v.components, "dtype": v.dtype} for k, v in r.outputs.items()}
        self._rec_outputs[name] = (r, outputs)
        return outputs

    def _stamp(self, p: Pass, r: Reflection, frame: FrameInputs) -> tuple[Any, ...]:
        """What a pass's cache key can differ by between two frames in which it kept its reflection:
        the reflection itself (its settings, programs, outputs and plan parts are made from it while no
        shader was replaced: _key), the shaders' revision, its inputs' versions, the scene if it uses
        it, the camera if it is view-dependent (_key's parts, cheaper than the key)."""
        versions = self.res.versions
        return (r, self.shaders.revision, tuple([versions.get(res, 0) for res in r.inputs]),
                (frame.scene_version, frame.mesh_lod) if p.uses_scene else None,
                frame.view_key if p.view_dependent else None)

    def _clean(self, name: str, old: dict[str, Any] | None, stamp: tuple[Any, ...] | None) -> bool:
        """Whether a pass's kept key ``old`` is this frame's without making it (FAST_CACHED): its stamp
        is the one kept with that very key (_keep_stamp; any new, popped or invalidated key is another
        object) and it is not part-way through its bands."""
        if stamp is None or old is None or name in self._progress:
            return False
        kept = self._stamps.get(name)
        return kept is not None and kept[0] is old and kept[1] == stamp

    def _keep_stamp(self, name: str, key: dict[str, Any] | None, stamp: tuple[Any, ...] | None) -> None:
        """The stamp of the frame in which ``key`` (the pass's kept key, made or found equal) held."""
        if key is None or stamp is None:
            self._stamps.pop(name, None)
        else:
            self._stamps[name] = (key, stamp)

    def _compile(self, refl: dict[str, Reflection], targets: list[str]
                 ) -> tuple[list[Pass], set[str], dict[str, str], set[str]]:
        """The order passes run in, the live set, why each other pass is pruned and what the order
        writes (compiler.py): the last frame's when every pass kept its reflection (the same objects:
        _still_holds) for the same targets (FAST_CACHED), else compiled afresh. A camera move of
        d'Eon's 51 passes spent more on the 32 prune reasons than on its 3 passes' Python."""
        shape = tuple(refl[p.name] for p in self.passes)
        last = self._compiled
        if FAST_CACHED and last is not None and last[1] == tuple(targets) and len(last[0]) == len(shape) \
                and all(a is b for a, b in zip(last[0], shape)):
            return last[2], last[3], last[4], last[5]
        order, live = order_passes(self.passes, refl, targets)
        reasons = {p.name: prune_reason(p.name, refl, live) for p in self.passes if p.name not in live}
        written = {res for p in order for res in refl[p.name].outputs}
        self._compiled = (shape, tuple(targets), order, live, reasons, written)
        return order, live, reasons, written

    def share_costs(self, other: RenderGraph) -> None:
        """Budget a pass never run in this graph by its cost in ``other``, a graph of the same technique
        (a governor's preview graph by the user's), scaled to its output pixels here (_expected_ms),
        instead of as free: the first frame of a preview no longer runs every pass at once. The
        user's settings cost more than a preview's (more iterations, taps), so this errs long; once a
        pass ran here its own cost is used."""
        self._cost_fallback = other

    def share_passes(self, other: RenderGraph) -> None:
        """Let this graph and ``other`` (graphs of one technique: the user's and a governor preview's)
        copy each other's passes: a pass that reads no texture computes from its key alone (settings,
        programs, output specs, scene, camera, plan), so an equal key in the other graph holds the same
        outputs, bit for bit. Issue 27: the user's graph re-rendered the key light's shadow map that the
        preview's graph had just made at the same light after a light drag."""
        if other is not self and other not in self.peers:
            self.peers.append(other)
            other.peers.append(self)

    def _copy_from_peer(self, p: Pass, r: Reflection, key: dict[str, Any], rec: PassRecord, timing: str) -> bool:
        """``p``'s outputs copied from a peer graph whose cache holds ``p`` under ``key`` (complete, not
        part-way through its bands); False where no peer does or ``p`` reads a texture (a texture's
        version is the graph's own: an equal number says nothing across graphs) or keeps state."""
        if not SHARE_PASSES or r.inputs or not r.outputs or p.name in self.refining:
            return False
        if any(spec.components == 3 for spec in r.outputs.values()):
            return False  # RGB float formats need not be colour-renderable (GL 3.3 core): no framebuffer to blit
        for peer in self.peers:
            if peer._keys.get(p.name) != key or p.name in peer._progress or p.name in peer.refining:
                continue
            if any(peer.res.specs.get(res) != spec or res not in peer.res.textures for res, spec in r.outputs.items()):
                continue
            t0 = time.perf_counter()
            if timing == "sync":
                self.ctx.finish()
                t0 = time.perf_counter()
            try:  # one framebuffer per texture: a blit copies one colour buffer to one
                for res in r.outputs:
                    self.ctx.copy_framebuffer(self.res.framebuffer_for((self.res.textures[res],)),
                                              peer.res.framebuffer_for((peer.res.textures[res],)))
            except Exception:  # a format no framebuffer takes (an uploaded table): the pass runs instead
                return False
            for res in r.outputs:
                self.res.versions[res] = self.res.versions.get(res, 0) + 1
            if timing == "sync":
                self.ctx.finish()
            self._exec_s += time.perf_counter() - t0
            rec.status, rec.ms = "ran", (time.perf_counter() - t0) * 1000.0
            self.frame_ms[p.name] = rec.ms
            rec.reason = "copied from a graph of the same technique holding the same key"
            self._keys[p.name] = key
            self._nonfinite[p.name] = list(peer._nonfinite.get(p.name, []))
            if p.name in peer._unchecked:
                self._unchecked.add(p.name)
            else:
                self._unchecked.discard(p.name)
            if p.name in peer._notes:
                self._notes[p.name] = peer._notes[p.name]
                rec.note, rec.figures = peer._notes[p.name]
            if peer._lod_notes.get(p.name):
                self._lod_notes[p.name] = peer._lod_notes[p.name]
            else:
                self._lod_notes.pop(p.name, None)
            rec.nonfinite = list(self._nonfinite[p.name])
            self._last_draws = 0
            return True
        return False

    # -- tiles: a long pass in row bands, across frames --------------------------------------
    def _keep_ms(self, name: str, ms: float, px: int) -> None:
        """A pass's cost at ``px`` output pixels: its last (``_last_ms``) and, with COST_PER_SIZE, that size's."""
        self._last_ms[name] = ms
        self._last_px[name] = px
        at = self._ms_at.setdefault(name, {})
        at.pop(px, None)  # the newest size last: the oldest goes first
        at[px] = ms
        while len(at) > SIZES_KEPT:
            del at[next(iter(at))]

    def _expected_ms(self, p: Pass, r: Reflection) -> float | None:
        """``p``'s last measured cost at the pixels of its outputs now (COST_PER_SIZE), else its last cost
        scaled to them (a governed preview runs the same pass at a quarter of the view, then the whole
        view: a pass not yet run at this size); None: never timed."""
        now = pixels(r)
        ms, then = self._last_ms.get(p.name), self._last_px.get(p.name, 0)
        at = self._ms_at.get(p.name) if COST_PER_SIZE else None
        if ms is not None and now != then and at is not None and now in at:
            return at[now]  # (at the last run's size: its cost, as always)
        fb = self._cost_fallback
        if ms is None and fb is not None:  # never run here: its cost in the user's graph (share_costs)
            ms, then = fb._last_ms.get(p.name), fb._last_px.get(p.name, 0)
        if ms is None:
            return None
        return ms * now / then if then > 0 and now > 0 else ms

    def _tile_count(self, p: Pass, r: Reflection, budget_ms: float) -> int:
        """Bands for a tileable pass: as many as make its costliest band (by its cost over the rows
        last time, paced: an upper bound) at most half the budget, so a band leaves room for the rest
        of the frame; UNMEASURED_TILES before it was ever timed."""
        ms = self._expected_ms(p, r)
        if ms is None:
            return UNMEASURED_TILES
        # split by what it may cost, not by what it cost: its prediction scaled by the pace and the
        # predictions' error margin (_paced), so a machine whose costs stray gets smaller bands (issue 27)
        cost, ms = ms, self._paced(ms, p.name)
        n = max(1, min(MAX_TILES, math.ceil(ms / max(0.5 * budget_ms, 1e-3))))
        # more bands for an uneven profile, but not below MIN_BAND_SHARE of the budget a band on average:
        # a band has a fixed cost of its own (its draw calls, the triangles straddling its edges), so a
        # costly band that does not shrink with the rows (ss_lighting's first) took the pass to 128 bands
        # and the pass to 3x its whole cost (burley2's refinement)
        most = max(n, min(MAX_TILES, int((cost if MIN_BAND_BY_COST else ms) / max(MIN_BAND_SHARE * budget_ms, 1e-3))))
        prof = self._band_profile.get(p.name)
        while prof is not None and n < most and ms * float(band_shares(prof, n).max()) > 0.5 * budget_ms:
            n = min(most, n + max(1, n // 4))
        return self._align_units(p.name, n)

    def _align_units(self, name: str, n: int) -> int:
        """``n`` bands for a pass of d dependent whole-target draws (ExecuteContext.units), as a multiple of
        d: each band is then one sub-band of one draw, so its cost over the bands (the profile) is each
        draw's, and a band is never a whole costly draw. With fewer bands than draws a band was one or
        two whole draws: Gosselin's Poisson blur at 1024² drew 95-126 ms bands in frames of a 90 ms
        budget (issue 27, the longest frames)."""
        d = self._units.get(name, 1)
        if n <= 1 or d <= 1 or not ALIGN_UNITS:
            return n
        return max(1, min(-(-n // d), MAX_TILES // d)) * d if d <= MAX_TILES else n

    def _band_next_ms(self, p: Pass, r: Reflection | None, progress: TileProgress) -> float:
        """What the next band of ``p`` costs: its share of the pass by the cost profile over the
        rows, times the pass's cost (from the bands done so far, else as last measured)."""
        shares = band_shares(self._band_profile.get(p.name), progress.count)
        k = progress.done
        if k >= progress.count:
            return 0.0
        done_share = float(shares[:k].sum())
        expected = self._expected_ms(p, r) if r is not None else None
        if k > 0 and done_share > 0.05:  # the bands done say how this run compares with the last
            total = progress.ms / done_share
        elif expected is not None:
            total = expected
        else:
            total = progress.ms / k * progress.count if k > 0 else 0.0
        return total * float(shares[k])

    def _band_ms_at(self, p: Pass, r: Reflection | None, progress: TileProgress, k: int) -> float:
        """What band ``k`` of ``p`` (at or after the next) is predicted to cost, as _band_next_ms."""
        if k >= progress.count:
            return 0.0
        if k == progress.done:
            return self._band_next_ms(p, r, progress)
        shares = band_shares(self._band_profile.get(p.name), progress.count)
        nxt = self._band_next_ms(p, r, progress)
        return nxt * float(shares[k]) / float(shares[progress.done]) if shares[progress.done] > 0 else nxt

    def _next_ms(self, p: Pass, r: Reflection, progress: TileProgress | None, budget_ms: float) -> float:
        """What running ``p`` next costs, as last measured (scaled to its outputs' pixels now): its
        next band for a tileable pass (band_next_ms), else its whole run; 0 when never measured. With
        the NaN/Inf check that follows the pass's last band, as it last cost (_check_after)."""
        last = self._expected_ms(p, r) or 0.0
        if not p.tileable:
            return last + self._check_after(p.name, None)
        if progress is None:
            progress = TileProgress({}, self._tile_count(p, r, budget_ms))
        return self._band_next_ms(p, r, progress) + self._check_after(p.name, progress)

    def _paced(self, ms: float, name: str = "", draw: int = ANY) -> float:
        """A predicted cost as an upper bound, not a mean: with QUANTILE_MARGIN, times the MARGIN_Q quantile
        of the recent actual / predicted ratios of draw ``draw`` of pass ``name`` (its pass's, every pass's
        while it has few: kernel/margin.py; a preview graph's, the user's graph's until it has its own);
        before any were kept, scaled by how recent predictions fared
        (``pace``, 1 .. PACE_MAX) with a margin of PACE_ERR_K times their mean error (``pace_err``)."""
        f = self.margins.factor(name, draw) if QUANTILE_MARGIN else None
        if f is None and QUANTILE_MARGIN and self._cost_fallback is not None:  # a preview's: the user's graph's
            f = self._cost_fallback.margins.factor(name, draw)
        if f is not None:
            return ms * min(f, MARGIN_MAX)
        return ms * (min(max(self.pace, 1.0), PACE_MAX) + min(PACE_ERR_K * self.pace_err, PACE_ERR_MAX))

    def _draw_of(self, name: str, progress: TileProgress | None, band: int | None = None) -> int:
        """Which of the pass's dependent whole-target draws (ExecuteContext.units) band ``band`` (default:
        the next) of ``progress`` draws: the key of its error statistics (0 for a pass of one draw)."""
        d = self._units.get(name, 1)
        if progress is None or d <= 1 or progress.count < d:
            return 0
        k = progress.done if band is None else band
        return min(k * d // progress.count, d - 1)

    def _fitted_progress(self, p: Pass, r: Reflection, key: dict[str, Any], budget_ms: float,
                         own_ms: float) -> TileProgress | None:
        """DEFER_UNFIT_FIRST, a tileable pass not started, the frame's first to run, whose first band (as
        _tile_count splits it) does not fit what the graph's own time ``own_ms`` left of ``budget_ms``: the
        bands (up to MAX_TILES, aligned to its draws) that make its first band fit that room, paced as
        every band is; None when none do (or it was never measured). The same rows drawn in more bands:
        the same image (issue 27, session 10: the final's first band in the release frame)."""
        room = budget_ms - own_ms
        if not DEFER_UNFIT_FIRST or room < STARVE_MIN_MS or self._expected_ms(p, r) is None:
            return None
        n = self._tile_count(p, r, budget_ms)
        while n < MAX_TILES:
            n = self._align_units(p.name, min(MAX_TILES, 2 * n))
            progress = TileProgress(key, n)
            if self._paced(self._next_ms(p, r, progress, budget_ms), p.name, self._draw_of(p.name, progress)) <= room:
                return progress
            if n >= MAX_TILES or self._align_units(p.name, min(MAX_TILES, 2 * n)) <= n:
                break
        return None

    @staticmethod
    def _fits_a_frame_of_its_own(paced_ms: float, own_ms: float, budget_ms: float) -> bool:
        """DEFER_UNFIT_FIRST: the frame's first pass (its next band), at ``paced_ms``, does not fit what the
        graph's own time ``own_ms`` left of ``budget_ms`` but fits a frame whose own time is small
        (STARVE_MIN_MS): waiting a frame keeps both within the budget."""
        return DEFER_UNFIT_FIRST and own_ms > STARVE_MIN_MS and paced_ms + STARVE_MIN_MS <= budget_ms

    def _keep_pace(self, predicted: float | None, ms: float | None, key: tuple[str, int] | None = None) -> None:
        """A pass (or band) predicted to cost ``predicted`` ms cost ``ms``: update the running pace
        and its error, and the error statistics of ``key`` (pass, draw) the margin is taken from."""
        compiled, self._first_drawn = self._first_drawn, False
        if predicted is None or ms is None or not predicted > 1.0 or not math.isfinite(ms) or compiled:
            return  # (a compile at a first draw: not what the draw costs, and not what the next one will)
        ratio = min(max(ms / predicted, 0.25), 4.0)
        if key is not None and predicted >= MARGIN_MIN_MS:
            self.margins.add(key[0], key[1], ratio)
        # the error of the pace it would have been predicted with: a running mean absolute deviation
        self.pace_err = (1.0 - PACE_WEIGHT) * self.pace_err + PACE_WEIGHT * abs(ratio - self.pace)
        self.pace = (1.0 - PACE_WEIGHT) * self.pace + PACE_WEIGHT * ratio

    def _check_after(self, name: str, progress: TileProgress | None) -> float:
        """What the NaN/Inf check after running ``name`` (its next band, when that is its last) costs
        this frame, as last measured: the graph's own time the budget must leave room for."""
        if not self._checking or (progress is not None and progress.done < progress.count - 1):
            return 0.0
        return self._check_ms.get(name, 0.0)

    def _run_bands(self, p: Pass, r: Reflection, frame: FrameInputs, timing: str, progress: TileProgress,
                   t_start: float, budget_ms: float) -> float | None:
        """Run bands of ``p`` from where ``progress`` stopped until all are done or the next band
        (its share of the pass by the cost profile) would take the frame past the budget; at least
        one band per call. Returns the ms of the bands run now; the profile is kept when all are done."""
        ms_now = 0.0
        chain: list[tuple[int, float]] = []  # bands run since the last glFinish: (band, predicted ms)
        chain_t0 = 0.0

        def close(total_ms: float) -> None:
            """The chain's bands and the band closing it took ``total_ms`` together: shared out by
            their predictions (what each one's own glFinish would have measured, in sum)."""
            nonlocal ms_now
            pred = sum(x for _, x in chain)
            if pred > 0.0:
                self._keep_pace(pred, total_ms, (p.name, self._draw_of(p.name, progress, chain[0][0])))
            for k, x in chain:
                ms = total_ms * x / pred if pred > 0.0 else total_ms / len(chain)
                ms_now += ms - progress.band_ms[k]
                progress.ms += ms - progress.band_ms[k]
                progress.band_ms[k] = ms
            chain.clear()

        while progress.done < progress.count:
            measured = p.name in self._last_ms
            predicted = self._band_next_ms(p, r, progress) if measured else None
            # what the frame has spent, the chain's queued work at its prediction (not yet waited for)
            spent = max((time.perf_counter() - t_start) * 1000.0,
                        (chain_t0 - t_start) * 1000.0 + sum(x for _, x in chain)) if chain else None
            lazy = (timing == "sync" and SAMPLED_SYNC and predicted is not None and predicted > 1.0
                    and self.pace_err <= SAMPLE_ERR and len(chain) < SYNC_EVERY - 1
                    and progress.done + 1 < progress.count
                    and (spent if spent is not None else (time.perf_counter() - t_start) * 1000.0)
                    + self._paced(predicted + self._band_ms_at(p, r, progress, progress.done + 1),
                                  p.name, self._draw_of(p.name, progress))
                    + self._check_after(p.name, progress) <= budget_ms)
            if lazy and not chain:
                self.ctx.finish()  # what ran before is not the chain's
                self._first_drawn = False
                chain_t0 = time.perf_counter()
            t_band = time.perf_counter()
            ms = self._execute(p, r, frame, timing, tile=(progress.done, progress.count), held=progress.held,
                               lazy=lazy or bool(chain), sync_after=not lazy, **_covering(progress.cover))
            if lazy:
                ms = float(predicted or 0.0)  # provisional: the chain's closing glFinish shares out its time
                chain.append((progress.done, ms))
            elif chain:
                chain.append((progress.done, float(predicted if predicted is not None else ms or 0.0)))
                ms = (time.perf_counter() - t_band) * 1000.0  # provisional, replaced by close()
            else:
                self._keep_pace(predicted, ms, (p.name, self._draw_of(p.name, progress)))
            progress.done += 1
            ms_now += ms or 0.0
            progress.ms += ms or 0.0
            progress.band_ms.append(ms or 0.0)
            if chain and not lazy:
                close((time.perf_counter() - chain_t0) * 1000.0)
            now_ms = (time.perf_counter() - t_start) * 1000.0
            if chain:  # a lazy band's work may still be running: the frame's time at its prediction
                now_ms = max(now_ms, (chain_t0 - t_start) * 1000.0 + sum(x for _, x in chain))
            if now_ms + self._paced(self._band_next_ms(p, r, progress), p.name, self._draw_of(p.name, progress)) \
                    + self._check_after(p.name, progress) > budget_ms:
                break
        if chain:  # the last band run was lazy (the look-ahead changed its mind): wait for it now
            t0 = time.perf_counter()
            self.ctx.finish()
            self._exec_s += time.perf_counter() - t0
            close((time.perf_counter() - chain_t0) * 1000.0)
        if progress.done == progress.count and progress.count > 1 and progress.ms > 0:
            self._band_profile[p.name] = np.concatenate([[0.0], np.cumsum(progress.band_ms) / progress.ms])
        return ms_now

    def _finish_bands(self, name: str) -> None:
        progress = self._progress.pop(name)
        for tex in progress.held.values():
            self.res.give(tex)

    def _cancel(self, name: str, keep: bool = False) -> None:
        """Abandon a pass's unfinished bands: held textures back to the pool, no key for its outputs; but with
        ``keep``, when the run was one for the cells its outputs did not hold (kernel/coverage), which writes
        no other cell: its key and the cells it held before are kept."""
        progress = self._progress.get(name)
        extension = progress is not None and progress.cover is not None and progress.cover[1] is not None
        self._finish_bands(name)
        self._keys.pop(name, None)
        self._covered.pop(name, None)  # a cancelled whole run may have overwritten any cell
        if keep and extension and progress is not None:
            self._keys[name] = progress.key
            self._covered[name] = progress.cover[1]
        self.cancelled.append(name)

    @property
    def in_progress(self) -> dict[str, tuple[int, int]]:
        """Tileable passes part-way: name -> (bands done, bands)."""
        return {n: (pr.done, pr.count) for n, pr in self._progress.items()}

    def _collect_queries(self) -> None:
        """The GPU time of the passes whose timer query _execute left to read (timing "gpu" without a
        budget): reading one waits for the GPU to finish that pass, so reading each right after its
        pass kept the CPU idle while the GPU ran it and the GPU idle while the CPU set up the next."""
        pending, self._pending_queries = self._pending_queries, []
        t0 = time.perf_counter()
        for query, rec, name, px, predicted in pending:
            rec.ms = _elapsed_ms(query)
            self._keep_pace(predicted, rec.ms, (name, 0))
            if rec.ms is not None:
                self._keep_ms(name, rec.ms, px)
        self._exec_s += time.perf_counter() - t0  # waiting for the GPU: the passes' time, not the graph's

    def _execute(self, p: Pass, r: Reflection, frame: FrameInputs, timing: str,
                 tile: tuple[int, int] = (0, 1), held: dict[str, Any] | None = None, defer: bool = False,
                 lazy: bool = False, sync_after: bool = True, cover: tuple[Any, Any] | None = None) -> Any:
        """Run ``p`` (or one band of it) and return its ms; ``defer`` (timing "gpu"): its timer query,
        to be read after the frame's last pass (_collect_queries). Sync timing: a glFinish before it
        (none when ``lazy``: a band of a sampled-sync chain, _run_bands) and after it (none unless
        ``sync_after``: its time is then only the CPU's)."""
        ec = ExecuteContext(self, p, r, frame, tile=tile, held=held, cover=cover)
        self._lod_notes.pop(p.name, None)
        t_enter = time.perf_counter()
        first_draws = self.shaders.first_draws
        try:
            if timing == "sync":
                if not lazy:
                    self.ctx.finish()
                t0 = time.perf_counter()
                p.execute(ec)
                if sync_after:
                    self.ctx.finish()
                return (time.perf_counter() - t0) * 1000.0
            query = self.ctx.query(time=True)
            with query:
                p.execute(ec)
            return query if defer else _elapsed_ms(query)
        finally:
            ec._finish()
            self._last_draws = ec.draws
            if self.shaders.first_draws > first_draws:  # a program finished (JIT-compiled) at its first draw
                self._first_drawn = True
            self._exec_s += time.perf_counter() - t_enter

    # -- reliability: memory needed before allocating, non-finite outputs after running ----------
    def plan_bytes(self, refl: dict[str, Reflection], order: list[Pass]) -> tuple[int, list[tuple[str, int]]]:
        return self.res.plan_bytes(refl, order)

    def _check(self, name: str, outputs: dict[str, TexSpec]) -> None:
        """The NaN/Inf check of a pass's outputs: its GPU scans are drawn now, after the pass, and
        read back once the frame's passes are all issued (_collect_checks): a read-back waits for the
        GPU, and one per pass kept the CPU and the GPU taking turns. What it cost is kept for the
        budget's look-ahead (the draws now plus the read-back then)."""
        t0 = time.perf_counter()
        flags = self._scan_nonfinite(outputs)
        synced = self._timing == "sync" and SYNC_CHECKS and bool(flags)
        if synced:  # the scans' GPU time, here where it is predicted, not in the next pass's opening glFinish
            self.ctx.finish()
        dt = time.perf_counter() - t0
        if self._timing != "sync" or synced:  # no glFinish after the pass: llvmpipe waits for it in the scan's
            self._exec_s += dt  # draw; or the scans waited for: GPU time, not the graph's own (own_ms)
        self.check_ms += dt * 1000.0
        self._pending_checks.append((name, flags, dt * 1000.0))

    def _collect_checks(self, records: dict[str, PassRecord] | None = None) -> None:
        """Read back the scans _check drew this frame: each pass's non-finite outputs (and its record's)."""
        pending, self._pending_checks = self._pending_checks, []
        t_all = time.perf_counter()
        for name, flags, ms in pending:
            t0 = time.perf_counter()
            bad: list[str] = []
            for res, tex in flags:
                try:
                    if records is not None and np.frombuffer(tex.read(alignment=1), dtype=np.uint8).any():
                        bad.append(res)
                finally:
                    if not self._kept_scan(tex):
                        self.res.give(tex)
            if records is None:  # abandoned (a frame that raised): checked again when next run
                self._unchecked.add(name)
                continue
            self._nonfinite[name] = bad
            hist = self._check_hist.setdefault(name, [])
            hist.append(ms + (time.perf_counter() - t0) * 1000.0)
            del hist[:-max(CHECKS_KEPT, 1)]
            self._check_ms[name] = float(np.median(hist))
            if name in records:
                records[name].nonfinite = list(bad)
        self._scan_used.clear()  # every kept flag target read: free for the next frame's scans
        # the first read-back waits for whatever the GPU has left of the frame: the passes' time, not the
        # graph's own (own_ms, which the governor counts as the frame's overhead)
        self._exec_s += time.perf_counter() - t_all
        self.check_ms += (time.perf_counter() - t_all) * 1000.0

    def _scan_nonfinite(self, outputs: dict[str, TexSpec]) -> list[tuple[str, moderngl.Texture]]:
        """A GPU scan of each output into a grid of at most 64x64 flags (<= 4 KB to read back; a
        flag is set where a texel is NaN or Inf): (output, its flags texture, taken from the pool:
        the caller reads and gives it back). 8-bit outputs cannot hold one and are skipped."""
        vao_of = self.gpu.fullscreen_vao
        out: list[tuple[str, moderngl.Texture]] = []
        for res, spec in outputs.items():
            if spec.dtype == "f1" or res not in self.res.textures:
                continue
            w, h = spec.size
            gw, gh = min(w, 64), min(h, 64)
            tile = (-(-w // gw), -(-h // gh))
            prog = self._check_program()
            if prog is None:
                return out
            if FAST_CACHED:
                flags, fbo = self._scan_target((gw, gh))
            else:
                flags = self.pool.take(TexSpec((gw, gh), 1, "f1", filter="nearest"))
                fbo = self.res.framebuffer_for((flags,))
            out.append((res, flags))
            fbo.use()
            self.res.textures[res].use(0)
            write_uniform(prog["src"], 0)
            write_uniform(prog["u_tile"], tile)
            write_uniform(prog["u_size"], (w, h))
            vao_of(prog).render(vertices=3)
        return out

    def _scan_target(self, size: tuple[int, int]) -> tuple[moderngl.Texture, moderngl.Framebuffer]:
        """A flags texture of ``size`` and its framebuffer for one scan of this frame, kept across frames
        (FAST_CACHED): a scan draws every texel of it, so a kept one holds what a pooled one would, and
        no framebuffer is made and released per scan a frame. Distinct within a frame (read back at its
        end, _collect_checks, which frees them all for the next)."""
        kept = self._scan_targets.setdefault(size, [])
        k = self._scan_used.get(size, 0)
        if k == len(kept):
            tex = self.pool.take(TexSpec(size, 1, "f1", filter="nearest"))
            kept.append((tex, self.ctx.framebuffer(color_attachments=[tex])))
        self._scan_used[size] = k + 1
        return kept[k]

    def _kept_scan(self, tex: moderngl.Texture) -> bool:
        return any(t is tex for t, _ in self._scan_targets.get(tex.size, ()))

    def _check_program(self) -> moderngl.Program | None:
        """shaders/finite_check.*, from the graph's library, or the project's when the graph was
        given another shader folder (tests); None if it does not compile (no check then). Which
        library is looked up once (FAST_CACHED; a file test per scan before)."""
        lib = self._check_src if FAST_CACHED else None
        if lib is None:
            lib = self.shaders
            if not (lib.root / "finite_check.frag").is_file():
                if self._check_lib is None:
                    self._check_lib = ShaderLibrary(self.ctx, shaders_dir())
                lib = self._check_lib
            self._check_src = lib
        try:
            return lib.get("finite_check")
        except ShaderCompileError:
            return None

    def affected(self, paths: Iterable[str], camera: bool = False) -> list[str]:
        """Passes (execution order of the last frame) that a change of these settings would re-run
        (compiler.affected); based on the last frame's reflection: a change that alters the
        graph's shape may re-run more."""
        return affected(self.order, self._last_refl, paths, camera)

    def predicted_ms(self, passes: Iterable[str]) -> float:
        """The last measured cost of re-running these passes (0 for those never timed)."""
        last = {p.name: p.ms for p in (self.last_report.passes if self.last_report else [])}
        return float(sum(self._last_ms.get(n, last.get(n) or 0.0) for n in passes))

    def programs(self) -> frozenset[tuple[str, tuple[tuple[str, str], ...]]]:
        """The program variants (name, sorted defines) the last frame's passes declared."""
        return frozenset((n, tuple(sorted((str(k), str(v)) for k, v in dict(d).items())))
                         for r in self._last_refl.values() for n, d in r.programs)

    def likely_programs(self) -> list[tuple[str, dict[str, Any]]]:
        """Program variants one toggle away from the last frame's (passes that define
        ``likely_programs(reflection)``): what ShaderLibrary.warm compiles while the viewer idles."""
        out = []
        for p in self.order:
            fn = getattr(p, "likely_programs", None)
            if fn is not None and p.name in self._last_refl:
                out += fn(self._last_refl[p.name])
        return out

    def trim(self) -> None:
        """Release depth buffers no cached framebuffer uses (one is made per render size)."""
        self.res.trim()

    def invalidate(self, pass_name: str | None = None) -> None:
        """Forget cache keys (all, or one pass) so they re-run next frame."""
        if pass_name is None:
            self._keys.clear()
            self._covered.clear()
            for name in list(self._progress):
                self._cancel(name)
        else:
            self._keys.pop(pass_name, None)
            self._covered.pop(pass_name, None)
            if pass_name in self._progress:
                self._cancel(pass_name)

    def release(self) -> None:
        self._collect_checks(None)
        for peer in self.peers:
            if self in peer.peers:
                peer.peers.remove(self)
        self.peers = []
        for name in list(self._progress):
            self._finish_bands(name)
        for p in self.passes:
            p.release()
        self.res.release()
        for kept in self._scan_targets.values():
            for tex, fbo in kept:
                fbo.release()
                self.pool.give(tex)
        self._scan_targets.clear()
        for obj in self.shape_state.pop("gl_objects", {}).values():
            if obj is not None:
                obj[0].release()  # texture_space.work_tiles
        self.gpu.release()
        self.shaders.remove_hook(self.gpu.forget_program)
        if self._check_lib is not None:
            self._check_lib.release()
            self._check_lib = None
        self._check_src = None

    def describe(self) -> list[dict[str, Any]]:
        """The passes in execution order with their declared inputs/outputs and last status."""
        report = self.last_report
        out = report.to_json()["passes"] if report else []
        return out
