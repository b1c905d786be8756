"""Issue 34: the viewer's layouts fit 960x600 (the Accuracy and Passes windows beside each other
over the 3D view, never over the panel, the Pareto chart visible without scrolling), legends that
wrap instead of running past their window's edge, and a status line about the calibration that is
true when no calibration will come (SKINVIEWER_CALIBRATE=0)."""
from __future__ import annotations

import json

import pytest
from helpers import viewer_app

from skinviewer.ui.layout import compute_layout, floating_rects, flow_rows, keep_inside, overlaps

SIZES = ((960, 600), (1280, 800), (1920, 1080))


def _inside(r, area, tol=0.5) -> bool:
    return (r[0] >= area[0] - tol and r[1] >= area[1] - tol and r[0] + r[2] <= area[0] + area[2] + tol
            and r[1] + r[3] <= area[1] + area[3] + tol)


@pytest.mark.parametrize("size", SIZES)
def test_the_floating_windows_first_rectangles_lie_in_the_view_apart(size):
    for side in ("left", "right"):
        lo = compute_layout(size, size, True, side=side)
        rects = floating_rects(lo.view)
        for name, r in rects.items():
            assert _inside(r, lo.view), (size, side, name, r, lo.view)
            assert not overlaps(r, lo.panel) and not overlaps(r, lo.status), (size, side, name)
            assert r[2] >= 200 and r[3] >= 400, (size, name, r)  # room for the Pareto chart at 960x600
        assert not overlaps(rects["accuracy"], rects["passes"]), (size, side)


def test_a_moved_window_is_brought_back_inside_the_view_not_over_the_panel():
    view = (400.0, 0.0, 560.0, 576.0)
    assert keep_inside((100.0, 50.0, 200.0, 300.0), view) == (400.0, 50.0)  # over the panel: moved right
    assert keep_inside((900.0, 500.0, 200.0, 300.0), view) == (760.0, 276.0)  # past the corner
    assert keep_inside((450.0, 20.0, 200.0, 300.0), view) == (450.0, 20.0)  # inside: kept
    assert keep_inside((450.0, 20.0, 900.0, 900.0), view) == (400.0, 0.0)  # larger: its top-left wins


def test_flow_rows_wrap_within_the_width_and_keep_the_order():
    widths = [60.0, 70.0, 60.0, 55.0, 65.0, 58.0]
    for avail in (100.0, 200.0, 360.0, 1000.0):
        rows = flow_rows(widths, avail, 12.0)
        assert [i for row in rows for i in row] == list(range(len(widths)))
        for row in rows:
            assert len(row) == 1 or sum(widths[i] for i in row) + 12.0 * (len(row) - 1) <= avail
    assert len(flow_rows(widths, 1000.0, 12.0)) == 1 and len(flow_rows(widths, 100.0, 12.0)) == 6
    assert flow_rows([500.0, 20.0], 100.0, 4.0) == [[0], [1]]  # a wide item: a row of its own


ENGINE_REASONS = ("no calibration for llvmpipe (large meshes) yet: measuring the techniques on this machine",
                  "calibration /x.json unreadable (ValueError: bad): rebuilding it",
                  "calibration /x.json is of another version or machine: rebuilding it",
                  "calibration /x.json: deon made for other preview ladders: measuring it again")


def test_the_calibration_line_never_promises_a_measurement_that_will_not_run():
    pytest.importorskip("imgui_bundle")
    from skinviewer.ui.frame import calibration_note
    for why in ENGINE_REASONS:
        have = "again" in why
        for cached in (False, True):
            off = calibration_note(why, have, cached, False, True, "llvmpipe (large meshes)")
            assert off.startswith("calibration off"), off
            assert "measuring" not in off and "rebuilding" not in off, off
            assert calibration_note(why, have, cached, True, True, "m") == why  # it will run: the engine's words
            assert calibration_note(why, have, cached, True, False, "m") == ""  # governor off: nothing runs
    shipped = calibration_note("", True, False, False, True, "m")
    assert "shipped" in shipped and shipped.startswith("calibration off")
    assert "this machine's" in calibration_note("", True, True, False, True, "m")
    assert calibration_note("", True, True, True, True, "m") == ""


@pytest.fixture(scope="module")
def app960(tmp_path_factory):
    yield from viewer_app(tmp_path_factory, "shadow-edge", (960, 600))


def test_at_960x600_both_windows_open_the_pareto_chart_is_whole_and_no_legend_is_cut(app960, tmp_path):
    from imgui_bundle import imgui

    from skinviewer.engine.bench import Result
    from skinviewer.ui.accuracy_window import CHART_MIN_H, AccuracyWindow
    from skinviewer.ui.passes_window import PassesWindow
    from skinviewer.ui.sections.look import LookSection
    app = app960
    techs = ("deon", "ssss", "separable", "burley", "burley2", "gosselin", "phong", "deon-long-name")
    rows = [Result(t, f"cfg{k}", {}, full_ms=20.0 * (k + 1), rms=[0.01 * (8 - k)] * 3, p99=[0.1] * 3,
                   dssim=0.01).to_json() for k, t in enumerate(techs)]
    (tmp_path / "results.json").write_text(json.dumps({"scene": "shadow-edge", "results": rows}))
    acc, passes = app.ui.window(AccuracyWindow), app.ui.window(PassesWindow)
    assert acc.load_results(str(tmp_path / "results.json"))

    class Open:  # the user expands both windows and picks the Pareto page
        def __init__(self, state, frame):
            pass

        def draw(self, ui):
            for name in ("Accuracy###accuracy", "Passes###passes"):
                imgui.set_window_collapsed(name, False, imgui.Cond_.always.value)

    app.ui.add_window(Open)
    acc.tab_request = "Pareto"
    try:
        app.step(3)
        lo = app.frame.layout
        a, p = acc.rect, passes._rect
        assert a[3] > 100 and p[3] > 100, "the windows did not open"
        for r in (a, p):
            assert _inside(r, lo.view), (r, lo.view)
            assert not overlaps(r, lo.panel)
        assert not overlaps(a, p)
        assert acc.tab == "Pareto" and acc.chart_rect is not None
        cx, cy, cw, ch = acc.chart_rect
        assert ch >= CHART_MIN_H and cy + ch <= a[1] + a[3] + 0.5, (acc.chart_rect, a)  # no scrolling to it
        right, edge = acc.legend_extent
        assert right <= edge + 0.5, "the Pareto legend runs past the window's edge"
        look = next(s for w in app.ui.windows for s in getattr(w, "sections", ()) if isinstance(s, LookSection))
        assert look.legend_extent, "the scatter-profile plot was not drawn"
        right, edge = look.legend_extent
        assert right <= edge + 0.5, "the scatter-profile legend is cut at the panel's edge"
    finally:
        app.ui.windows.pop()


def test_with_calibration_off_the_status_bar_says_so(app960):
    from skinviewer.ui.status_bar import StatusBar
    msg = app960.frame.load_calibration(auto=False)
    texts = [t for t, _ in app960.ui.window(StatusBar).fields()]
    assert msg and msg.startswith("calibration off") and msg in texts, texts
    assert not any("measuring" in t or "rebuilding" in t for t in texts), texts


def test_the_start_up_headline_promises_a_preview_only_when_the_governor_makes_one():
    pytest.importorskip("imgui_bundle")
    from skinviewer.ground.settings import Settings, with_values
    from skinviewer.ui.app import startup_headline
    off = startup_headline(with_values(Settings(), {"render.governor": "off"}))
    assert "preview appears" not in off and "your settings" in off
    assert "preview" in startup_headline(Settings())


def test_a_click_on_a_legend_item_hides_its_series_and_a_second_shows_it(app960):
    """The wrapped legends (issue 34) keep implot's click-to-hide: a click on "R table" in the
    scatter profile's legend hides that curve, a second click shows it again."""
    from imgui_bundle import imgui

    from skinviewer.ui.sections.look import LookSection
    app = app960
    look = next(s for w in app.ui.windows for s in getattr(w, "sections", ()) if isinstance(s, LookSection))
    app.step(1)
    assert "R table" in look.legend_rects, look.legend_rects
    x, y, w, h = look.legend_rects["R table"]
    io = imgui.get_io()
    for expect in (True, False):
        io.add_mouse_pos_event(x + w / 2, y + h / 2)
        app.step(1)
        io.add_mouse_button_event(0, True)
        app.step(1)
        io.add_mouse_button_event(0, False)
        app.step(1)
        assert ("R table" in look.profile_hidden) is expect, look.profile_hidden
    io.add_mouse_pos_event(-1.0, -1.0)
    app.step(1)
