"""Burley normalized-diffusion blur passes in screen space: Golubev 2018 (HDRP) and the thesis's
contrast-driven two-level sampling (seed 001 §3.4, ch. 4; spec §5, §7). GLSL: shaders/burley_blur.frag
with shaders/lib/burley.glsl; numpy twin: skinviewer/physics/burley.py.

The blur reads the screen-space framework's diffuse irradiance, linear depth (mm) and SSS mask and
writes the blurred diffuse (consumed by the framework's combine pass) and a per-pixel statistics
texture: R samples taken, G extra levels taken, B 1 where the kernel was under the pixel cutoff,
A the base contrast (max channel; -1 where none was computed). ``BurleyCountPass`` sums the statistics
on the GPU (a two-stage reduction) and puts the frame's sample count in the pass report."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, declare
from skinviewer.passes.output import OutputPass
from skinviewer.passes.screen_space import DEPTH, DIFFUSE, CombinePass
from skinviewer.physics import burley as B

# the screen-space framework's resources (skinviewer/passes/screen_space): ss_diffuse rgb irradiance,
# a = SSS mask; ss_depth r = linear depth in mm
IRRADIANCE = DIFFUSE
IRRADIANCE_DTYPE = "f4"  # the blurred output has the irradiance's format: skipped pixels copy it bit for bit

BLURRED = "burley_diffuse"
# reuse: the blur writes its near / far sample sums, the reuse pass pools the far ones into BLURRED
PARTIAL = "burley_partial"
NEAR_W = "burley_near_w"
FAR = "burley_far"
FAR_W = "burley_far_w"
STATS = "burley_stats"
# temporal accumulation: the accumulated estimate, and the running mean (rgb, a = frames in it), ping-ponged
TEMPORAL = "burley_temporal"
HISTORY = ("burley_history_0", "burley_history_1")
HISTORY_OWN = ("burley_history_own_0", "burley_history_own_1")  # with reuse: the mean of the own samples
TEMPORAL_FRAME = ("burley_temporal", "frame")  # shape_state: the seed index of the frame being accumulated
TEMPORAL_LEFT = ("burley_temporal", "left")  # shape_state: frames still to take on this view
SEED_STEP = 7919  # u_seed step per accumulated frame (any change decorrelates the rotation hash)
COUNT = "burley_count"
VIEW = "burley_view"


def declare_profile(r: Reflection) -> None:
    """Declare the ``burley`` fields the profile reads (physics.burley.profile_of_section)."""
    b = r.settings.burley
    declare(b.albedo, b.mfp, b.fit, b.scale)


@dataclass(frozen=True)
class Plan:
    """The sample levels a blur pass takes, and how it decides (physics.burley.Sampling in GLSL terms)."""
    levels: tuple[int, ...]
    cutoffs: tuple[tuple[float, ...], ...] = ()  # one RGB triple per level beyond the base
    split: str = "half-radius"
    contrast: str = "rings"
    always: bool = False
    nested: bool = False
    seed: int = 0
    reuse: int = 0  # neighbourhood reuse radius in px (0: off; BurleyReusePass)
    reuse_split: float = 3.0  # px: samples at least this far from the centre are pooled with the neighbours'
    reuse_dz: float = 0.05  # depth tolerance beyond the local slope, as a fraction of the filter radius
    wide_px: float = 1e30  # kernels at least this wide (filter radius, px) multiply the cutoffs by wide_scale
    wide_scale: float = 1.0
    temporal: int = 0  # frames in each pixel's running mean (BurleyTemporalPass; 0: off)

    def sampling(self, budget: bool) -> B.Sampling:
        cut = tuple(-1.0 if self.always else c for c in self.cutoffs)
        return B.Sampling(self.levels, cut, self.split, self.contrast, budget, self.nested, self.seed, self.wide_px,
                          self.wide_scale)


def seed_of(plan: Plan, state: dict) -> int:
    """The rotation-hash seed of this frame: the plan's, stepped per accumulated frame (temporal)."""
    j = state.get(TEMPORAL_FRAME, 0) if plan.temporal else 0
    return (int(plan.seed) + SEED_STEP * int(j)) % (1 << 32)


def _floats(v) -> str:
    return ", ".join(repr(float(np.float32(x))) for x in v)


def table_defines(plan: Plan, budget: bool) -> dict[str, str]:
    """The sample tables and counts as #defines (the counts specialise the loops: llvmpipe is SIMD)."""
    sets = plan.sampling(budget).sets()
    defs = {"N_SET0": str(sets[0].n), "N_SET1": "0", "N_SET2": "0",
            "N_INNER": str(int(np.count_nonzero(sets[0].inner))),
            "CONTRAST_MINMAX": "1" if plan.contrast == "minmax" else "0",
            "BURLEY_BUDGET": "1" if budget else "0", "BURLEY_ALWAYS": "1" if plan.always else "0",
            "BURLEY_REUSE": "1" if plan.reuse else "0", "BURLEY_FILTER_RADIUS_UNIT": repr(B.FILTER_RADIUS_UNIT)}
    if not np.all(sets[0].inner[:np.count_nonzero(sets[0].inner)]):
        raise ValueError("inner ring must be the first samples by radius")
    for k, s in enumerate(sets):
        defs[f"N_SET{k}"] = str(s.n)
        defs[f"SET{k}_X_TABLE"] = f"float[{s.n}]({_floats(s.x)})"
        defs[f"SET{k}_RCP_TABLE"] = f"float[{s.n}]({_floats(s.rcp_pdf)})"
        cs = s.cos_sin
        defs[f"SET{k}_CS_TABLE"] = f"vec2[{s.n}](" + ", ".join(
            f"vec2({_floats(c)})" for c in cs) + ")"
    return defs


# burley2.mode "beyond": the variant that beat the thesis's Table 4.1 target on the default head (benchmarks/
# bench_table41.py; notes/ss2.md): 9 base samples with an equal-count ring split (the outer mean rests on 4-5
# samples instead of 2, spec §7.3), 11 extra where C > 0.35 (x 2 where the kernel is >= 20 px wide, whose
# far samples the reuse pools), and the far samples (>= 0.5 px) pooled over the 3x3 neighbourhood
BEYOND_PLAN = Plan((9, 11), ((0.35, 0.35, 0.35),), split="equal-count", reuse=1, reuse_split=0.5, wide_px=20.0,
                   wide_scale=2.0)


def golubev_plan(b) -> Plan:
    """The ``burley`` section (``r.settings.burley`` or a BurleySettings) -> Golubev's one level."""
    return Plan((int(b.samples),))


def two_level_plan(b2) -> Plan:
    """The ``burley2`` section (``r.settings.burley2`` or a Burley2Settings) -> levels. ``thesis``:
    Algorithm 1 (base, extra, cutoff on the ring contrast); ``three-level``: a third level and a
    second cutoff on top of it."""
    mode = b2.mode
    if mode == "beyond":
        return replace(BEYOND_PLAN, temporal=int(b2.temporal))
    t = b2.threshold
    c1 = tuple(float(t) * float(s) for s in b2.channel_scale)
    levels: tuple[int, ...] = (int(b2.base), int(b2.extra))
    cutoffs: tuple[tuple[float, ...], ...] = (c1,)
    if mode == "three-level" and int(b2.third) > 0:
        t2 = float(b2.threshold2)
        levels += (int(b2.third),)
        cutoffs += (tuple(t2 * float(s) for s in b2.channel_scale),)
    return Plan(levels, cutoffs, b2.split, b2.contrast, nested=mode == "nested",
                reuse=int(b2.reuse), reuse_split=float(b2.reuse_split),
                wide_px=float(b2.wide_px), wide_scale=float(b2.wide_scale),
                temporal=int(b2.temporal))


class BurleyBlurPass(Pass):
    """One full-screen pass: Golubev's per-pixel Burley estimator (spec §5.3), optionally multi-level
    (spec §7.5-7.6). ``variant``: "golubev" (``burley.samples``) or "two_level" (``burley2.*``);
    ``plan`` fixes the levels instead (tests, the bench's pooled estimator)."""
    view_dependent = True
    uses_scene = False
    tileable = True  # one full-screen draw: in row bands under the viewer's frame budget (issue 27)

    def __init__(self, variant: str = "golubev", plan: Plan | None = None, name: str = "burley_blur"):
        if variant not in ("golubev", "two_level"):
            raise ValueError(f"unknown variant {variant!r}")
        self.variant = variant
        self.fixed_plan = plan
        self.name = name

    def _plan(self, r: Reflection) -> Plan:
        if self.fixed_plan is not None:
            return self.fixed_plan
        return golubev_plan(r.settings.burley) if self.variant == "golubev" else two_level_plan(r.settings.burley2)

    def reflect(self, r: Reflection) -> None:
        declare_profile(r)
        budget = bool(r.settings.burley.budget)
        if self.fixed_plan is None:
            if self.variant == "golubev":
                declare(r.settings.burley.samples)
            else:
                declare(r.settings.burley2)
        plan = self._plan(r)
        r.program("burley_blur", **table_defines(plan, budget))
        if plan.temporal:
            r.depends("temporal_frame", r.state.get(TEMPORAL_FRAME, 0))
        for res in (IRRADIANCE, DEPTH):
            r.input(res)
        w, h = r.settings.render.width, r.settings.render.height
        r.plan(sampling=plan, height=h)
        r.output(PARTIAL if plan.reuse else BLURRED, TexSpec((w, h), 4, IRRADIANCE_DTYPE, filter="nearest"))
        r.output(STATS, TexSpec((w, h), 4, "f2", filter="nearest"))
        if plan.reuse:
            for res in (NEAR_W, FAR, FAR_W):
                r.output(res, TexSpec((w, h), 4, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        plan = ec.plan.sampling
        prog = ec.program("burley_blur")  # the variant reflect declared (table_defines)
        prof = B.profile_of_section(ec.settings.burley)
        view = ec.view
        h = ec.plan.height
        cut = plan.cutoffs + ((1e30,) * 3,) * (2 - len(plan.cutoffs))
        ec.uniforms(prog, u_proj_scale=float(view.proj[1, 1]) * h / 2.0, u_filter_radius=prof.filter_radius,
                    u_S=tuple(float(v) for v in prof.S), u_d=prof.d, u_seed=seed_of(plan, ec.state))
        # the cutoffs are dropped by the compiler in Golubev's variant (no contrast test)
        ec.set(prog, "u_cutoff1", tuple(float(c) for c in cut[0]), optional=True)
        ec.set(prog, "u_cutoff2", tuple(float(c) for c in cut[1]), optional=True)
        ec.set(prog, "u_wide_px", float(plan.wide_px), optional=True)
        ec.set(prog, "u_wide_scale", float(plan.wide_scale), optional=True)
        ec.textures(prog, irradiance=IRRADIANCE, lin_depth=DEPTH)
        if plan.reuse:
            ec.set(prog, "u_reuse_split", float(plan.reuse_split))
        with ec.band():  # a tileable pass (issue 27): this band's rows
            ec.draw_fullscreen(prog, *((PARTIAL, STATS, NEAR_W, FAR, FAR_W) if plan.reuse else (BLURRED, STATS)))


class BurleyReusePass(Pass):
    """Neighbourhood reuse (shaders/burley_reuse.frag): pools the far samples' weighted sums of the (2R+1)^2
    pixels around each pixel (a tent, same surface only); declares nothing (and is pruned) without reuse."""
    view_dependent = True
    uses_scene = False
    name = "burley_reuse"

    def __init__(self, plan: Plan | None = None):
        self.fixed_plan = plan

    def _plan(self, r: Reflection) -> Plan:
        return self.fixed_plan if self.fixed_plan is not None else two_level_plan(r.settings.burley2)

    @staticmethod
    def _defines(plan: Plan) -> dict[str, str]:
        return {"REUSE_R": str(plan.reuse)}

    def reflect(self, r: Reflection) -> None:
        if self.fixed_plan is None:
            if r.peeked.burley2.reuse == 0 and r.peeked.burley2.mode != "beyond":
                return
            declare(r.settings.burley2)
        plan = self._plan(r)
        declare_profile(r)
        r.program("burley_reuse", **self._defines(plan))
        r.plan(sampling=plan)
        for res in (PARTIAL, NEAR_W, FAR, FAR_W, DEPTH):
            r.input(res)
        w, h = r.settings.render.width, r.settings.render.height
        r.output(BLURRED, TexSpec((w, h), 4, IRRADIANCE_DTYPE, filter="nearest"))

    def execute(self, ec) -> None:
        plan = ec.plan.sampling
        prog = ec.program("burley_reuse")
        prof = B.profile_of_section(ec.settings.burley)
        ec.uniforms(prog, u_reuse_dz=plan.reuse_dz * prof.filter_radius)
        ec.textures(prog, partial=PARTIAL, near_w=NEAR_W, far=FAR, far_w=FAR_W, lin_depth=DEPTH)
        ec.draw_fullscreen(prog, BLURRED)


class BurleyTemporalPass(Pass):
    """Temporal accumulation on a still view (``burley2.temporal`` frames; shaders/burley_temporal.frag):
    each frame's estimate, taken with a new rotation seed, joins a per-pixel running mean of up to N
    frames. Any change (camera included) restarts the mean from that frame, so a moving view shows the
    plain per-frame estimate. With neighbourhood reuse (beyond) it also keeps the mean of each pixel's
    own samples and moves to it as frames come in: the restart frame is the clean pooled estimate, the
    converged image has no pooling bias. While the mean fills, the pass asks the graph for more frames
    (``ec.refine``); once N frames are in, it and the blur stay cached. Declares nothing (pruned) when
    temporal is 0."""
    view_dependent = True
    uses_scene = False
    name = "burley_temporal"

    def __init__(self, plan: Plan | None = None):
        self.fixed_plan = plan
        self._last: tuple | None = None  # (what the mean was taken of, history index written)

    def _plan(self, r: Reflection) -> Plan:
        return self.fixed_plan if self.fixed_plan is not None else two_level_plan(r.settings.burley2)

    def reflect(self, r: Reflection) -> None:
        if self.fixed_plan is None:
            if r.peeked.burley2.temporal == 0:
                return
            declare(r.settings.burley2)
        plan = self._plan(r)
        r.depends("temporal_frame", r.state.get(TEMPORAL_FRAME, 0))
        r.program("burley_temporal", **self._defines(plan))
        r.plan(sampling=plan)
        declare_profile(r)
        declare(r.settings.burley.budget)
        # the lighting pass's outputs: a new version (camera, lights, scene, size...) restarts the mean
        for res in (BLURRED, IRRADIANCE, DEPTH) + ((PARTIAL, NEAR_W, FAR, FAR_W) if plan.reuse else ()):
            r.input(res)
        w, h = r.settings.render.width, r.settings.render.height
        r.output(TEMPORAL, TexSpec((w, h), 4, IRRADIANCE_DTYPE, filter="nearest"))
        for res in HISTORY + (HISTORY_OWN if plan.reuse else ()):
            r.output(res, TexSpec((w, h), 4, "f4", filter="nearest"))

    @staticmethod
    def _defines(plan: Plan) -> dict[str, str]:
        return {"TEMPORAL_REUSE": "1" if plan.reuse else "0"}

    def execute(self, ec) -> None:
        plan = ec.plan.sampling
        # the mean holds while the lighting pass's outputs (their versions), the profile and the plan are
        # the ones it was taken of: only the blur's seed changed
        b = ec.settings.burley
        taken_of = (ec.input_version(IRRADIANCE), ec.input_version(DEPTH), plan,
                    tuple(repr(v) for v in (b.albedo, b.mfp, b.fit, b.scale, b.budget)))
        last = self._last
        reset = last is None or last[0] != taken_of
        write = 0 if last is None else 1 - last[1]
        prog = ec.program("burley_temporal")
        ec.uniforms(prog, u_max_n=float(plan.temporal), u_reset=int(reset))
        ec.textures(prog, current=BLURRED, history=ec.output(HISTORY[1 - write]))
        targets: tuple[str, ...] = (TEMPORAL, HISTORY[write])
        if plan.reuse:  # the own samples' mean beside the pooled one (shaders/burley_temporal.frag)
            ec.textures(prog, partial=PARTIAL, near_w=NEAR_W, far=FAR, far_w=FAR_W,
                        history_own=ec.output(HISTORY_OWN[1 - write]))
            targets += (HISTORY_OWN[write],)
        ec.draw_fullscreen(prog, *targets)
        self._last = (taken_of, write)
        # frames still to take: N - 1 after a restart, then one fewer per frame
        left = plan.temporal - 1 if reset else max(int(ec.state.get(TEMPORAL_LEFT, 0)) - 1, 0)
        ec.state[TEMPORAL_LEFT] = left
        if left > 0:
            ec.state[TEMPORAL_FRAME] = int(ec.state.get(TEMPORAL_FRAME, 0)) + 1
        ec.refine(left > 0)
        done = plan.temporal - left
        ec.note(f"temporal: frame {done} of {plan.temporal} in the mean" + (" (restarted)" if reset else ""),
                frames=done, restarted=bool(reset))

    def release(self) -> None:
        self._last = None


class BurleyCombinePass(CombinePass):
    """The framework's combine pass reading the accumulated estimate when ``burley2.temporal`` is on."""

    def reflect(self, r: Reflection) -> None:
        self.source = TEMPORAL if r.peeked.burley2.temporal > 0 else BLURRED
        super().reflect(r)


@dataclass(frozen=True)
class SampleCount:
    """The frame's figures, summed on the GPU from the statistics texture."""
    samples: int  # samples taken (every SSS pixel above the cutoff)
    pixels: int  # SSS pixels blurred
    triggered: int  # pixels that took at least one extra level
    skipped: int  # SSS pixels under the pixel cutoff (output = input)

    @property
    def per_pixel(self) -> float:
        return self.samples / max(self.pixels, 1)

    def summary(self) -> str:
        trig = 100.0 * self.triggered / max(self.pixels, 1)
        return (f"{self.samples:,} samples on the GPU ({self.per_pixel:.2f}/px over {self.pixels:,} px); "
                f"extra: {trig:.1f} % px; skipped (kernel < 1 px): {self.skipped:,} px")


def _split(hi: float, lo: float) -> int:
    return round(float(hi)) * 4096 + round(float(lo))


class BurleyCountPass(Pass):
    """Sums the blur's statistics texture on the GPU: each row (stage 1, exact in float up to 2^24),
    then the rows in uint (stage 2, written as 4096-based hi/lo pairs, exact up to 2^36); reads back
    the two resulting texels and reports the figures (``last`` and the pass report's note)."""
    name = "burley_count"
    uses_scene = False

    def __init__(self):
        self.last: SampleCount | None = None

    def reflect(self, r: Reflection) -> None:
        r.input(STATS)
        declare(r.settings.render.width)
        r.plan(rows=TexSpec((1, r.settings.render.height), 4, "f4", filter="nearest"))  # stage 1's row sums
        r.program("burley_count", STAGE="1")
        r.program("burley_count", STAGE="2")
        r.output(COUNT, TexSpec((2, 1), 4, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        rows = ec.scratch(ec.plan.rows)
        p1 = ec.program("burley_count", STAGE="1")
        ec.bind(p1, "stats", STATS)
        ec.draw_fullscreen(p1, rows)
        p2 = ec.program("burley_count", STAGE="2")
        ec.bind(p2, "rows", rows)
        ec.draw_fullscreen(p2, COUNT)
        raw = np.frombuffer(ec.output(COUNT).read(), dtype=np.float32).reshape(2, 4)
        self.last = SampleCount(samples=_split(raw[0, 0], raw[0, 1]), triggered=_split(raw[0, 2], raw[0, 3]),
                                skipped=_split(raw[1, 0], raw[1, 1]), pixels=_split(raw[1, 2], raw[1, 3]))
        ec.note(self.last.summary(), samples=self.last.samples, pixels=self.last.pixels,
                triggered=self.last.triggered, skipped=self.last.skipped)


VIEW_MODES = ("image", "extra", "samples")


class BurleyViewPass(Pass):
    """The view modes (``burley.view``): ``extra`` tints the pixels that took extra samples (magenta; a
    second extra level orange) and those under the pixel cutoff (blue) over the lit image; ``samples``
    shows samples per pixel as a heat map (black 0 ... white at the plan's maximum)."""
    name = "burley_view"
    uses_scene = False

    def reflect(self, r: Reflection) -> None:
        r.input("lit")
        r.input(STATS)
        declare(r.settings.burley.view)
        w, h = r.settings.render.width, r.settings.render.height
        r.program("burley_view")
        r.output(VIEW, TexSpec((w, h), 4, "f2"))

    def execute(self, ec) -> None:
        prog = ec.program("burley_view")
        ec.textures(prog, lit="lit", stats=STATS)
        ec.uniforms(prog, u_mode=VIEW_MODES.index(ec.settings.burley.view), u_max_samples=32.0)
        ec.draw_fullscreen(prog, VIEW)


class BurleyOutputPass(OutputPass):
    """The output pass, fed by the view pass when ``burley.view`` is not ``image``."""

    def reflect(self, r: Reflection) -> None:
        self.source = "lit" if r.settings.burley.view == "image" else VIEW
        super().reflect(r)

