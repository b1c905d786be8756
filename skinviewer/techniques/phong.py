"""Phong/Lambert baseline with shadow maps (seed 000 eq. 1-7): the naive reference."""
from __future__ import annotations

from skinviewer.passes.output import OutputPass
from skinviewer.passes.phong import PhongPass
from skinviewer.techniques.base import Technique, shadow_passes


def build():
    return shadow_passes() + [PhongPass(), OutputPass("lit")]


TECHNIQUE = Technique("phong", "Phong/Lambert baseline with shadow maps (seed 000 eq. 1-7)", build)
