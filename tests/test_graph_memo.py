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
    a = first.memo("rule", lambda: _rule(first, calls))
    b = second.memo("rule", lambda: _rule(second, calls))
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
    rs[0].memo("inner", lambda: _rule(rs[0], calls))  # asked alone first
    rs[1].memo("outer", lambda: rs[1].memo("inner", lambda: _rule(rs[1], calls)) + 1.0)  # inner: a hit
    rs[2].memo("outer", lambda: pytest.fail("answered by the memo"))
    assert len(calls) == 1
    assert {"deon.mix", "deon.irradiance_size"} <= set(rs[2].declared)
    assert rs[2].dropped == {"deon_tsm": "kernel under a pixel"}


def test_without_a_frame_memo_every_ask_is_fresh():
    calls: list[int] = []
    r = Reflection(Settings())
    r.memo("rule", lambda: _rule(r, calls))
    r.memo("rule", lambda: _rule(r, calls))
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
    monkeypatch.setattr(Reflection, "memo", lambda self, key, make: make())
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
