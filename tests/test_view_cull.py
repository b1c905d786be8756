"""deon.view_cull (issue 27; notes/deon_light_move.md section 17): d'Eon's texture-space passes make only the
tiles the current view reads (passes/view_cull.py), and a camera move makes the tiles they do not hold yet
(kernel/coverage: the graph's record of what each pass holds under its key). The presented image (lit,
image) is bit-identical to view_cull = off's over light moves, camera moves, back light, zoom, the scan."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import LPS_GLB, NEEDS_SCAN
from helpers import small_settings

import skinviewer.passes.view_cull as view_cull
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.coverage import TileCover
from skinviewer.kernel.graph import FrameInputs, Pass, RenderGraph, TexSpec
from skinviewer.kernel.shaders import ShaderLibrary

# -- the graph's record of the cells a pass holds ------------------------------------------------


class Covered(Pass):
    """A toy pass that declares the cells it needs (``need``) and records each run's ExecuteContext.cover."""
    uses_scene = False
    tileable = True

    def __init__(self):
        self.name, self.need, self.seen = "cov", None, []

    def reflect(self, r):
        r.setting("render.exposure")
        r.depends("toy", 0)  # reflected every frame: ``need`` is this object's, not a memoised rule's
        r.program("fill")
        r.output("c", TexSpec((8, 8), 4, "f4"))
        if self.need is not None:
            r.cover(self.need)

    def execute(self, ec):
        self.seen.append(ec.cover)
        prog = ec.program("fill")
        ec.set(prog, "u_value", float(ec.setting("render.exposure")))
        with ec.band():
            ec.draw_fullscreen(prog, "c")


def _cells(*on):
    m = np.zeros((4, 4), bool)
    for k in on:
        m.flat[k] = True
    return TileCover(m)


def _graph(gl_ctx, shader_dir):
    p = Covered()
    return RenderGraph(gl_ctx, ShaderLibrary(gl_ctx, shader_dir), [p], ["c"]), p


def _frame(s):  # a settings object of its own: the graph's idle frame needs the very same object
    return FrameInputs(settings=with_values(s, {}), scene=None, scene_version=0, view=None, view_key="cam")


def test_a_pass_runs_again_only_for_the_cells_it_does_not_hold(gl_ctx, shader_dir):
    g, p = _graph(gl_ctx, shader_dir)
    s = with_values(Settings(), {"render.exposure": 1.0})
    a, b = _cells(0, 1), _cells(1, 2)
    p.need = a
    assert g.run(_frame(s)).ran == ["cov"] and p.seen[-1] == (a, None)  # a whole run: the cells a
    version = g.res.versions["c"]
    assert g.run(_frame(s)).ran == [] and len(p.seen) == 1  # held
    p.need = b  # cell 2 is missing: the pass makes it, given what it holds; its output's version stays
    assert g.run(_frame(s)).ran == ["cov"] and p.seen[-1] == (b, a) and g.res.versions["c"] == version
    p.need = _cells(0, 2)
    assert g.run(_frame(s)).ran == [] and len(p.seen) == 2  # a | b holds both
    g.run(_frame(with_values(s, {"render.exposure": 2.0})))  # its key changed: every needed cell again
    assert p.seen[-1] == (p.need, None) and g.res.versions["c"] == version + 1
    g.invalidate("cov")
    g.run(_frame(with_values(s, {"render.exposure": 2.0})))
    assert p.seen[-1] == (p.need, None)
    p.need = None  # every cell wanted (view culling turned off by something outside the key): a whole run
    g.run(_frame(with_values(s, {"render.exposure": 2.0})))
    assert p.seen[-1] is None and "cov" not in g._covered


def test_a_cancelled_run_leaves_no_record_of_cells(gl_ctx, shader_dir):
    g, p = _graph(gl_ctx, shader_dir)
    s = with_values(Settings(), {"render.exposure": 1.0})
    p.need = _cells(0)
    g.run(_frame(s))
    p.need = _cells(0, 5)
    rep = g.run(_frame(s), budget_ms=1e-9)  # the extension's first band, then the budget is spent
    assert "cov" in g.in_progress and p.seen[-1] == (p.need, _cells(0)), rep.ran
    assert "cov" not in g._keys  # its output part-way: under no key while its bands run
    p.need = _cells(0, 9)  # the view moved on: the extension's bands are cancelled; it wrote only cell 5,
    g.run(_frame(s), budget_ms=1e-9)  # so what it held before (cell 0) is still held, and it extends from that
    assert "cov" in g.cancelled and p.seen[-1] == (p.need, _cells(0))
    while "cov" in g.in_progress:
        g.run(_frame(s), budget_ms=1e-9)
    assert g._covered["cov"] == _cells(0) | p.need
    g.run(_frame(with_values(s, {"render.exposure": 3.0})), budget_ms=1e-9)  # a key change: a whole run, in bands
    assert "cov" in g.in_progress and p.seen[-1] == (p.need, None)
    p.need = _cells(3)
    g.run(_frame(with_values(s, {"render.exposure": 3.0})), budget_ms=1e-9)  # cancelled part-way: nothing is held
    assert "cov" in g.cancelled and "cov" not in g._covered
    while "cov" in g.in_progress:
        g.run(_frame(with_values(s, {"render.exposure": 3.0})), budget_ms=1e-9)
    assert p.seen[-1] == (p.need, None) and g._covered["cov"] == p.need  # started over as a whole run


# -- the needed tiles on the CPU -------------------------------------------------------------------


def test_facing_keeps_what_gl_may_draw():
    tri = np.array([[0, 1, 2]])
    front = np.array([[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.0, 0.5, 0.0]])  # counter-clockwise in NDC
    ident = np.eye(4)
    assert view_cull.facing(front, tri, ident, True).tolist() == [True]
    assert view_cull.facing(front[::-1].copy(), tri, ident, True).tolist() == [False]  # clockwise: culled
    assert view_cull.facing(front[::-1].copy(), tri, ident, False).tolist() == [True]  # both faces drawn
    off = front + np.array([3.0, 0.0, 0.0])  # wholly right of the frustum
    assert view_cull.facing(off, tri, ident, False).tolist() == [False]
    edge = front + np.array([1.45, 0.0, 0.0])  # one corner inside
    assert view_cull.facing(edge, tri, ident, False).tolist() == [True]


def test_grow_and_half_size():
    m = np.zeros((8, 8), bool)
    m[3, 4] = True
    assert view_cull.grow(m, 1).sum() == 9 and view_cull.grow(m, 2).sum() == 25
    h = view_cull.half_of(m, 64)  # 64 texels: 8 x 8 tiles; full tile (3, 4) -> half tile (1, 2), one wider
    assert h.shape == (64 // view_cull.VIEW_TILE,) * 2 and h[1, 2] and h.sum() == 9


# -- the image, bit for bit -----------------------------------------------------------------------

def _steps(s: Settings, near: float = 180.0) -> list[tuple[str, Settings]]:
    """Light moves, then camera moves (the incremental path), a back light with the TSM, zoom (the camera
    ``near`` mesh units from the head, about a third of its framing distance), pitch."""
    d = tuple(s.lights[0].direction)
    out = [("base", s)]
    for k in (1, 2):
        out.append((f"light move {k}", with_values(s, {"lights.0.direction": (d[0] + 0.05 * k, d[1], d[2])})))
    # the light swung round, the view kept: the TSM's first surfaces (L) are others, F the same
    out.append(("light swung", with_values(s, {"lights.0.direction": (-d[0], d[1], -d[2])})))
    out.append(("light back", out[2][1]))
    cur = out[-1][1]
    for yaw in (0.0, 90.0, 180.0, 25.0):
        cur = with_values(cur, {"camera.yaw": yaw})
        out.append((f"yaw {yaw:.0f}", cur))
    for pitch in (60.0, -60.0):
        cur = with_values(cur, {"camera.pitch": pitch})
        out.append((f"pitch {pitch:.0f}", cur))
    cur = with_values(cur, {"camera.pitch": 5.0, "camera.yaw": 25.0, "camera.distance": near})
    out.append(("zoomed in", cur))
    cur = with_values(cur, {"lights.0.direction": (d[0], d[1] + 0.1, d[2])})
    out.append(("zoomed in, light moved", cur))
    cur = with_values(cur, {"lights.0.direction": (-d[0], d[1], -d[2]), "camera.distance": None})
    out.append(("back-lit", cur))
    cur = with_values(cur, {"camera.yaw": 120.0})
    out.append(("back-lit, yaw 120", cur))
    return out


def _same_images(gl_ctx, steps) -> list[float]:
    """Render each step with view culling and without (two renderers); assert lit and image bit-identical;
    return the share of the diffuse sum's tiles each culled frame made (its note's figure)."""
    from skinviewer.engine.renderer import Renderer
    ra, rb = Renderer(gl_ctx), Renderer(gl_ctx)
    made = []
    try:
        for label, s in steps:
            rep = ra.render(with_values(s, {"deon.view_cull": "view"}))
            rb.render(with_values(s, {"deon.view_cull": "off"}))
            for res in ("lit", "image"):
                a, b = ra.graph("deon").read(res), rb.graph("deon").read(res)
                assert np.array_equal(a, b), f"{label}: {res} differs in {int((a != b).any(axis=-1).sum())} pixels"
            comb = next(p for p in rep.passes if p.name == "deon_combine")
            if comb.status == "ran":
                made.append(comb.figures.get("view_tiles", 1.0))
    finally:
        ra.release()
        rb.release()
    return made


def test_the_head_renders_the_same_and_culls(gl_ctx):
    s = small_settings("head", "deon", size=96, **{"deon.irradiance_size": 512, "camera.yaw": 25.0,
                                                  "camera.pitch": 5.0})
    made = _same_images(gl_ctx, _steps(s))
    assert made and max(made) < 0.7 and min(made) < 0.1, made  # a light move makes part of the map, a camera move less


@pytest.mark.parametrize("extra", [{"deon.surface_gather_below_texels": 0.0},
                                   {"deon.surface_gather_below_texels": 2.0, "deon.irradiance_size": 256}],
                         ids=["separable", "gather 2, 256"])
def test_other_chains_render_the_same(gl_ctx, extra):
    s = small_settings("head", "deon", size=64, **{"deon.irradiance_size": 512, **extra})
    steps = _steps(s)
    _same_images(gl_ctx, [steps[0], steps[1], steps[3], steps[4], steps[5], steps[7], steps[-2]])


@NEEDS_SCAN
def test_the_scan_renders_the_same_open_border(gl_ctx):
    s = small_settings("head", "deon", size=64, **{"scene.mesh": str(LPS_GLB), "scene.mm_per_unit": 48.0,
                                                  "deon.irradiance_size": 512, "deon.open_border": "reflect"})
    steps = _steps(s, near=4.0)
    _same_images(gl_ctx, [steps[0], steps[1], steps[3], steps[4], steps[5], steps[7], steps[9], steps[-4], steps[-3],
                          steps[-2]])


def test_a_needed_set_too_small_shows(gl_ctx, monkeypatch):
    """The sets are not larger than they must be for nothing: the combine's half-size reads one tile narrower
    (half_of without its bilinear ring) change the image."""
    monkeypatch.setattr(view_cull, "half_of", lambda mask, m: _half_tight(mask, m))
    s = small_settings("head", "deon", size=96, **{"deon.irradiance_size": 512})
    with pytest.raises(AssertionError, match="differs"):
        _same_images(gl_ctx, _steps(s)[:8])


def _half_tight(mask: np.ndarray, m: int) -> np.ndarray:
    nt = view_cull.tiles_of(m)
    out = np.zeros((nt, nt), bool)
    ys, xs = np.nonzero(mask)
    out[np.minimum(ys // 2, nt - 1), np.minimum(xs // 2, nt - 1)] = True
    return out


def test_idle_completion_makes_a_later_orbit_free(gl_ctx):
    """Renderer.complete_view (the viewer's idle frames): after a light move and its view, the tiles no view
    needed are made; a camera move then runs no texture-space pass, and the image is the unculled one."""
    from skinviewer.engine.renderer import Renderer
    s = small_settings("head", "deon", size=64, **{"deon.irradiance_size": 512, "deon.view_cull": "view"})
    d = tuple(s.lights[0].direction)
    moved = with_values(s, {"lights.0.direction": (d[0] + 0.05, d[1], d[2])})
    ra, rb = Renderer(gl_ctx), Renderer(gl_ctx)
    try:
        ra.render(s)
        ra.render(moved)
        assert ra.complete_view(moved, budget_ms=None) and not ra.complete_view(moved)
        assert set(ra.graph("deon").last_report.ran) <= {"deon_irradiance", "deon_blur_4", "deon_blur_5",
                                                         "deon_transmitted", "deon_combine"}  # not the final pass
        turned = with_values(moved, {"camera.yaw": 200.0})
        rep = ra.render(turned)
        ran = set(rep.ran)
        assert not ran & {"deon_irradiance", "deon_blur_3", "deon_transmitted", "deon_combine"}, ran
        rb.render(with_values(turned, {"deon.view_cull": "off"}))
        for res in ("lit", "image"):
            assert np.array_equal(ra.graph("deon").read(res), rb.graph("deon").read(res)), res
    finally:
        ra.release()
        rb.release()
