"""``skinviewer settings --list``: every settable key (dotted path, as ``--set`` and presets take it),
generated from the settings model, with its type, default, allowed range, unit and meaning."""
from __future__ import annotations

import json
import typing

from pydantic import BaseModel

from skinviewer.ground.settings import REGIONS, Settings
from skinviewer.ui.fielddocs import doc as field_doc

CONVENTIONS = (
    "Conventions: lengths of built-in scenes are millimetres, other meshes are in mesh units "
    "(scene.mm_per_unit converts); a directional light's `direction` points from the surface TOWARDS the light "
    "(+z is in front of the default head's face, +y up, +x the head's left); colours are linear RGB; "
    "list items are addressed by index (lights.0.intensity), per-region tables by region name "
    f"({', '.join(REGIONS)})."
)


def _bounds(info) -> str:
    parts = []
    for m in info.metadata:
        for attr, sym in (("ge", ">="), ("gt", ">"), ("le", "<="), ("lt", "<"), ("min_length", "len>="),
                          ("max_length", "len<=")):
            v = getattr(m, attr, None)
            if v is not None:
                parts.append(f"{sym}{v}")
    return " ".join(parts)


def _type_name(ann) -> str:
    origin = typing.get_origin(ann)
    if origin is typing.Literal:
        return " | ".join(repr(a) for a in typing.get_args(ann))
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        return " | ".join(_type_name(a) for a in typing.get_args(ann))
    if origin is tuple:
        return "(" + ", ".join(_type_name(a) for a in typing.get_args(ann)) + ")"
    if ann is type(None):
        return "None"
    return getattr(ann, "__name__", str(ann))


def rows(model: BaseModel | None = None, prefix: str = "") -> list[dict]:
    """One row per leaf setting of ``model`` (default: the defaults), in declaration order."""
    model = model if model is not None else Settings()
    out: list[dict] = []
    for name, info in type(model).model_fields.items():
        path = f"{prefix}{name}"
        value = getattr(model, name)
        if isinstance(value, BaseModel):
            out += rows(value, path + ".")
            continue
        if isinstance(value, list) and value and isinstance(value[0], BaseModel):
            for i, item in enumerate(value):
                out += rows(item, f"{path}.{i}.")
            continue
        unit, doc = field_doc(path)
        out.append({"key": path, "type": _type_name(info.annotation), "default": value,
                    "range": _bounds(info), "unit": unit, "doc": doc or (info.description or "")})
    return out


def print_list(as_json: bool = False) -> None:
    table = rows()
    if as_json:
        print(json.dumps(table, indent=2, default=str))
        return
    print(CONVENTIONS)
    print()
    for r in table:
        default = json.dumps(r["default"], default=str)
        if len(default) > 60:
            default = default[:57] + "..."
        extra = "  ".join(x for x in (r["range"], f"[{r['unit']}]" if r["unit"] else "") if x)
        print(f"{r['key']:<44} {r['type']:<28} = {default}  {extra}")
        if r["doc"]:
            print(f"{'':<46}{r['doc']}")


def add_parser(sub) -> None:
    p = sub.add_parser("settings", help="list every settable key (for --set and presets)")
    p.add_argument("--list", action="store_true", default=True, help="list keys with type, default, range, unit")
    p.add_argument("--json", action="store_true", help="as JSON")
    p.set_defaults(func=_cmd_list)


def _cmd_list(args) -> int:
    print_list(args.json)
    return 0
