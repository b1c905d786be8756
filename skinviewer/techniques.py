"""Techniques are graph descriptions: which passes, which target. Not forks of the renderer."""
from __future__ import annotations

from typing import Callable

from .graph import Pass
from .passes.common import MAX_LIGHTS
from .passes.output import OutputPass
from .passes.phong import PhongPass
from .passes.shadow_map import ShadowMapPass

TARGETS = ["image"]


def shadow_passes() -> list[Pass]:
    return [ShadowMapPass(i) for i in range(MAX_LIGHTS)]


def phong() -> list[Pass]:
    return shadow_passes() + [PhongPass(), OutputPass("lit")]


BUILDERS: dict[str, Callable[[], list[Pass]]] = {"phong": phong}


def register(name: str, builder: Callable[[], list[Pass]]) -> None:
    BUILDERS[name] = builder


def _load_techniques() -> None:
    # the skin techniques live in their own modules and register themselves on import (imported
    # here, lazily, because they import this module to do so)
    from .passes import gosselin  # noqa: F401  (registration order = the viewer's order)
    from .passes import deon  # noqa: F401


def names() -> list[str]:
    _load_techniques()
    return list(BUILDERS)


def build(name: str) -> tuple[list[Pass], list[str]]:
    _load_techniques()
    if name not in BUILDERS:
        raise KeyError(f"technique '{name}' is not available (have: {', '.join(BUILDERS)})")
    return BUILDERS[name](), list(TARGETS)
