"""The technique registry, in the viewer's order (keys 1, 2, 3, ...). A technique is a graph
description (``base.Technique``); adding one means adding a module here and one line below."""
from __future__ import annotations

from skinviewer.kernel.pass_api import Pass
from skinviewer.techniques import (
    burley,
    burley2,
    deon,
    gosselin,
    penner,
    phong,
    separable,
    ssss,
)
from skinviewer.techniques.base import TARGETS, Technique, shadow_passes

REGISTRY: dict[str, Technique] = {t.name: t for t in (phong.TECHNIQUE, gosselin.TECHNIQUE, deon.TECHNIQUE, ssss.TECHNIQUE,
                                                  separable.TECHNIQUE, burley.TECHNIQUE, burley2.TECHNIQUE,
                                                  penner.TECHNIQUE)}


def names() -> list[str]:
    return list(REGISTRY)


def get(name: str) -> Technique:
    if name not in REGISTRY:
        raise KeyError(f"technique '{name}' is not available (have: {', '.join(REGISTRY)})")
    return REGISTRY[name]


def build(name: str) -> tuple[list[Pass], list[str]]:
    t = get(name)
    return t.build(), list(t.targets)


__all__ = ["REGISTRY", "TARGETS", "Technique", "build", "get", "names", "shadow_passes"]
