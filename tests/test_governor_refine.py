"""Issue 27, release -> final: the refinement skips its intermediate rung when the final frame is at most
SKIP_STEP_FRAMES frames away (the intermediate image would be on screen for about a frame, at the cost of
its own frame of rendering and presenting); a final frame further away still gets one."""
from __future__ import annotations

from skinviewer.ground.settings import Settings, with_values
from skinviewer.techniques.preview import FINAL
from skinviewer.ui import governor as gov
from skinviewer.ui.governor import Governor
from tests.test_governor import fake_calibration


def _plan(budget_ms: float, seed: int = 3) -> tuple[Governor, list]:
    s = with_values(Settings(), {"technique": "deon"})
    g = Governor("interactive", budget_ms, fake_calibration("deon", s, seed=seed))  # FINAL costs 1000 ms
    first = g.rung_for(s, interacting=True, camera=False, last_complete=True)
    return g, [] if first.final else list(g._plan)


def test_no_intermediate_rung_when_the_final_frame_is_two_frames_away():
    g, plan = _plan(650.0)
    assert g.cost("deon", FINAL, False) <= gov.SKIP_STEP_FRAMES * g.room()
    assert plan == [FINAL]


def test_a_distant_final_frame_still_gets_its_intermediate_rung(monkeypatch):
    stepped = 0
    for seed in range(40):
        g, plan = _plan(60.0, seed)
        assert g.cost("deon", FINAL, False) > gov.SKIP_STEP_FRAMES * g.room()
        monkeypatch.setattr(gov, "SKIP_STEP_FRAMES", 0.0)  # the rule before: an intermediate whenever one is cheap
        _, before = _plan(60.0, seed)
        monkeypatch.undo()
        assert plan == before
        stepped += len(plan) == 2
    assert stepped  # some calibrations have an intermediate rung at this budget
