"""The viewer's Presets > Export... / Import... / Turntable: the same export and import as the CLI, a
turntable in a child process with progress and cancel (cancel leaves nothing), and the block draws in
every state (imgui without a window)."""
from __future__ import annotations

import time

import pytest

from skinviewer.ground.settings import Settings, with_values
from skinviewer.ui import exchange as ux

TINY = {"render.width": 48, "render.height": 48, "deon.irradiance_size": 256, "deon.tsm_size": 256,
        "shadow.map_size": 256}


def test_export_then_import_changes_the_profile(tmp_path):
    s = with_values(Settings(), {"technique": "burley", "burley.mfp": [2.0, 1.0, 0.5]})
    out = tmp_path / "skin.py"
    ok, msg = ux.export_current(s, "blender", str(out))
    assert ok and "Burley fit loses" in msg and out.is_file()
    new, msg = ux.import_into(Settings(), str(out))
    assert new is not None and "imported a blender profile" in msg
    assert new.burley.fit == "direct" and new.deon.gaussians != Settings().deon.gaussians


def test_refused_import_and_export_say_why(tmp_path):
    bad = tmp_path / "x.json"
    bad.write_text("{}")
    new, msg = ux.import_into(Settings(), str(bad))
    assert new is None and msg.startswith("import refused")
    ok, msg = ux.export_current(Settings(), "hdrp", str(tmp_path / "x.mtlx"))
    assert not ok and "writes a .asset" in msg and not (tmp_path / "x.mtlx").exists()


def _wait(job, seconds):
    t0 = time.monotonic()
    while not job.finished and time.monotonic() - t0 < seconds:
        time.sleep(0.2)
    return job.finished


@pytest.mark.slow
def test_turntable_job_progress_and_result(tmp_path):
    out = tmp_path / "spin.mp4"
    job = ux.TurntableJob(with_values(Settings(), TINY), str(out), frames=2, size=(48, 48))
    assert _wait(job, 300), "turntable did not finish"
    assert job.ok, job.message
    assert job.done == 2 and job.fraction == 1.0 and out.stat().st_size > 0
    assert "wrote" in job.take_message() and job.take_message() == ""


@pytest.mark.slow
def test_turntable_cancel_leaves_nothing(tmp_path):
    out = tmp_path / "spin.gif"
    job = ux.TurntableJob(with_values(Settings(), TINY), str(out), frames=400, size=(48, 48))
    t0 = time.monotonic()
    while job.done < 1 and not job.finished and time.monotonic() - t0 < 300:
        time.sleep(0.2)
    job.cancel()
    assert _wait(job, 120)
    assert not job.ok and "cancelled" in job.message
    assert list(tmp_path.iterdir()) == []


def test_block_draws_in_every_state(monkeypatch):
    imgui = pytest.importorskip("imgui_bundle").imgui
    from skinviewer.ui.widgets import UiContext
    ctx = imgui.create_context()
    try:
        io = imgui.get_io()
        io.set_ini_filename("")  # no imgui.ini left in the working folder
        io.display_size = imgui.ImVec2(800, 600)
        io.delta_time = 1 / 60
        io.fonts.get_tex_data_as_rgba32()

        class State:
            settings = Settings()

        class Job:  # a running turntable
            finished, ok, done, total, fraction, message = False, False, 3, 10, 0.3, ""

        tools = ux.ExchangeTools()
        for job in (None, Job()):
            tools.job = job
            imgui.new_frame()
            imgui.begin("panel")
            tools.draw(State(), UiContext(expand_all=True))
            imgui.end()
            imgui.end_frame()
            imgui.render()
        assert tools.path.endswith("skin_hdrp.asset")
    finally:
        imgui.destroy_context(ctx)
