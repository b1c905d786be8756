"""What a technique is: a graph description (passes + targets), not a fork of the renderer.

Each technique module defines one ``Technique``: its name, what it is (with the seed equations it
follows), how to build its passes, and the quality knobs ``skinviewer bench`` sweeps."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from skinviewer.ground.constants import MAX_LIGHTS
from skinviewer.kernel.pass_api import Pass
from skinviewer.passes.environment import EnvironmentPass
from skinviewer.passes.shadow_map import ShadowBoundsPass, ShadowMapPass

TARGETS = ["image"]

# A bench configuration: a short label and the settings it changes (dotted path -> value).
Config = tuple[str, dict[str, Any]]


@dataclass(frozen=True)
class Technique:
    name: str
    title: str  # what it is, in the papers' terms, with the seeds it follows
    build: Callable[[], list[Pass]]
    # the configurations ``skinviewer bench`` sweeps (quick=True: a few for CI-sized runs)
    sweep: Callable[[bool], list[Config]] = field(default=lambda quick: [("default", dict[str, Any]())])
    targets: tuple[str, ...] = tuple(TARGETS)


def shadow_passes() -> list[Pass]:
    """The shadow map of each light and its bounds (the PCF's exact early-out, issue 27), and the
    environment light's pre-filtered maps (issue 32)."""
    return ([ShadowMapPass(i) for i in range(MAX_LIGHTS)] + [ShadowBoundsPass(i) for i in range(MAX_LIGHTS)]
            + [EnvironmentPass()])
