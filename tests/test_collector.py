"""The frame loop's garbage-collector policy (issue 27, ui/collector.py): no full collection while the
view is busy, one in the first idle frame, then the automatic collector back; start-up objects frozen
once per scene."""
from __future__ import annotations

import gc

from skinviewer.ui import collector
from skinviewer.ui.collector import Collector


class _Cycle:
    def __init__(self):
        self.me = self  # garbage only a collection frees


def test_busy_frames_collect_only_young_generations_and_idle_ones_hand_back(monkeypatch):
    asked: list[int] = []

    def full() -> list[int]:  # the full collections asked (a held frame may also take the young ones, by count)
        return [g for g in asked if g == 2]
    real = gc.collect
    monkeypatch.setattr(gc, "collect", lambda generation=2: (asked.append(generation), real(generation))[1])
    clock = [1000.0]  # the collector's clock, stepped by hand (no waiting, no timing in the test)
    monkeypatch.setattr(collector.time, "perf_counter", lambda: clock[0])
    was = gc.isenabled()
    gc.enable()
    c = Collector(idle_s=1.0)
    try:
        c.frame(busy=True, scene_key="head")
        assert not gc.isenabled() and c.held  # the automatic collector is off while busy
        for _ in range(30):  # a drag's worth of allocations: the young generations fill up
            junk = [_Cycle() for _ in range(2 * gc.get_threshold()[0])]
            del junk
            c.frame(busy=True, scene_key="head")
        assert asked and set(asked) <= {0, 1}, asked  # young generations collected, never a full one
        assert 1 in asked  # the middle one too, as the automatic collector would
        assert gc.get_count()[0] < 2 * gc.get_threshold()[0] + 100  # nothing piles up in generation 0
        asked.clear()
        c.frame(busy=False, scene_key="head")  # still and final, but only just: the user may drag again
        clock[0] += 0.5
        c.frame(busy=False, scene_key="head")
        assert not gc.isenabled() and 2 not in asked
        clock[0] += 0.6  # idle for IDLE_S: one full collection in this frame, start-up frozen, handed back
        c.frame(busy=False, scene_key="head")
        assert gc.isenabled() and not c.held
        assert full() == [2] and set(asked) <= {0, 1, 2} and c.frozen_for == "head" and gc.get_freeze_count() > 0
        clock[0] += 5.0
        c.frame(busy=False, scene_key="head")
        assert full() == [2]  # idle frames after it: the automatic collector's business
        c.frame(busy=True, scene_key="head")  # a drag again: held at once
        assert not gc.isenabled()
        clock[0] += 0.1
        c.frame(busy=False, scene_key="head")
        clock[0] += 1.0
        c.frame(busy=False, scene_key="head")  # idle: what the drag put off, collected; not re-frozen
        assert full() == [2, 2] and gc.isenabled()
        c.frame(busy=True, scene_key="scan")
        c.frame(busy=False, scene_key="scan")
        clock[0] += 1.0
        c.frame(busy=False, scene_key="scan")  # another scene: unfrozen, collected once, frozen again
        assert full() == [2, 2, 2] and c.frozen_for == "scan"
        c.frame(busy=True, scene_key="scan")
        c.release()  # the viewer closing hands the collector back, nothing frozen
        assert gc.isenabled() and gc.get_freeze_count() == 0
    finally:
        c.release()
        gc.unfreeze()
        if not was:
            gc.disable()


def test_the_collector_leaves_a_collector_it_did_not_turn_off_alone():
    was = gc.isenabled()
    gc.disable()  # someone else's choice (a profiler, a test): not ours to turn back on
    try:
        c = Collector()
        c.frame(busy=True, scene_key=None)
        assert not c.held
        c.frame(busy=False, scene_key=None)
        assert not gc.isenabled()
    finally:
        if was:
            gc.enable()
