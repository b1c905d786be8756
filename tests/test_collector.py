"""The frame loop's garbage-collector policy (issue 27, ui/collector.py): no full collection while the
view is busy, the automatic collector back once it is still, start-up objects frozen once per scene."""
from __future__ import annotations

import gc

from skinviewer.ui.collector import Collector


class _Cycle:
    def __init__(self):
        self.me = self  # garbage only a collection frees


def test_busy_frames_collect_only_young_generations_and_still_ones_hand_back(monkeypatch):
    asked: list[int] = []
    real = gc.collect
    monkeypatch.setattr(gc, "collect", lambda generation=2: (asked.append(generation), real(generation))[1])
    was = gc.isenabled()
    gc.enable()
    c = Collector()
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
        c.frame(busy=False, scene_key="head")
        assert gc.isenabled() and not c.held  # still and final: the automatic collector again
        assert asked == [2] and c.frozen_for == "head" and gc.get_freeze_count() > 0  # start-up frozen once
        c.frame(busy=False, scene_key="head")
        assert asked == [2]  # once per scene, not every still frame
        c.frame(busy=True, scene_key="scan")
        c.frame(busy=False, scene_key="scan")  # another scene: unfrozen, collected, frozen again
        assert asked == [2, 2] and c.frozen_for == "scan"
        c.frame(busy=True, scene_key="scan")
        c.release()  # the viewer closing hands the collector back
        assert gc.isenabled()
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
