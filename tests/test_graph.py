"""The pass graph: ordering, pruning, caching (settings, inputs, shaders, camera), timing, pooling."""
from __future__ import annotations

import time

import numpy as np
import pytest
from helpers import FS_VERT, small_settings

from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.compiler import order_passes
from skinviewer.kernel.graph import (
    FrameInputs,
    GraphError,
    Pass,
    Reflection,
    RenderGraph,
    TexSpec,
)
from skinviewer.kernel.shaders import ShaderLibrary


class Fill(Pass):
    uses_scene = False

    def __init__(self, name, out, setting):
        self.name, self.out, self.setting_path = name, out, setting

    def reflect(self, r: Reflection):
        r.setting(self.setting_path)
        r.program("fill")
        r.output(self.out, TexSpec((8, 8), 4, "f4"))

    def execute(self, ec):
        prog = ec.program("fill")
        ec.set(prog, "u_value", float(ec.setting(self.setting_path)))
        ec.draw_fullscreen(prog, self.out)


class Add(Pass):
    uses_scene = False

    def __init__(self, name, a, b, out, view_dependent=False):
        self.name, self.a, self.b, self.out = name, a, b, out
        self.view_dependent = view_dependent

    def reflect(self, r):
        r.input(self.a)
        r.input(self.b)
        r.program("add")
        r.output(self.out, TexSpec((8, 8), 4, "f4"))

    def execute(self, ec):
        prog = ec.program("add")
        ec.textures(prog, a=self.a, b=self.b)  # a sampler the compiler dropped is skipped
        ec.draw_fullscreen(prog, self.out)


def make_graph(gl_ctx, shader_dir, passes, targets):
    lib = ShaderLibrary(gl_ctx, shader_dir)
    g = RenderGraph(gl_ctx, lib, passes, targets)
    return g, lib


def frame(s, view_key="cam0"):
    return FrameInputs(settings=s, scene=None, scene_version=0, view=None, view_key=view_key)


def test_orders_producers_first_and_computes(gl_ctx, shader_dir):
    # listed consumer-first on purpose
    passes = [Add("sum", "a", "b", "out"), Fill("fill_a", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient")]
    g, _ = make_graph(gl_ctx, shader_dir, passes, ["out"])
    s = with_values(Settings(), {"render.exposure": 2.0, "phong.ambient": 0.25})
    rep = g.run(frame(s))
    assert [p.name for p in g.order] == ["fill_a", "fill_b", "sum"]
    assert rep.ran == ["fill_a", "fill_b", "sum"]
    assert np.allclose(g.read("out"), 2.25)


def test_prunes_unconsumed_and_caches(gl_ctx, shader_dir):
    passes = [Fill("fill_a", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient"),
              Fill("unused", "c", "phong.specular"), Add("sum", "a", "b", "out")]
    g, _ = make_graph(gl_ctx, shader_dir, passes, ["out"])
    s = Settings()
    rep = g.run(frame(s))
    assert rep.pruned == ["unused"]
    rep = g.run(frame(s))
    assert rep.ran == [] and set(rep.cached) == {"fill_a", "fill_b", "sum"}
    # a setting re-runs exactly the pass that declared it and its consumers
    rep = g.run(frame(with_values(s, {"phong.ambient": 0.5})))
    assert rep.ran == ["fill_b", "sum"] and "fill_a" in rep.cached
    assert "setting phong.ambient" in next(p.reason for p in rep.passes if p.name == "fill_b")
    assert "input b" in next(p.reason for p in rep.passes if p.name == "sum")
    # a setting nobody declared re-runs nothing
    rep = g.run(frame(with_values(s, {"phong.ambient": 0.5, "gosselin.iterations": 7})))
    assert rep.ran == []


def test_camera_reruns_only_view_dependent(gl_ctx, shader_dir):
    passes = [Fill("fill_a", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient"),
              Add("final", "a", "b", "out", view_dependent=True)]
    g, _ = make_graph(gl_ctx, shader_dir, passes, ["out"])
    s = Settings()
    g.run(frame(s, "cam0"))
    rep = g.run(frame(s, "cam1"))
    assert rep.ran == ["final"]
    assert next(p.reason for p in rep.passes if p.name == "final") == "camera"


def test_shader_edit_reruns_users(gl_ctx, shader_dir):
    passes = [Fill("fill_a", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient"), Add("sum", "a", "b", "out")]
    g, lib = make_graph(gl_ctx, shader_dir, passes, ["out"])
    s = with_values(Settings(), {"render.exposure": 1.0})  # a = 1
    g.run(frame(s))
    time.sleep(0.01)
    p = shader_dir / "add.frag"
    p.write_text(p.read_text().replace("texture(a, v_uv) + texture(b, v_uv)", "texture(a, v_uv) * 3.0"))
    replaced, errors = lib.reload()
    assert replaced == ["add"] and not errors
    rep = g.run(frame(s))
    assert rep.ran == ["sum"]
    assert np.allclose(g.read("out"), 3.0)


def test_undeclared_setting_is_an_error(gl_ctx, shader_dir):
    class Sneaky(Fill):
        def execute(self, ec):
            ec.setting("phong.shininess")

    g, _ = make_graph(gl_ctx, shader_dir, [Sneaky("s", "a", "render.exposure")], ["a"])
    with pytest.raises(GraphError, match="did not declare"):
        g.run(frame(Settings()))


def test_writing_an_undeclared_output_is_an_error(gl_ctx, shader_dir):
    class Trespasser(Fill):
        def execute(self, ec):
            ec.framebuffer("a")  # written by another pass

    g, _ = make_graph(gl_ctx, shader_dir, [Fill("fill_a", "a", "render.exposure"), Trespasser("t", "b", "phong.ambient")],
                      ["a", "b"])
    with pytest.raises(GraphError, match="did not declare as an output"):
        g.run(frame(Settings()))


def test_graph_errors(gl_ctx, shader_dir):
    g, _ = make_graph(gl_ctx, shader_dir, [Add("x", "y_out", "b", "x_out"), Add("y", "x_out", "b", "y_out"),
                                            Fill("fb", "b", "render.exposure")], ["x_out"])
    with pytest.raises(GraphError, match="cycle"):
        g.run(frame(Settings()))
    g, _ = make_graph(gl_ctx, shader_dir, [Add("x", "nowhere", "b", "out"), Fill("fb", "b", "render.exposure")], ["out"])
    with pytest.raises(GraphError, match="no pass writes"):
        g.run(frame(Settings()))


def test_timing_modes_are_reported(gl_ctx, shader_dir):
    passes = [Fill("fill_a", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient"), Add("sum", "a", "b", "out")]
    g, _ = make_graph(gl_ctx, shader_dir, passes, ["out"])
    rep = g.run(frame(Settings()), timing="sync")
    assert rep.timing_mode == "sync" and all(p.ms is not None and p.ms >= 0 for p in rep.passes)
    assert "glFinish" in rep.to_json()["timing_note"]
    rep = g.run(frame(Settings()), timing="gpu", force=True)
    assert rep.timing_mode == "gpu"
    # timer queries may answer nothing useful on llvmpipe; never a bogus 0xFFFFFFFF figure
    assert all(p.ms is None or 0 <= p.ms < 4000 for p in rep.passes)


def test_pool_reuses_textures(gl_ctx, shader_dir):
    passes = [Fill("fill_a", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient"),
              Fill("fill_c", "c", "phong.specular"), Add("sum", "a", "b", "out")]
    g, _ = make_graph(gl_ctx, shader_dir, passes, ["out"])
    g.run(frame(Settings()), targets=["out", "c"])
    allocated = g.pool.allocated
    g.run(frame(Settings()), targets=["out"])  # c pruned: its texture goes back to the pool
    assert "c" not in g.resources()
    g.run(frame(Settings()), targets=["out", "c"])  # ...and comes back from it
    assert g.pool.allocated == allocated and g.pool.reused >= 1
    rep = g.last_report
    assert "fill_c" in rep.ran  # its old output was released, so it must run again


# -- the real Phong graph ------------------------------------------------------------------------

def test_phong_graph_caching_rules(renderer):
    s = small_settings("shadow-edge", "phong")
    rep = renderer.render(s)
    assert set(rep.ran) == {"shadow_map_0", "phong", "output"}
    # the environment light's pass (issue 32) is in every graph, pruned without an environment light
    # so are the shadow maps' bounds (the PCF's early-out, issue 27: off by default, nobody reads them)
    bounds = {f"shadow_bounds_{i}" for i in range(4)}
    assert set(rep.pruned) == {"shadow_map_1", "shadow_map_2", "shadow_map_3", "environment"} | bounds
    rep = renderer.render(s)
    assert rep.ran == []
    rep = renderer.render(with_values(s, {"camera.yaw": 10.0}))
    assert set(rep.ran) == {"phong", "output"}, rep.table()
    s2 = with_values(s, {"camera.yaw": 10.0})
    rep = renderer.render(with_values(s2, {"lights.0.color": [1.0, 0.5, 0.5]}))
    assert set(rep.ran) == {"phong", "output"}  # colour is not part of the light's pose
    rep = renderer.render(with_values(s2, {"lights.0.color": [1.0, 0.5, 0.5], "lights.0.direction": [0.1, 0.0, 1.0]}))
    assert set(rep.ran) == {"shadow_map_0", "phong", "output"}
    rep = renderer.render(with_values(s2, {"lights.0.color": [1.0, 0.5, 0.5], "lights.0.direction": [0.1, 0.0, 1.0],
                                           "render.exposure": 2.0}))
    assert rep.ran == ["output"]


def test_second_light_adds_its_shadow_map(renderer):
    s = small_settings("shadow-edge", "phong")
    renderer.render(s)
    lights = [l.model_dump() for l in s.lights] + [{"kind": "point", "position": [50.0, 50.0, 80.0]}]
    rep = renderer.render(with_values(s, {"lights": lights}))
    assert "shadow_map_1" in rep.ran and "shadow_map_0" in rep.cached


def test_affected_predicts_what_a_change_reruns(renderer):
    """The graph can say, before an edit, which passes it would re-run (and their last cost)."""
    s = small_settings("shadow-edge", "phong")
    renderer.render(s)
    g = renderer.graph("phong")
    assert g.affected(["camera.yaw"]) == []  # the camera is not a declared setting...
    assert g.affected([], camera=True) == ["phong", "output"]  # ...it reaches view-dependent passes
    assert g.affected(["render.exposure"]) == ["output"]
    assert g.affected(["lights.0.direction"]) == ["shadow_map_0", "phong", "output"]
    assert g.affected(["lights"]) == ["shadow_map_0", "phong", "output"]  # a parent path
    assert g.predicted_ms(["phong", "output"]) > 0
    # the prediction matches what really re-runs
    for change in ({"lights.0.color": [1.0, 0.2, 0.2]}, {"shadow.map_size": 512}, {"phong.shininess": 8.0}):
        path = next(iter(change))
        predicted = g.affected([path])
        rep = renderer.render(with_values(s, change))
        assert rep.ran == predicted, (change, rep.ran, predicted)
        renderer.render(s)


def test_time_budget_spreads_a_frame_over_several(renderer):
    """With a tiny budget each call runs one pass (or bands of one tileable pass); the frame
    completes after at least as many calls as it has passes to run, and the image is only written
    by the last of them."""
    s = small_settings("shadow-edge", "gosselin")
    renderer.render(s, force=True)
    s2 = with_values(s, {"lights.0.direction": [0.1, 0.0, 1.0]})
    image_before = renderer.read(s, "image").copy()
    done: list[str] = []
    calls = 0
    for _ in range(4000):
        rep = renderer.render(s2, budget_ms=1e-6)
        calls += 1
        done += rep.ran
        if rep.complete:
            break
        assert len(rep.ran) <= 1 and rep.deferred
        assert np.array_equal(renderer.read(s, "image"), image_before)  # no half-updated image
    assert rep.complete and calls >= len(set(done))
    assert set(done) == set(renderer.graph("gosselin").affected(["lights.0.direction"]))
    assert renderer.render(s2).ran == []  # all cached now


def test_trim_releases_depth_buffers_of_old_sizes(renderer):
    s = small_settings("shadow-edge", "phong", size=64)
    renderer.render(s)
    renderer.render(with_values(s, {"render.width": 80}))
    g = renderer.graph("phong")
    assert len(g.res.depth) >= 2  # the 64x64 lit image's depth buffer is no longer used...
    renderer.trim()
    assert (64, 64) not in g.res.depth and (80, 64) in g.res.depth  # ...and goes; the one in use stays
    assert renderer.render(with_values(s, {"render.width": 80})).ran == []  # nothing cached was lost


def test_idle_frames_take_the_fast_path_and_stay_correct(renderer, monkeypatch):
    from skinviewer.kernel import graph as graph_mod
    monkeypatch.setattr(graph_mod, "REUSE_REFLECTIONS", False)  # the full check reflects (tests/test_graph_memo.py)
    s = small_settings("shadow-edge", "gosselin")
    renderer.render(s)
    g = renderer.graph("gosselin")
    calls = []
    for p in g.passes:
        p.reflect = (lambda f: (lambda r: (calls.append(1), f(r))[1]))(p.reflect)
    rep = renderer.render(s)  # the same settings object: nothing is reflected
    assert calls == [] and rep.ran == [] and set(rep.cached) == {p.name for p in g.order}
    rep = renderer.render(with_values(s, {}))  # an equal but new object: the full check, still all cached
    assert calls and rep.ran == []
    g.shaders.revision += 1  # any shader replaced: the full check again
    calls.clear()
    renderer.render(s)
    assert calls


# -- the ExecuteContext services ------------------------------------------------------------------

class Custom(Pass):
    """A pass whose execute is given as a function (service tests)."""
    uses_scene = False

    def __init__(self, name, program, out, body, inputs=()):
        self.name, self.prog_name, self.out, self.body, self.inputs = name, program, out, body, inputs

    def reflect(self, r):
        for res in self.inputs:
            r.input(res)
        r.setting("render.exposure")
        r.program(self.prog_name)
        r.output(self.out, TexSpec((8, 8), 4, "f4"))

    def execute(self, ec):
        self.body(ec, ec.program(self.prog_name))


def _run_one(gl_ctx, shader_dir, body, program="fill", inputs=(), extra=()):
    g, lib = make_graph(gl_ctx, shader_dir, [*extra, Custom("custom", program, "out", body, inputs)], ["out"])
    g.run(frame(Settings()))
    return g, lib


def test_misspelt_uniform_fails_loudly_naming_pass_program_and_uniform(gl_ctx, shader_dir):
    def body(ec, prog):
        ec.set(prog, "u_valeu", 1.0)
        ec.draw_fullscreen(prog, "out")

    with pytest.raises(GraphError, match=r"pass custom: program 'fill' declares no uniform 'u_valeu'"):
        _run_one(gl_ctx, shader_dir, body)


def test_declared_but_unused_uniform_and_optional_names_are_skipped(gl_ctx, shader_dir):
    (shader_dir / "fill.frag").write_text("#version 330 core\nuniform float u_value;\nuniform float u_unused;\n"
                                          "out vec4 f;\nvoid main() { f = vec4(u_value); }\n")

    def body(ec, prog):
        assert "u_unused" not in prog  # the compiler dropped it; the source declares it
        ec.uniforms(prog, u_value=0.5, u_unused=3.0)
        ec.set(prog, "u_not_in_this_variant", 1.0, optional=True)
        ec.draw_fullscreen(prog, "out")

    g, _ = _run_one(gl_ctx, shader_dir, body)
    assert np.allclose(g.read("out"), 0.5)


def test_textures_by_name_units_allocated_and_unbound_samplers_read_a_dummy(gl_ctx, shader_dir):
    stale = gl_ctx.texture((8, 8), 4, np.full((8, 8, 4), 7.0, np.float32).tobytes(), dtype="f4")

    def body(ec, prog):
        for unit in range(4):  # whatever an earlier pass left on the units...
            stale.use(unit)
        ec.bind(prog, "a", "a")  # ...b is not bound: it reads the 1x1 zero texture, not a stale unit
        ec.draw_fullscreen(prog, "out")

    g, _ = _run_one(gl_ctx, shader_dir, body, program="add", inputs=("a",),
                    extra=[Fill("fill_a", "a", "phong.ambient")])
    assert np.allclose(g.read("out"), Settings().phong.ambient)
    stale.release()

    def undeclared(ec, prog):
        ec.bind(prog, "c", "a")

    with pytest.raises(GraphError, match="declares no uniform 'c'"):
        _run_one(gl_ctx, shader_dir, undeclared, program="add", inputs=("a",),
                 extra=[Fill("fill_a", "a", "phong.ambient")])


def test_scratch_targets_and_undeclared_targets(gl_ctx, shader_dir):
    def body(ec, prog):
        tmp = ec.scratch(TexSpec((8, 8), 4, "f4"))
        ec.set(prog, "u_value", 0.25)
        ec.draw_fullscreen(prog, tmp)
        ec.set(prog, "u_value", 0.75)
        ec.draw_fullscreen(prog, "out")
        with pytest.raises(GraphError, match="did not declare as an output"):
            ec.draw_fullscreen(prog, "elsewhere")
        with pytest.raises(GraphError, match="scratch"):
            ec.draw_fullscreen(prog, ec.graph.pool.take(TexSpec((8, 8), 4, "f4")))

    g, _ = _run_one(gl_ctx, shader_dir, body)
    assert np.allclose(g.read("out"), 0.75)


def test_one_vao_cache_released_on_hot_reload_and_release(gl_ctx, shader_dir):
    passes = [Fill("fill_a", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient"), Add("sum", "a", "b", "out")]
    g, lib = make_graph(gl_ctx, shader_dir, passes, ["out"])
    s = with_values(Settings(), {"render.check_finite": False})  # only the passes' own programs
    g.run(frame(s))
    assert len(g.gpu._vaos) == 2  # fill and add, one each
    old = lib.get("add")
    time.sleep(0.01)
    p = shader_dir / "add.frag"
    p.write_text(p.read_text().replace("texture(a, v_uv) + texture(b, v_uv)", "texture(a, v_uv) * 2.0"))
    lib.reload()
    assert all(prog is not old for prog, _, _ in g.gpu._vaos.values())  # released with the program
    g.run(frame(s))
    assert len(g.gpu._vaos) == 2
    g.release()
    assert g.gpu._vaos == {} and g.gpu.forget_program not in lib._release_hooks


def test_settings_sections_are_read_only_and_declared(gl_ctx, shader_dir):
    seen = {}

    class Sectioned(Fill):
        def reflect(self, r):
            super().reflect(r)
            r.section("phong", ("ambient", "shininess"))

        def execute(self, ec):
            ph = ec.section("phong", ("ambient", "shininess"))
            seen["ambient"] = ph.ambient
            with pytest.raises(AttributeError, match="read-only"):
                ph.ambient = 2.0
            with pytest.raises(AttributeError, match="no field 'specular'"):
                ph.specular
            with pytest.raises(GraphError, match="did not declare"):
                ec.section("phong", ("specular",))
            super().execute(ec)

    g, _ = make_graph(gl_ctx, shader_dir, [Sectioned("s", "a", "render.exposure")], ["a"])
    g.run(frame(with_values(Settings(), {"phong.ambient": 0.125})))
    assert seen["ambient"] == 0.125
    rep = g.run(frame(with_values(Settings(), {"phong.ambient": 0.25})))
    assert rep.ran == ["s"]  # a section's fields are declared settings


class Counting(Fill):
    """A Fill that reports a figure (what a pass like burley_count puts in the frame report)."""

    def execute(self, ec):
        super().execute(ec)
        ec.note("filled", value=float(ec.setting(self.setting_path)))


def test_frames_count_by_one_and_cached_passes_keep_their_figures(gl_ctx, shader_dir):
    """Issue 36's mutation run: the frame counter steps by one per run; a cached pass's record keeps the
    figures of the run that made its output; the reason names what changed; a bad TexSpec says why."""
    g, _ = make_graph(gl_ctx, shader_dir, [Counting("fill_a", "out", "render.exposure")], ["out"])
    s = with_values(Settings(), {"render.exposure": 2.0})
    frames = []
    for k in range(3):
        rep = g.run(frame(s))
        frames.append(rep.frame)
        rec = next(p for p in rep.passes if p.name == "fill_a")
        assert rec.status == ("ran" if k == 0 else "cached") and rec.figures == {"value": 2.0}, rec
    assert frames[1] - frames[0] == 1 and frames[2] - frames[1] == 1
    rep = g.run(frame(with_values(s, {"render.exposure": 3.0})))
    rec = next(p for p in rep.passes if p.name == "fill_a")
    assert rec.status == "ran" and "render.exposure" in rec.reason and rec.figures == {"value": 3.0}
    with pytest.raises(ValueError, match=r"bad texture size \(0, 8\)"):
        TexSpec((0, 8), 4, "f4")
    with pytest.raises(ValueError):
        TexSpec((8, 8), 4, "f8")


class SlowFill(Fill):
    """A Fill whose execute takes ``ms`` of wall time (what a long pass costs on a slow machine)."""

    def __init__(self, name, out, setting, ms):
        super().__init__(name, out, setting)
        self.ms = ms

    def execute(self, ec):
        time.sleep(self.ms / 1000.0)
        super().execute(ec)


def test_a_budget_defers_the_pass_its_last_cost_would_push_past_it(gl_ctx, shader_dir):
    """Under a budget the graph looks ahead: a pass whose last measured cost would take the frame
    past the budget waits for the next frame (it used to run whenever the budget was not yet spent,
    so a 40 ms budget could end a 75 ms frame); the first pass of a frame always runs."""
    passes = [SlowFill("fill_a", "a", "render.exposure", 30.0), SlowFill("fill_b", "b", "render.exposure", 30.0),
              Add("sum", "a", "b", "out")]
    g, _ = make_graph(gl_ctx, shader_dir, passes, ["out"])
    s = Settings()
    g.run(frame(s))  # measured: 30 ms each
    s2 = with_values(s, {"render.exposure": 2.0})
    # 55 ms: the adder's last cost (sync timing, its first draw's shader compile) has 25 ms beside fill_b, not
    # 10: a 40 ms budget failed when another test process shared the 2 cores (pytest-xdist workers)
    rep = g.run(frame(s2), budget_ms=55.0)
    assert rep.ran == ["fill_a"] and not rep.complete  # 30 + 30 > 55: fill_b waits
    rep = g.run(frame(s2), budget_ms=55.0)
    assert rep.ran == ["fill_b", "sum"] and rep.complete  # the adder's last cost fits beside it
    assert np.allclose(g.read("out"), 4.0)


def test_auto_timing_is_sync_on_a_software_rasterizer_and_timer_queries_on_a_gpu(renderer):
    """render.timing = auto (the default): no glFinish between passes on a hardware GPU (timer
    queries there), sync on llvmpipe & co., whose timer queries are far too low."""
    from types import SimpleNamespace

    from skinviewer.kernel.gl import software_renderer
    assert Settings().render.timing == "auto"
    for name, soft in (("llvmpipe (LLVM 15.0.6, 256 bits)", True), ("softpipe", True),
                       ("Google SwiftShader", True), ("NVIDIA H100 80GB HBM3/PCIe/SSE2", False),
                       ("AMD Radeon RX 7900 XTX (radeonsi, navi31, LLVM 17.0.6, DRM 3.54)", False),
                       ("Mesa Intel(R) Arc(tm) A770 Graphics (DG2)", False)):
        assert software_renderer(SimpleNamespace(info={"GL_RENDERER": name})) is soft, name
    want = "sync" if software_renderer(renderer.ctx) else "gpu"
    assert renderer.timing_mode("auto") == want
    assert renderer.timing_mode("sync") == "sync" and renderer.timing_mode("gpu") == "gpu"
    rep = renderer.render(small_settings("shadow-edge", "phong", size=32))
    assert rep.timing_mode == want


# ---------------------------------------------------------------------------------------------
# issue 36, second round: the kernel's paths the seeded mutation sample found untested

class Spec(Pass):
    """Fills one output of a given TexSpec with u_value (a NaN/Inf-able uniform in one corner)."""
    uses_scene = False

    def __init__(self, name, out, spec, value=0.3, bad=None, uses_scene=False, depends=None, skip=None):
        self.name, self.out, self.spec, self.value, self.bad = name, out, spec, value, bad
        self.uses_scene, self.depends, self.skip = uses_scene, depends, skip

    def reflect(self, r):
        if self.skip:
            r.skip(self.skip)
            return
        if self.depends is not None:
            r.depends("frame index", self.depends)
        r.program("corner")
        r.output(self.out, self.spec)

    def execute(self, ec):
        prog = ec.program("corner")
        w, h = self.spec.size
        bad = self.bad if self.bad is not None else self.value
        ec.uniforms(prog, u_value=self.value, u_bad=bad, u_corner=(w - 1.0, h - 1.0))
        ec.draw_fullscreen(prog, self.out)

    def likely_programs(self, r):
        return [("corner", {"VARIANT": "1"})]


@pytest.fixture
def corner_dir(shader_dir):
    (shader_dir / "corner.vert").write_text(FS_VERT)
    (shader_dir / "corner.frag").write_text(
        "#version 330 core\nuniform float u_value;\nuniform float u_bad;\nuniform vec2 u_corner;\nout vec4 f;\n"
        "void main() { f = all(greaterThan(gl_FragCoord.xy, u_corner)) ? vec4(u_bad) : vec4(u_value); }\n")
    return shader_dir


@pytest.mark.parametrize("dtype,components,value,expect", [("f1", 1, 0.2, 51 / 255), ("f2", 2, 0.375, 0.375),
                                                           ("f4", 3, 0.3, float(np.float32(0.3)))])
def test_read_back_every_format_in_its_shape(gl_ctx, corner_dir, dtype, components, value, expect):
    """read(): (h, w, components) float32 from 8-bit unorm (x / 255), half and float targets (values exact in
    each format: a GPU's rounding to half or unorm is its own)."""
    g, _ = make_graph(gl_ctx, corner_dir, [Spec("fill", "out", TexSpec((7, 5), components, dtype), value=value)],
                      ["out"])
    g.run(frame(Settings()))
    got = g.read("out")
    assert got.shape == (5, 7, components) and got.dtype == np.float32
    np.testing.assert_array_equal(got, np.float32(expect))
    g.release()


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_scan_finds_one_texel_in_the_far_corner_of_a_large_target(gl_ctx, corner_dir, bad):
    """render.check_finite: the scan folds a 300 x 200 target into at most 64 x 64 tiles; a single bad texel
    in the last row and column is found; a clean target and an 8-bit one are not flagged."""
    passes = [Spec("big", "big", TexSpec((300, 200), 4, "f4"), bad=bad),
              Spec("clean", "clean", TexSpec((300, 200), 4, "f2")),
              Spec("bytes", "bytes", TexSpec((70, 70), 4, "f1"), bad=bad)]
    g, _ = make_graph(gl_ctx, corner_dir, passes, ["big", "clean", "bytes"])
    s = with_values(Settings(), {"render.check_finite": True})
    rep = g.run(frame(s))
    flags = {p.name: p.nonfinite for p in rep.passes}
    assert flags == {"big": ["big"], "clean": [], "bytes": []}
    assert not np.isfinite(g.read("big")[-1, -1]).all() and np.isfinite(g.read("big")[:-1]).all()
    rep = g.run(frame(s))  # cached: the flag stays with the output
    assert {p.name: p.nonfinite for p in rep.passes}["big"] == ["big"]
    g.release()


def test_scene_version_depends_values_skips_and_likely_programs(gl_ctx, corner_dir):
    """A pass that uses the scene re-runs when the scene version changes (reason "scene"), one that does not
    stays cached; a value declared with r.depends re-runs its pass; a skipped pass is pruned with its
    reason; likely_programs gathers the passes' one-toggle-away variants."""
    spec = TexSpec((8, 8), 4, "f4")
    scene_pass = Spec("on_scene", "a", spec, uses_scene=True)
    dep = Spec("progressive", "b", spec, depends=0)
    passes = [scene_pass, dep, Spec("screen", "c", spec), Spec("never", "d", spec, skip="not needed here")]
    g, _ = make_graph(gl_ctx, corner_dir, passes, ["a", "b", "c"])
    s = Settings()
    g.run(FrameInputs(settings=s, scene=None, scene_version=1, view=None, view_key="cam0"))
    rep = g.run(FrameInputs(settings=s, scene=None, scene_version=2, view=None, view_key="cam0"))
    assert rep.ran == ["on_scene"]
    assert next(p.reason for p in rep.passes if p.name == "on_scene") == "scene"
    dep.depends = 1  # a new settings object of equal values: not the idle fast path
    rep = g.run(FrameInputs(settings=Settings(), scene=None, scene_version=2, view=None, view_key="cam0"))
    assert rep.ran == ["progressive"]
    never = next(p for p in rep.passes if p.name == "never")
    assert never.status == "pruned" and never.reason == "pruned: not needed here"
    assert g.likely_programs() == [("corner", {"VARIANT": "1"})] * 3
    g.release()


def test_memory_plan_counts_outputs_depth_and_ping_pong(gl_ctx, corner_dir):
    """plan_bytes: every live output, one depth buffer (4 bytes a texel) per size that needs one, and two
    copies of the largest pass's outputs, with the outputs listed largest first; a frame that needs more
    than is available is refused before anything is allocated, naming the largest."""
    passes = [Spec("small", "s", TexSpec((16, 16), 4, "f1")),
              Spec("large", "l", TexSpec((64, 32), 4, "f4", depth=True)),
              Spec("middle", "m", TexSpec((32, 32), 2, "f2", depth=True))]
    g, _ = make_graph(gl_ctx, corner_dir, passes, ["s", "l", "m"])
    refl = g._reflect_all(Settings())
    order, _ = order_passes(g.passes, refl, ["s", "l", "m"])
    total, per = g.plan_bytes(refl, order)
    sizes = {"s": 16 * 16 * 4, "l": 64 * 32 * 16, "m": 32 * 32 * 4}
    assert per == [("l", sizes["l"]), ("m", sizes["m"]), ("s", sizes["s"])]
    assert total == sum(sizes.values()) + 4 * (64 * 32 + 32 * 32) + 2 * sizes["l"]
    g.memory_available = total - 1
    with pytest.raises(Exception, match=r"largest: l 0\.0 MB"):
        g.run(frame(Settings()))
    assert g.resources() == {}
    g.memory_available = total
    g.run(frame(Settings()))
    assert set(g.resources()) == {"s", "l", "m"}
    g.release()


class Rows(Fill):
    """A tileable Fill: each band writes its rows (ec.band())."""
    tileable = True

    def execute(self, ec):
        prog = ec.program("fill")
        ec.set(prog, "u_value", float(ec.setting(self.setting_path)))
        with ec.band():
            ec.draw_fullscreen(prog, self.out)


def test_a_tileable_pass_runs_in_bands_across_frames_and_restarts_when_its_key_changes(gl_ctx, shader_dir):
    """Under a spent budget a never-timed tileable pass takes UNMEASURED_TILES (4) row bands, one a frame:
    deferred with "band k/4 done" until the last, whose output is whole; a key change mid-way cancels it
    and starts over; the band count then follows the measured cost: ceil(ms / (budget / 2)), 1..128."""
    import skinviewer.kernel.graph as graph_mod
    p = Rows("rows", "out", "render.exposure")
    g, _ = make_graph(gl_ctx, shader_dir, [p], ["out"])
    g.run(frame(with_values(Settings(), {"render.exposure": 1.0})))  # whole, no budget: 1.0 everywhere
    g._last_ms.pop("rows")  # as if never timed
    s = with_values(Settings(), {"render.exposure": 2.0})
    seen = []
    for k in range(graph_mod.UNMEASURED_TILES):
        rep = g.run(frame(with_values(s, {})), budget_ms=1e-9)
        rec = rep.passes[0]
        seen.append((rec.status, g.in_progress.get("rows")))
        if k == 0:
            assert rec.reason == "setting render.exposure; band 1/4 done, resumed next frame"
            got = g.read("out")[..., 0]
            # rows 0-1 (band 1 of 4 of 8 rows) written, bottom first; the others still hold the last frame
            assert np.all(got[:2] == 2.0) and np.all(got[2:] == 1.0)
        elif k < 3:
            assert rec.reason.startswith(f"resumed at band {k + 1}/4")
    assert seen == [("deferred", (1, 4)), ("deferred", (2, 4)), ("deferred", (3, 4)), ("ran", None)]
    assert rep.passes[0].reason.endswith("in 4 bands") and np.all(g.read("out") == 2.0)
    # a change of key part-way: the bands already run are abandoned
    # (now timed: any cost over half of a 1e-9 ms budget is the most bands, 128)
    g.run(frame(with_values(s, {"render.exposure": 3.0})), budget_ms=1e-9)
    assert g.in_progress == {"rows": (1, graph_mod.MAX_TILES)} and g.cancelled == []
    g.run(frame(with_values(s, {"render.exposure": 4.0})), budget_ms=1e-9)
    assert g.cancelled == ["rows"] and g.in_progress == {"rows": (1, graph_mod.MAX_TILES)}
    g.release()
    # the band count from the last measured cost
    g, _ = make_graph(gl_ctx, shader_dir, [p], ["out"])
    r = g._reflect_all(Settings(), None)["rows"]
    assert g._tile_count(p, r, 2.0) == graph_mod.UNMEASURED_TILES
    for ms, budget, bands in ((3.0, 2.0, 3), (2.5, 2.0, 3), (0.5, 2.0, 1), (0.0, 2.0, 1), (1e6, 2.0, 128)):
        g._last_ms["rows"] = ms
        assert g._tile_count(p, r, budget) == bands, (ms, budget)
    g.release()


class Dropper(Spec):
    """A consumer that does not read ``source`` this frame, for a reason (r.drop)."""

    def __init__(self, name, out, spec, source, why):
        super().__init__(name, out, spec)
        self.source, self.why = source, why

    def reflect(self, r):
        r.drop(self.source, self.why)
        super().reflect(r)


def test_dropped_inputs_name_why_their_producer_is_pruned_and_release_frees_shape_objects(gl_ctx, corner_dir):
    """A producer whose only consumer dropped its output is reported "pruned: <the consumer's reason>";
    likely_programs skips passes without the hook; release() releases the GL objects a pass kept in the
    graph's shape state (texture_space.work_tiles' tile tables)."""
    spec = TexSpec((8, 8), 4, "f4")
    passes = [Spec("maker", "extra", spec), Dropper("user", "out", spec, "extra", "no ear in this scene"),
              Fill("plain", "p", "render.exposure")]
    g, _ = make_graph(gl_ctx, corner_dir, passes, ["out", "p"])
    rep = g.run(frame(Settings()))
    maker = next(p for p in rep.passes if p.name == "maker")
    assert maker.status == "pruned" and maker.reason == "pruned: no ear in this scene"
    assert g.likely_programs() == [("corner", {"VARIANT": "1"})]  # "plain" has no likely_programs

    class Held:
        released = False

        def release(self):
            self.released = True
    held = Held()
    g.shape_state["gl_objects"] = {"work_tiles": (held, 3), "none": None}
    g.release()
    assert held.released and "gl_objects" not in g.shape_state


class TwoHalves(Fill):
    """Two draws, each into one half of the rows (ec.band(sub, subs)): the whole target in two draws."""

    def execute(self, ec):
        prog = ec.program("fill")
        ec.set(prog, "u_value", float(ec.setting(self.setting_path)))
        for k in range(2):
            with ec.band(k, 2):
                ec.draw_fullscreen(prog, self.out)


class Sized(Fill):
    """A Fill whose output size follows render.width (a resolution change reallocates it)."""

    def reflect(self, r):
        super().reflect(r)
        r.output(self.out, TexSpec((int(r.setting("render.width")) // 80, 8), 4, "f4"))


class Multi(Spec):
    """Two outputs: an 8-bit one first (not scanned), then a float one with a NaN in a corner."""

    def reflect(self, r):
        r.program("corner")
        r.output("bytes", TexSpec((8, 8), 4, "f1"))
        r.output(self.out, self.spec)

    def execute(self, ec):
        prog = ec.program("corner")
        w, h = self.spec.size
        ec.uniforms(prog, u_value=0.5, u_bad=float("nan"), u_corner=(w - 1.0, h - 1.0))
        ec.draw_fullscreen(prog, self.out)
        ec.uniforms(prog, u_bad=0.5)
        ec.draw_fullscreen(prog, "bytes")


def test_kernel_bookkeeping_sub_bands_resizes_budgets_idle_frames_and_prune_chains(gl_ctx, corner_dir):
    """Sub-band draws cover the target and are counted; a producer reallocated at a new size re-runs its
    consumer; a spent budget defers the next pass with "frame time budget spent"; an idle frame reports the
    passes' inputs; a pass whose consumer is pruned for a reason is pruned "(via consumer)"; an
    unconsumed pass says so; a pass's later float output is scanned after an 8-bit one."""
    spec = TexSpec((8, 8), 4, "f4")
    g, _ = make_graph(gl_ctx, corner_dir, [TwoHalves("halves", "h", "render.exposure")], ["h"])
    rep = g.run(frame(with_values(Settings(), {"render.exposure": 1.5})))
    assert rep.passes[0].draws == 2 and np.all(g.read("h") == 1.5)
    g.release()
    # resize: the producer is reallocated and re-runs; its consumer (fixed size) re-runs with it
    passes = [Sized("sized", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient"), Add("sum", "a", "b", "out")]
    g, _ = make_graph(gl_ctx, corner_dir, passes, ["out"])
    g.run(frame(with_values(Settings(), {"render.width": 640})))
    rep = g.run(frame(with_values(Settings(), {"render.width": 800})))
    assert rep.ran == ["sized", "sum"]
    # a spent budget: the first pass runs, the next is deferred and says why
    rep = g.run(frame(with_values(Settings(), {"render.width": 800, "render.exposure": 5.0, "phong.ambient": 0.7})),
                budget_ms=1e-9)
    reasons = {p.name: (p.status, p.reason) for p in rep.passes}
    assert reasons["sized"][0] == "ran" and reasons["fill_b"] == ("deferred", "frame time budget spent")
    # an idle frame (the very same settings object) reports the same passes with their inputs
    s = with_values(Settings(), {"render.width": 800})
    g.run(frame(s))
    last = {p.name: p.inputs for p in g.run(frame(s)).passes}
    assert last == {"sized": [], "fill_b": [], "sum": ["a", "b"]}
    g.release()
    # prune chains: base -> mid -> (dropped by the target's pass); an unconsumed pass
    passes = [Spec("base", "base_out", spec), Add("mid", "base_out", "base_out", "mid_out"),
              Dropper("user", "out", spec, "mid_out", "no ear in this scene"), Spec("lonely", "nobody", spec)]
    g, _ = make_graph(gl_ctx, corner_dir, passes, ["out"])
    rep = {p.name: p.reason for p in g.run(frame(Settings())).passes}
    assert rep["mid"] == "pruned: no ear in this scene"
    assert rep["base"] == "pruned: no ear in this scene (via mid)"
    assert rep["lonely"] == "output not consumed"
    g.release()
    g, _ = make_graph(gl_ctx, corner_dir, [Multi("multi", "big", TexSpec((100, 70), 4, "f4"))], ["big", "bytes"])
    rep = g.run(frame(with_values(Settings(), {"render.check_finite": True})))
    assert rep.passes[0].nonfinite == ["big"]
    g.release()


MESH_VERT = """#version 330 core
in vec2 in_pos;
void main() { gl_Position = vec4(in_pos, 0.0, 1.0); }
"""


class OneTriangle:
    """A stand-in for the GPU scene: a mesh of one triangle that covers the whole target (the kernel only
    asks the scene for ``vertex_array(prog, lod)``)."""

    def __init__(self, ctx):
        self.buf = ctx.buffer(np.array([-1, -1, 3, -1, -1, 3], "f4").tobytes())
        self.ctx = ctx

    def vertex_array(self, prog, lod=0):
        return self.ctx.vertex_array(prog, [(self.buf, "2f", "in_pos")])


class MeshRows(Fill):
    """A tileable pass that rasterises the scene's mesh (ec.draw_mesh, which clears first) in row bands."""
    uses_scene = True
    tileable = True

    def reflect(self, r):
        r.setting(self.setting_path)
        r.program("meshfill")
        r.output(self.out, TexSpec((8, 8), 4, "f4"))

    def execute(self, ec):
        prog = ec.program("meshfill")
        ec.set(prog, "u_value", float(ec.setting(self.setting_path)))
        with ec.band():
            ec.draw_mesh(prog, self.out)


class MeshHalves(MeshRows):
    """Two mesh draws in one run, each into one half of the rows (ec.band(sub, subs)), each clearing."""
    tileable = False

    def execute(self, ec):
        prog = ec.program("meshfill")
        ec.set(prog, "u_value", float(ec.setting(self.setting_path)))
        for k in range(2):
            with ec.band(k, 2):
                ec.draw_mesh(prog, self.out)


def test_a_banded_mesh_pass_clears_only_its_own_rows(gl_ctx, shader_dir):
    """draw_mesh clears colour and depth before it draws; in a band that clear must stay inside the band's
    rows (fbo.clear(viewport=rect)): a band that cleared its whole target would wipe the rows the earlier
    bands (or the last frame) wrote. Band by band across frames, then two sub-bands in one run."""
    import skinviewer.kernel.graph as graph_mod
    (shader_dir / "meshfill.vert").write_text(MESH_VERT)
    (shader_dir / "meshfill.frag").write_text((shader_dir / "fill.frag").read_text())
    scene = OneTriangle(gl_ctx)

    def mesh_frame(value, version=1):
        s = with_values(Settings(), {"render.exposure": value})
        return FrameInputs(settings=s, scene=scene, scene_version=version, view=None, view_key="cam0")

    g, _ = make_graph(gl_ctx, shader_dir, [MeshRows("rows", "out", "render.exposure")], ["out"])
    g.run(mesh_frame(1.0))  # whole, no budget
    assert np.all(g.read("out")[..., 0] == 1.0)
    g._last_ms.pop("rows")  # as if never timed: UNMEASURED_TILES (4) bands of 2 rows, one a frame
    for k in range(graph_mod.UNMEASURED_TILES):
        g.run(mesh_frame(2.0), budget_ms=1e-9)
        got = g.read("out")[..., 0]
        rows = 2 * (k + 1)
        # bands 1..k+1 drawn (bottom first); the rows above still hold the last frame's 1.0, not the clear's 0
        assert np.all(got[:rows] == 2.0) and np.all(got[rows:] == 1.0), (k, got[:, 0])
    assert g.in_progress == {}
    g.release()
    g, _ = make_graph(gl_ctx, shader_dir, [MeshHalves("halves", "h", "render.exposure")], ["h"])
    rep = g.run(mesh_frame(1.5))
    assert rep.passes[0].draws == 2 and np.all(g.read("h")[..., 0] == 1.5)
    g.release()
    scene.buf.release()


class OwnState(Fill):
    """A pass whose reflect reads state of its own, set from outside, without declaring it (the
    contract says r.depends): only a forced run is bound to see it."""

    def reflect(self, r: Reflection):
        r.setting(self.setting_path)
        r.program("fill")
        r.output(self.out, TexSpec((self.n, self.n), 4, "f4"))


def test_a_forced_run_reflects_every_pass_afresh(gl_ctx, shader_dir):
    p = OwnState("sized", "out", "render.exposure")
    p.n = 8
    g, _ = make_graph(gl_ctx, shader_dir, [p], ["out"])
    s = Settings()
    g.run(frame(s))
    p.n = 12  # nothing the reflection read changed: a plain run may reuse it; force must not
    g.run(frame(s, "cam1"), force=True)
    assert g.read("out").shape[:2] == (12, 12)
