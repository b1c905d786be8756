"""Each technique's preview ladder (issue 27): lighter configurations of the user's own settings,
cheapest first, that the viewer's quality governor (ui/governor.py) shows while the user drags
and steps up, when input stops, to the user's settings themselves (the last rung, ``{}``).

A rung caps the technique's own knobs at a value (never raises one the user set lower) and may
scale the view (``scale``: the render size's fraction, as the orbit resolution does). A rung that
changes nothing is left out. The governor times the rungs on the machine at hand
(engine/calibration.py) and picks among them; this module only says what they are."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from skinviewer.ground.settings import Settings, get_path


@dataclass(frozen=True)
class Rung:
    label: str  # what is shown, in the papers' terms ("irradiance 256², separable blurs")
    changes: dict[str, Any] = field(default_factory=dict)  # dotted path -> value; {}: the user's settings
    scale: float = 1.0  # the view's render size, as a fraction

    @property
    def final(self) -> bool:
        return not self.changes and self.scale == 1.0

    def __hash__(self) -> int:
        return hash((self.label, tuple(sorted((k, repr(v)) for k, v in self.changes.items())), self.scale))


FINAL = Rung("your settings")


def _cap(s: Settings, caps: dict[str, Any]) -> dict[str, Any]:
    """The caps that lower a value of ``s`` (numbers: min; other values: replaced when different)."""
    out = {}
    for path, value in caps.items():
        have = get_path(s, path)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if value < have:
                out[path] = value
        elif value != have:
            out[path] = value
    return out


def _deon(s: Settings) -> list[tuple[str, dict, float]]:
    sep = {"deon.surface_gather_below_texels": 0.0}
    small = {"deon.irradiance_size": 256, "deon.tsm_size": 256, **sep}
    # the cheapest: one shadow-map texel per test (PCF halves the 256² irradiance's cost on llvmpipe)
    return [("view ¼, irradiance 256², separable blurs, hard shadows", {**small, "shadow.pcf": 0}, 0.25),
            ("view ½, irradiance 256², separable blurs", {"deon.irradiance_size": 256, "deon.tsm_size": 256, **sep}, 0.5),
            ("irradiance 256², separable blurs", {"deon.irradiance_size": 256, "deon.tsm_size": 256, **sep}, 1.0),
            ("irradiance 512², separable blurs", {"deon.irradiance_size": 512, "deon.tsm_size": 512, **sep}, 1.0),
            ("irradiance 512²", {"deon.irradiance_size": 512, "deon.tsm_size": 512}, 1.0),
            ("separable blurs", sep, 1.0)]


def _gosselin(s: Settings) -> list[tuple[str, dict, float]]:
    return [("view ½, light map 256², 1 blur", {"gosselin.light_map_size": 256, "gosselin.iterations": 1}, 0.5),
            ("light map 256², 2 blurs", {"gosselin.light_map_size": 256, "gosselin.iterations": 2}, 1.0),
            ("light map 512²", {"gosselin.light_map_size": 512}, 1.0)]


def _phong(s: Settings) -> list[tuple[str, dict, float]]:
    return [("view ½, shadow map 512²", {"shadow.map_size": 512}, 0.5), ("shadow map 512²", {"shadow.map_size": 512}, 1.0)]


def _screen(knobs: list[tuple[str, dict]]) -> Callable[[Settings], list[tuple[str, dict, float]]]:
    """A screen-space technique: its cost follows the pixels, then its own sample counts."""
    def ladder(s: Settings) -> list[tuple[str, dict, float]]:
        cheap = knobs[0][1] if knobs else {}
        cheap_label = f", {knobs[0][0]}" if knobs else ""
        return ([("view ¼" + cheap_label, cheap, 0.25), ("view ½" + cheap_label, cheap, 0.5)]
                + [(label, ch, 1.0) for label, ch in knobs])
    return ladder


def _penner(s: Settings) -> list[tuple[str, dict, float]]:
    return [("view ½, tables 32²", {"penner.lut_size": 32}, 0.5), ("tables 32²", {"penner.lut_size": 32}, 1.0)]


LADDERS: dict[str, Callable[[Settings], list[tuple[str, dict, float]]]] = {
    "phong": _phong,
    "gosselin": _gosselin,
    "deon": _deon,
    "ssss": _screen([]),
    "separable": _screen([("7 taps", {"separable.taps": 7}), ("11 taps", {"separable.taps": 11})]),
    "burley": _screen([("6 samples", {"burley.samples": 6}), ("12 samples", {"burley.samples": 12})]),
    "burley2": _screen([("6+6 samples", {"burley2.base": 6, "burley2.extra": 6, "burley2.temporal": 0}),
                        ("no temporal", {"burley2.temporal": 0})]),
    "penner": _penner,
}


# how a change reads in the status bar (None: not named, it goes with another)
_WORDS: dict[str, Callable[[Any], str | None]] = {
    "deon.irradiance_size": lambda v: f"irradiance {v}²",
    "deon.tsm_size": lambda v: f"TSM {v}²",
    "deon.surface_gather_below_texels": lambda v: "separable blurs" if not v else f"summed below {v:g} texels",
    "gosselin.light_map_size": lambda v: f"light map {v}²",
    "gosselin.iterations": lambda v: f"{v} blur{'s' if v != 1 else ''}",
    "shadow.map_size": lambda v: f"shadow map {v}²",
    "separable.taps": lambda v: f"{v} taps",
    "burley.samples": lambda v: f"{v} samples",
    "burley2.base": lambda v: f"{v} base samples",
    "burley2.extra": lambda v: f"+{v}",
    "burley2.temporal": lambda v: "no temporal" if not v else f"temporal {v}",
    "penner.lut_size": lambda v: f"tables {v}²",
    "shadow.pcf": lambda v: "hard shadows" if not v else f"PCF {v}",
}


def describe(changes: dict[str, Any], scale: float = 1.0) -> str:
    """What a rung shows, from what it actually changes ("view ½, irradiance 256², separable blurs")."""
    words = [] if scale == 1.0 else [f"view {_FRACTIONS.get(scale, f'{scale:g}×')}"]
    for path, value in changes.items():
        w = _WORDS.get(path, lambda v, p=path: f"{p.split('.')[-1]} {v}")(value)
        if w:
            words.append(w)
    return ", ".join(words) or "your settings"


_FRACTIONS = {0.5: "½", 0.25: "¼"}


def ladder(s: Settings) -> list[Rung]:
    """The preview rungs of ``s.technique`` for the user's settings ``s``, as declared (cheapest
    first), each capped to what lowers ``s``, duplicates and no-ops left out, ending with FINAL."""
    out: list[Rung] = []
    seen = set()
    # the user's own settings on a smaller view: what an orbit can show without re-rendering the
    # texture-space work it has cached (ui/governor.py restricts a camera drag to these)
    views: list[tuple[str, dict, float]] = [("", {}, 0.25), ("", {}, 0.5)]
    for _label, caps, scale in views + LADDERS.get(s.technique, lambda s: [])(s):
        ch = _cap(s, caps)
        key = (tuple(sorted((k, repr(v)) for k, v in ch.items())), scale)
        if (not ch and scale == 1.0) or key in seen:
            continue
        seen.add(key)
        out.append(Rung(describe(ch, scale), ch, scale))
    return out + [FINAL]


def cheapest(s: Settings) -> Rung:
    """The cheapest rung of ``s``'s ladder as declared (the technique's first rung, capped to what
    lowers ``s``), without a calibration: the viewer's first image at a cold start, before this
    machine has timed any rung (issue 34). FINAL when the technique has no ladder or its first rung
    changes nothing."""
    declared = LADDERS.get(s.technique, lambda s: [])(s)
    if not declared:
        return FINAL
    _label, caps, scale = declared[0]
    ch = _cap(s, caps)
    if not ch and scale == 1.0:
        return FINAL
    return Rung(describe(ch, scale), ch, scale)
