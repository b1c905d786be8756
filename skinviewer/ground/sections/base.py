"""What a settings section is made of: the strict pydantic base, the shared validators, and
``field``, which declares a field's default, range, panel label, unit and tooltip together
(issue 28: a technique's section is declared in one place, its own module)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from skinviewer.ground.constants import REGIONS

Vec3 = tuple[float, float, float]


class Section(BaseModel):
    """A settings section: unknown keys are errors, assignments are validated."""
    model_config = ConfigDict(extra="forbid", validate_assignment=True)


@dataclass(frozen=True)
class FieldDoc:
    """What the panel shows for a field: its label (words an artist uses; the paper's term is in the
    tooltip), the unit after it, and the tooltip. Kept in the field's metadata, outside the JSON schema."""
    label: str | None = None
    unit: str = ""
    tip: str = ""


def field(default: Any = ..., *, label: str | None = None, unit: str = "", tip: str = "", **kw: Any) -> Any:
    """A section's field: ``Field(default, ge=..., le=..., description=...)`` plus the panel's
    ``label`` (default: the field name with spaces), ``unit`` and ``tip`` (the tooltip; default: the
    description). ``ui.fielddocs`` reads them; the JSON schema and validation are ``Field``'s."""
    info = Field(default, **kw)
    info.metadata.append(FieldDoc(label, unit, tip))
    return info


def field_doc(info: Any) -> FieldDoc | None:
    """The FieldDoc a field was declared with (``field``), or None."""
    return next((m for m in getattr(info, "metadata", ()) if isinstance(m, FieldDoc)), None)


def known_regions(v: dict[str, Any]) -> dict[str, Any]:
    bad = [k for k in v if k not in REGIONS]
    if bad:
        raise ValueError(f"unknown region(s) {bad}; known: {list(REGIONS)}")
    return v


def finite(v: float) -> float:
    if not math.isfinite(v):
        raise ValueError("must be a finite number")
    return v


def finite_vec(v: Vec3 | None) -> Vec3 | None:
    if v is not None and any(not math.isfinite(c) for c in v):
        raise ValueError("components must be finite numbers")
    return v


def odd(v: int) -> int:
    if v % 2 == 0:
        raise ValueError("must be odd (a centre tap)")
    return v
