"""The start-up screen (ui/splash.py): the window shows the start-up steps, not black, and a long step
runs in a worker while the screen keeps being redrawn."""
from __future__ import annotations

import os
import time

import numpy as np
import pytest


@pytest.fixture(scope="module")
def wnd():
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY")
    from skinviewer.ui.app import WindowUnavailableError, create_window
    try:
        w = create_window((320, 200), visible=True, vsync=False)
    except WindowUnavailableError as exc:
        pytest.skip(str(exc))
    yield w
    w.destroy()


def test_the_window_shows_the_steps_not_black(wnd, monkeypatch):
    from skinviewer.ui.splash import BG, Splash
    sp = Splash(wnd, interval=0.02)
    monkeypatch.setattr(wnd, "swap_buffers", lambda: None)  # read the frame that would be presented
    sp.show("window open")
    w, h = wnd.buffer_size
    shown = np.frombuffer(wnd.ctx.screen.read(components=3, alignment=1), np.uint8).reshape(h, w, 3)[::-1]
    want = sp._image()  # the text block, at the top left; the rest of the screen is BG
    th, tw = want.shape[:2]
    assert th <= h and tw <= w
    assert np.abs(shown[:th, :tw].astype(int) - want.astype(int)).mean() < 2.0  # the lines, upright
    assert np.all(shown[th:] == np.array(BG, np.uint8)) and np.all(shown[:, tw:] == np.array(BG, np.uint8))
    assert (np.abs(shown.astype(int) - np.array(BG)).sum(-1) > 60).mean() > 0.005  # text, not an empty screen
    frames = sp.frames
    assert sp.run("a slow step", lambda: (time.sleep(0.2), 42)[1]) == 42
    assert sp.frames >= frames + 3  # redrawn while the worker ran
    assert [t for _, t in sp.lines] == ["window open", "a slow step"]
    with pytest.raises(ValueError):
        sp.run("a failing step", lambda: (_ for _ in ()).throw(ValueError("boom")))
    sp.release()
