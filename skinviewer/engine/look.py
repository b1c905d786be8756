"""The artist model in the settings: what the look (``look.*``, physics/artist.py) sets in each
technique's own fields, and the look a technique's fields show when the look does not drive them.

* d'Eon, ssss, penner (and Gosselin in mm mode) read ``deon.gaussians``: a table fitted to the look
  (exact energy and mean radius per channel, physics/artist.py);
* burley, burley2 read ``burley.albedo`` / ``burley.mfp``: the look itself (searchlight-dmfp, eq. 2.88);
* separable keeps Jimenez's own strength / falloff (its look controls are those).

The derivation is deterministic (a table rounded to 7 digits), so a preset saved with source = look
loads, re-derives and saves to the same bytes.
"""
from __future__ import annotations

from collections.abc import Collection, Iterable
from typing import Any

import numpy as np

from skinviewer.ground.settings import Settings, with_values
from skinviewer.physics import artist

# settings the look writes: an edit of one of these by hand hands the profile back to the table
DERIVED = ("deon.gaussians", "burley.albedo", "burley.mfp", "burley.fit")
# techniques whose profile is the Gaussian table / Burley's parameters / their own
TABLE_TECHNIQUES = ("deon", "ssss", "penner", "gosselin")
BURLEY_TECHNIQUES = ("burley", "burley2")
OWN_TECHNIQUES = ("separable", "phong")


def derived_values(s: Settings) -> dict[str, Any]:
    """The assignments the look makes (whatever ``look.source`` says)."""
    lk = s.look
    rows = artist.table(lk.scatter_color, lk.scatter_radius, lk.gaussians, normalize=lk.energy == "albedo-map")
    return {"deon.gaussians": [{"variance": v, "weights": list(w)} for v, w in rows],
            "burley.albedo": list(lk.scatter_color), "burley.mfp": list(lk.scatter_radius),
            "burley.fit": artist.FIT}


def apply_look(s: Settings) -> Settings:
    """``s`` with the look's values in the techniques' fields when the look drives them."""
    if s.look.source != "look":
        return s
    return with_values(s, derived_values(s))


def set_look(s: Settings, color: Iterable[float] | None = None, radius: Iterable[float] | None = None,
             **fields: Any) -> Settings:
    """The look changed by the artist: it drives the profile from now on."""
    a: dict[str, Any] = {"look.source": "look"}
    if color is not None:
        a["look.scatter_color"] = [float(x) for x in color]
    if radius is not None:
        a["look.scatter_radius"] = [float(x) for x in radius]
    a.update({f"look.{k}": v for k, v in fields.items()})
    return apply_look(with_values(s, a))


def touches_derived(assignments: Iterable[str]) -> bool:
    return any(k == d or k.startswith(d + ".") for k in assignments for d in DERIVED)


def touches_look(assignments: Iterable[str]) -> bool:
    return any(k == "look" or k.startswith("look.") for k in assignments)


def resolve(s: Settings, assignments: Collection[str]) -> Settings:
    """After ``assignments`` were applied to ``s``: a hand edit of a derived field (and none of the
    look) hands the profile to the table; an edit of the look (unless it sets ``look.source`` itself)
    makes the look drive and re-derives."""
    if touches_derived(assignments) and not touches_look(assignments) and s.look.source == "look":
        return with_values(s, {"look.source": "table"})
    if touches_look(assignments):
        if s.look.source != "look" and "look.source" not in assignments and "look" not in assignments:
            s = with_values(s, {"look.source": "look"})  # moving a look control means: the look drives
        return apply_look(s)
    return s


def shown_look(s: Settings, technique: str | None = None) -> tuple[np.ndarray, np.ndarray, str]:
    """(colour, radius mm, where it comes from) of the look for ``technique`` (default: the active one):
    the look's own values when it drives, else read back from that technique's fields."""
    t = technique or s.technique
    lk = s.look
    if lk.source == "look":
        return np.array(lk.scatter_color), np.array(lk.scatter_radius), "look"
    if t in BURLEY_TECHNIQUES:
        b = s.burley
        return np.array(b.albedo), np.array(b.mfp), "burley.albedo / burley.mfp"
    v = np.array([g.variance for g in s.deon.gaussians])
    w = np.array([g.weights for g in s.deon.gaussians])
    color = artist.estimate_color(w, lk.scatter_color)
    return color, np.clip(artist.estimate_radius(v, w, color), 0.01, 50.0), "estimated from deon.gaussians"
