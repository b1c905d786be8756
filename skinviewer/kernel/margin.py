"""The look-ahead's margin from the distribution of its own errors (issue 27: every frame within the
budget). The render graph predicts what a pass, or a band of it, will cost from its last runs; on a
shared machine the actual cost strays from that (llvmpipe here: 0.6-2x). A margin of a few *mean*
errors still let one band in twenty or so take its frame past the budget. This keeps the recent ratios
actual / predicted of each draw (a band of one draw of a pass: the pass's name and the draw's index),
and budgets a predicted cost at a high quantile of them (the budget's p99, not its mean): a draw whose
cost is steady gets a small margin, one that strays a large one. Fewer ratios of a draw than
``min_n``: its pass's, then every pass's; fewer still: None (the caller's own rule)."""
from __future__ import annotations

from collections import deque

ANY = -1  # the draw index of a pass's statistics over all its draws (and of every pass's: name "")


class ErrorQuantiles:
    """Recent ratios actual / predicted, per (pass, draw), per pass and over every pass; ``factor`` is
    their ``q`` quantile (at least 1: a cost is never budgeted below its prediction)."""

    def __init__(self, window: int = 48, q: float = 0.99, min_n: int = 6, total_window: int = 256):
        self.window = int(window)
        self.total_window = int(total_window)
        self.q = float(q)
        self.min_n = int(min_n)
        self._ratios: dict[tuple[str, int], deque[float]] = {}
        self._cached: dict[tuple[str, int], float] = {}

    def add(self, name: str, draw: int, ratio: float) -> None:
        """A run of draw ``draw`` of pass ``name`` cost ``ratio`` times its prediction."""
        if not (ratio > 0.0) or ratio == float("inf"):
            return
        for key in ((name, draw), (name, ANY), ("", ANY)):
            d = self._ratios.get(key)
            if d is None:
                d = self._ratios[key] = deque(maxlen=self.total_window if key[0] == "" else self.window)
            d.append(float(ratio))
            self._cached.pop(key, None)

    def count(self, name: str, draw: int = ANY) -> int:
        d = self._ratios.get((name, draw))
        return 0 if d is None else len(d)

    def _quantile(self, key: tuple[str, int]) -> float:
        q = self._cached.get(key)
        if q is None:
            xs = sorted(self._ratios[key])
            # the sample quantile, interpolated between the order statistics around it
            pos = self.q * (len(xs) - 1)
            lo = int(pos)
            hi = min(lo + 1, len(xs) - 1)
            q = self._cached[key] = max(1.0, xs[lo] + (xs[hi] - xs[lo]) * (pos - lo))
        return q

    def factor(self, name: str, draw: int = ANY) -> float | None:
        """The ``q`` quantile of the draw's ratios (of its pass's, of every pass's when it has fewer than
        ``min_n``); None: fewer than ``min_n`` ratios anywhere."""
        for key in ((name, draw), (name, ANY), ("", ANY)):
            if self.count(*key) >= self.min_n:
                return self._quantile(key)
        return None

    def clear(self) -> None:
        self._ratios.clear()
        self._cached.clear()
