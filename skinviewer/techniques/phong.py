"""Phong/Lambert baseline with shadow maps (seed 000 eq. 1-7): the naive reference."""
from __future__ import annotations

from skinviewer.passes.output import OutputPass
from skinviewer.passes.phong import PhongPass
from skinviewer.techniques.base import Technique, shadow_passes


def build():
    return shadow_passes() + [PhongPass(), OutputPass("lit")]


def sweep(quick: bool):
    """Phong's only quality knobs are its shadow maps (eq. 6-7): size, PCF radius and filter."""
    if quick:
        return [("sm1024 pcf1", {"shadow.map_size": 1024, "shadow.pcf": 1})]
    return ([(f"sm{n} pcf{k}", {"shadow.map_size": n, "shadow.pcf": k}) for n in (512, 1024, 2048) for k in (0, 1, 2)]
            + [(f"sm{n} pcf1 box", {"shadow.map_size": n, "shadow.pcf": 1, "shadow.pcf_filter": "box"})
               for n in (512, 1024, 2048)])


TECHNIQUE = Technique("phong", "Phong/Lambert baseline with shadow maps (seed 000 eq. 1-7)", build, sweep)
