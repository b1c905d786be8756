"""Python's cyclic garbage collector, steered by the viewer's frame loop (issue 27).

Left to itself the collector runs whenever allocations pass its thresholds, in whatever frame that
happens: a full (generation 2) collection over the scene, the render graphs and the UI's objects took
33 ms of one d'Eon light-drag frame here, enough to take it past the 100 ms budget. So:

- **while the view is busy** (the user drags or edits, a frame is spread over several, a refinement
  is under way) the automatic collector is off; each frame collects only the young generations, and
  only when they are over their thresholds (``gc.collect(0)`` / ``gc.collect(1)``: what the automatic
  collector would have done, minus the full collection);
- **once the view has been still and final for IDLE_S** (the user let go, the refinement is done, and
  nothing happened for a moment) the loop makes one full collection in that idle frame -- it renders
  nothing -- and turns the automatic collector back on. Everything that survived start-up, or the last
  scene load, is frozen there first (``gc.freeze``: moved to the permanent generation, which no
  collection walks), so a full collection no longer walks the scene's large, long-lived object graph
  (at the defaults: ~100k objects; a full collection 266-276 ms -> 0 ms at load ~12 here). A scene
  change unfreezes it first and collects, so a replaced scene's cycles are freed, not kept for the
  rest of the session. (Handing the collector back at the first still frame instead let its pending
  full collection land in the frame that showed the final image: 179 ms at load ~12.)

``release()`` (the viewer closing) unfreezes and turns the automatic collector back on."""
from __future__ import annotations

import gc
import time

IDLE_S = 1.0  # still and final this long: the idle frame that collects in full and hands back


class Collector:
    def __init__(self, idle_s: float = IDLE_S) -> None:
        self.idle_s = idle_s
        self._still_since: float | None = None
        self.held = False  # the automatic collector is off, by us
        self.frozen_for: object = None  # the scene whose start-up objects are frozen (None: none yet)
        self.collections: list[int] = []  # the generations this object collected explicitly (tests, logs)

    def frame(self, busy: bool, scene_key: object) -> None:
        """After a frame. ``busy``: the user interacts or the image is not final yet; ``scene_key``:
        the scene loaded (a change unfreezes, collects and freezes again in the next idle frame)."""
        now = time.perf_counter()
        if not busy and self._still_since is None:
            self._still_since = now
        idle = not busy and now - (self._still_since or now) >= self.idle_s
        if not idle:
            if busy:
                self._still_since = None
            if busy and not self.held and gc.isenabled():
                gc.disable()
                self.held = True
            if self.held:
                self._young()
            return
        collected = False
        if scene_key is not None and scene_key != self.frozen_for:
            gc.unfreeze()  # a replaced scene's objects become collectable again
            gc.collect()
            self.collections.append(2)
            gc.freeze()
            self.frozen_for, collected = scene_key, True
        if self.held:
            if not collected:  # what the drag put off, in this idle frame
                gc.collect()
                self.collections.append(2)
            gc.enable()
            self.held = False

    def _young(self) -> None:
        """The young generations, as the automatic collector would (its thresholds), never the oldest."""
        c0, c1, _ = gc.get_count()
        t0, t1, _ = gc.get_threshold()
        if c1 >= t1:
            gc.collect(1)
            self.collections.append(1)
        elif c0 >= t0:
            gc.collect(0)
            self.collections.append(0)

    def release(self) -> None:
        """The viewer closing: the automatic collector on, nothing frozen (the interpreter's exit, or
        another viewer in the same process, finds the collector as it was)."""
        if self.frozen_for is not None:
            gc.unfreeze()
            self.frozen_for = None
        if self.held:
            gc.enable()
            self.held = False
