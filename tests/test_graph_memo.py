"""Issue 27 (the graph's own CPU work): a scene rule many passes ask (d'Eon's map size, blur plan,
TSM light, the kernel-under-a-pixel rule) is answered once a frame (Reflection.memo). A hit must
leave each pass's reflection exactly as asking afresh would: the settings read declared (the cache
keys), the notes noted and the drops dropped; an edit of a setting read only inside a memoised rule
must still re-run the passes that depend on it."""
from __future__ import annotations

import pytest

from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.pass_api import Reflection


def _rule(r: Reflection, calls: list[int]) -> float:
    calls.append(1)
    r.note("map 256² from screen coverage")
    r.drop("deon_tsm", "kernel under a pixel")
    return float(r.settings.deon.mix) + float(r.settings.deon.irradiance_size)


def test_a_hit_declares_notes_and_drops_as_the_first_ask():
    memo: dict = {}
    calls: list[int] = []
    first, second = Reflection(Settings()), Reflection(Settings())
    first._frame_memo = second._frame_memo = memo
    first.settings.deon.mix  # noqa: B018  (read before the rule: the rule's record must still hold it)
    a = first.memo("rule", lambda rr: _rule(rr, calls))
    b = second.memo("rule", lambda rr: _rule(rr, calls))
    assert a == b and len(calls) == 1
    assert "deon.mix" in second.declared and "deon.irradiance_size" in second.declared
    assert second.notes == ["map 256² from screen coverage"]
    assert second.dropped == {"deon_tsm": "kernel under a pixel"}


def test_a_nested_hit_is_recorded_by_the_outer_rule():
    memo: dict = {}
    calls: list[int] = []
    rs = [Reflection(Settings()) for _ in range(3)]
    for r in rs:
        r._frame_memo = memo
    rs[0].memo("inner", lambda rr: _rule(rr, calls))  # asked alone first
    rs[1].memo("outer", lambda rr: rr.memo("inner", lambda r2: _rule(r2, calls)) + 1.0)  # inner: a hit
    rs[2].memo("outer", lambda rr: pytest.fail("answered by the memo"))
    assert len(calls) == 1
    assert {"deon.mix", "deon.irradiance_size"} <= set(rs[2].declared)
    assert rs[2].dropped == {"deon_tsm": "kernel under a pixel"}


def test_without_a_frame_memo_every_ask_is_fresh():
    calls: list[int] = []
    r = Reflection(Settings())
    r.memo("rule", lambda rr: _rule(rr, calls))
    r.memo("rule", lambda rr: _rule(rr, calls))
    assert len(calls) == 2


def _small(**extra) -> Settings:
    return with_values(Settings(), {"technique": "deon", "render.width": 32, "render.height": 32,
                                    "shadow.map_size": 64, "deon.tsm_size": 64, "deon.irradiance_size": 256,
                                    **extra})


def _reflections(r, s: Settings) -> dict[str, tuple]:
    r.render(s, force=True)
    g = r.graph("deon")
    return {name: (list(x.declared), list(x.notes), dict(x.dropped), x.skip_reason, dict(x._plan),
                   list(x.inputs), dict(x.outputs), list(x.programs))
            for name, x in g._last_refl.items()}


@pytest.mark.parametrize("extra", [{"deon.subpixel_kernel_px": 0.0}, {"deon.subpixel_kernel_px": 4.0},
                                   {"deon.subpixel_kernel_px": 0.0, "deon.irradiance_size_mode": "auto"}],
                         ids=["whole chain", "kernel under a pixel", "auto map size"])
def test_deon_reflects_as_without_the_memo(gl_ctx, monkeypatch, extra):
    """Every d'Eon pass's reflection (declared settings, notes, drops, plan, inputs, outputs,
    programs) with the memo equals the one asked afresh, rule by rule."""
    from skinviewer.engine.renderer import Renderer
    s = _small(**extra)
    r = Renderer(gl_ctx)
    try:
        memoised = _reflections(r, s)
    finally:
        r.release()
    monkeypatch.setattr(Reflection, "memo", lambda self, key, rule: rule(self))
    r = Renderer(gl_ctx)
    try:
        fresh = _reflections(r, s)
    finally:
        r.release()
    assert memoised == fresh


def test_an_edit_read_only_inside_a_memoised_rule_re_runs(gl_ctx):
    """deon.irradiance_size is read by the memoised map-size rule: changing it must re-run the
    irradiance, and a camera move must not."""
    from skinviewer.engine.renderer import Renderer
    s = _small(**{"deon.subpixel_kernel_px": 0.0})  # the whole chain (a 32² view puts the kernel under a pixel)
    r = Renderer(gl_ctx)
    try:
        r.render(s)
        cam = r.render(with_values(s, {"camera.yaw": s.camera.yaw + 5.0}))
        assert "deon_irradiance" not in cam.ran
        edit = r.render(with_values(s, {"camera.yaw": s.camera.yaw + 5.0, "deon.irradiance_size": 512}))
        assert "deon_irradiance" in edit.ran
    finally:
        r.release()


def test_finite_checks_are_read_back_after_the_last_pass(gl_ctx, tmp_path, monkeypatch):
    """render.check_finite: each pass's scan is drawn after it, but read back (a wait for the GPU)
    only once every pass of the frame is issued; the frame's own report still names the pass."""
    import moderngl
    from test_reliability import FS_VERT, Poison

    from skinviewer.kernel.graph import RenderGraph
    from skinviewer.kernel.pass_api import TexSpec
    from skinviewer.kernel.report import FrameInputs
    from skinviewer.kernel.shaders import ShaderLibrary

    events: list[str] = []

    class After(Poison):
        name = "after"

        def reflect(self, r):
            super().reflect(r)
            r.outputs.clear()
            r.input("lit")
            r.output("image", TexSpec((200, 70), 4, "f2"))

        def execute(self, ec):
            events.append("after ran")
            prog = ec.program("fill")
            ec.set(prog, "u_value", 0.5)
            ec.draw_fullscreen(prog, "image")

    (tmp_path / "fill.vert").write_text(FS_VERT)
    (tmp_path / "fill.frag").write_text("#version 330 core\nuniform float u_value;\nout vec4 f;\nvoid main() {"
                                        " f = (ivec2(gl_FragCoord.xy) == ivec2(137, 41)) ? vec4(u_value) : vec4(0.5); }\n")
    g = RenderGraph(gl_ctx, ShaderLibrary(gl_ctx, tmp_path), [Poison(float("nan")), After(0.5)], ["image"])
    read = moderngl.Texture.read

    def spy(tex, *a, **k):
        if tex.size == (64, 64) and tex.components == 1:  # a scan's flags
            events.append("flags read")
        return read(tex, *a, **k)
    monkeypatch.setattr(moderngl.Texture, "read", spy)
    rep = g.run(FrameInputs(Settings(), None, 0, None, "c"))
    assert events[0] == "after ran" and events.count("flags read") == 2  # lit and image, after both passes
    assert rep.nonfinite == {"poison": ["lit"]}
    g.release()


def test_timer_queries_are_read_after_the_last_pass(gl_ctx, shader_dir, monkeypatch):
    """render.timing = gpu without a frame budget (render, bench): every pass's timer query is read
    once all are issued (reading one waits for the GPU); each pass still gets its own figure. Under a
    budget (the viewer) each is read at once: the look-ahead needs it."""
    import moderngl
    from test_graph import Add, Fill, frame, make_graph

    events: list[str] = []

    class Spy(Fill):
        def execute(self, ec):
            events.append("ran")
            super().execute(ec)
    passes = [Spy("fill_a", "a", "render.exposure"), Spy("fill_b", "b", "phong.ambient"), Add("sum", "a", "b", "out")]
    g, _ = make_graph(gl_ctx, shader_dir, passes, ["out"])
    elapsed = moderngl.Query.elapsed

    def spy(q):
        events.append("read")
        return elapsed.fget(q)
    monkeypatch.setattr(moderngl.Query, "elapsed", property(spy))
    for _ in range(2):  # llvmpipe's first query may answer nothing
        events.clear()
        rep = g.run(frame(Settings()), timing="gpu", force=True)
    assert events == ["ran", "ran", "read", "read", "read"]
    assert all(p.ms is None or 0 <= p.ms < 4000 for p in rep.passes)
    assert sum(p.ms is not None for p in rep.passes) >= 1
    events.clear()
    g.run(frame(Settings()), timing="gpu", force=True, budget_ms=1e6)
    assert events == ["ran", "read", "ran", "read", "read"]
    g.release()


def _sequence(s: Settings) -> list[Settings]:
    """A drag, a light move, an edit, a zoom under the coverage rules, back: what reflections see."""
    d = s.lights[0].direction
    auto = with_values(s, {"deon.irradiance_size_mode": "auto", "shadow.map_size_mode": "auto"})
    return [s, with_values(s, {"camera.yaw": s.camera.yaw + 20.0}),
            with_values(s, {"lights.0.direction": (d[0] + 0.3, d[1], d[2])}),
            with_values(s, {"deon.mix": 0.7, "burley.scale": 1.5, "gosselin.scale_x": 2.5}),
            auto, with_values(auto, {"camera.fov_y": 8.0}),
            with_values(auto, {"camera.fov_y": 8.0, "camera.yaw": 30.0}),
            with_values(s, {"lights.0.enabled": False}), s]


@pytest.mark.parametrize("tech", ["deon", "burley2", "gosselin", "ssss"])
def test_reused_reflections_equal_fresh_ones_frame_by_frame(gl_ctx, monkeypatch, tech):
    """RenderGraph reuses a pass's last reflection while nothing it read changed: over a sequence of
    camera, light, edit and coverage changes every frame re-runs the same passes and every pass's
    reflection (settings, plan, inputs, outputs, programs, notes, drops, skip) equals the one a
    fresh reflect makes (REUSE_REFLECTIONS off)."""
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel import graph as graph_mod

    def run(reuse: bool) -> list:
        monkeypatch.setattr(graph_mod, "REUSE_REFLECTIONS", reuse)
        r = Renderer(gl_ctx)
        out = []
        try:
            for s in _sequence(_small(**{"technique": tech, "deon.subpixel_kernel_px": 0.0})):
                rep = r.render(s)
                g = r.graph(tech)
                out.append((rep.ran, {n: (list(x.declared), list(x.notes), dict(x.dropped), x.skip_reason,
                                          dict(x._plan), list(x.inputs), dict(x.outputs), list(x.programs))
                                      for n, x in g._last_refl.items()}))
        finally:
            r.release()
        return out
    fresh, reused = run(False), run(True)
    for k, (a, b) in enumerate(zip(fresh, reused)):
        assert a == b, f"frame {k}"


def test_a_camera_move_reuses_deons_texture_space_reflections(gl_ctx):
    """The point of it: on a camera-only frame the texture-space passes' reflections are reused (the
    view-dependent passes still re-run: their keys hold the camera); after an edit of what they read
    they are made afresh."""
    from skinviewer.engine.renderer import Renderer
    s = _small(**{"deon.subpixel_kernel_px": 0.0})
    r = Renderer(gl_ctx)
    try:
        r.render(s)
        g = r.graph("deon")
        before = dict(g._last_refl)
        r.render(with_values(s, {"camera.yaw": s.camera.yaw + 5.0}))
        assert g._last_refl["deon_irradiance"] is before["deon_irradiance"]
        assert "deon_final" in r.render(with_values(s, {"camera.yaw": s.camera.yaw + 9.0})).ran  # the camera re-keys it
        r.render(with_values(s, {"camera.yaw": s.camera.yaw + 5.0, "deon.irradiance_size": 512}))
        assert g._last_refl["deon_irradiance"] is not before["deon_irradiance"]
        assert g._last_refl["deon_irradiance"].outputs != before["deon_irradiance"].outputs
    finally:
        r.release()


def test_a_reused_reflection_still_re_runs_after_a_shader_edit(gl_ctx, shader_dir):
    """The cache key made from a reused reflection is kept while no shader was replaced; a hot-reloaded
    program re-keys (and re-runs) its pass, and an edit of a setting it declared does too."""
    import os

    from test_graph import Add, Fill, frame, make_graph

    passes = [Fill("fill_a", "a", "render.exposure"), Fill("fill_b", "b", "phong.ambient"), Add("sum", "a", "b", "out")]
    g, lib = make_graph(gl_ctx, shader_dir, passes, ["out"])
    g.run(frame(Settings()))
    assert g.run(frame(Settings(), "cam1")).ran == []  # new settings object, equal: reused, cached
    frag = shader_dir / "fill.frag"
    frag.write_text(frag.read_text() + "\n// edited\n")
    os.utime(frag, (frag.stat().st_mtime + 5, frag.stat().st_mtime + 5))
    lib.reload()
    assert set(g.run(frame(Settings(), "cam2")).ran) == {"fill_a", "fill_b", "sum"}
    assert g.run(frame(Settings(), "cam3")).ran == []
    edited = with_values(Settings(), {"phong.ambient": 0.2})
    assert set(g.run(frame(edited, "cam4")).ran) == {"fill_b", "sum"}
    g.release()
