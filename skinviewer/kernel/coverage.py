"""Part-valid outputs (issue 27, deon.view_cull): a pass may declare the cells of a tile grid its outputs
must hold this frame (``Reflection.cover``); the graph keeps, per pass, the union of the grids it has made
under its current cache key, re-runs it on the cells still missing when a frame needs more (the pass reads
``ExecuteContext.cover``) and forgets the record whenever the key changes or a run is cancelled."""
from __future__ import annotations

import hashlib

import numpy as np


class TileCover:
    """An immutable set of cells of a grid (True cells of ``mask``), compared by value. ``tag``: what the cells
    mean (hashable, compared by ==): sets of another tag never cover each other."""

    __slots__ = ("mask", "tag", "_digest")

    def __init__(self, mask: np.ndarray, tag: object = None):
        m = np.array(mask, dtype=bool, copy=True)
        m.setflags(write=False)
        self.mask = m
        self.tag = tag
        self._digest = hashlib.blake2b(repr((m.shape, tag)).encode() + np.packbits(m).tobytes(),
                                       digest_size=16).digest()

    def covers(self, other: TileCover) -> bool:
        """Whether every cell of ``other`` is one of these (another shape or tag: never)."""
        return self.mask.shape == other.mask.shape and self.tag == other.tag \
            and not bool((other.mask & ~self.mask).any())

    def __or__(self, other: TileCover) -> TileCover:
        if self.mask.shape != other.mask.shape or self.tag != other.tag:
            return other
        return TileCover(self.mask | other.mask, self.tag)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, TileCover) and self._digest == other._digest

    def __hash__(self) -> int:
        return hash(self._digest)

    def __repr__(self) -> str:
        return f"TileCover({int(self.mask.sum())}/{self.mask.size})"

    @property
    def fraction(self) -> float:
        return float(self.mask.mean()) if self.mask.size else 0.0
