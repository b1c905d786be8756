"""Generic settings widgets: walk a pydantic model's fields and draw the matching imgui widget
(bool -> checkbox, Literal -> combo, bounded float -> slider/drag with those bounds, int -> input,
RGB tuple -> colour edit, 3-vector -> drag3, optional -> "auto" checkbox + value, str -> text).
Lists and dicts (tables) are hand-built by the panel. Edits are collected as dotted-path
assignments in the frame's ``UiContext``; the state validates them through ``with_values``;
invalid input shows a message. Nothing here is module-global: what a widget needs besides imgui
(where edits go, what an edit costs, whether every section is forced open) is in the context."""
from __future__ import annotations

import math
import types
import typing
from collections.abc import Callable
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Any, Literal

from imgui_bundle import imgui
from pydantic import BaseModel

from skinviewer.ui.fielddocs import doc, label_with_unit

_ENTER = imgui.InputTextFlags_.enter_returns_true.value
# colours shared by the panel, the passes window, the status bar and the profile lab
ERR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)
WARN = imgui.ImVec4(1.0, 0.8, 0.35, 1.0)
OK = imgui.ImVec4(0.55, 0.9, 0.55, 1.0)
DIM = imgui.ImVec4(0.65, 0.65, 0.7, 1.0)


def flow_legend(items, tooltips: dict[str, str] | None = None,
                hidden: set[str] | None = None, rects: dict | None = None) -> tuple[float, float]:
    """A plot's legend above it, as imgui items (issue 34): a colour square and the label per item
    ``(label, (r, g, b, a))``, wrapped into as many rows as the window's width needs (implot's own
    outside legend is one row, cut at the window's edge). With ``hidden`` (the caller's set of
    labels not to plot), a click on an item hides or shows its series, as implot's legend did; a
    hidden item is drawn dimmed; ``rects`` receives each item's screen rect (tests). Returns the rightmost x drawn and the right edge available
    (tests: the first never passes the second)."""
    from skinviewer.ui.layout import flow_rows
    sq = imgui.get_text_line_height() * 0.75
    gap = imgui.get_style().item_spacing.x
    widths = [sq + 4 + imgui.calc_text_size(label).x for label, _ in items]
    x0 = imgui.get_cursor_screen_pos().x
    avail = imgui.get_content_region_avail().x
    right = x0
    dl = imgui.get_window_draw_list()
    for row in flow_rows(widths, avail, gap * 2):
        for k, i in enumerate(row):
            label, col = items[i]
            if k:
                imgui.same_line(0, gap * 2)
            p = imgui.get_cursor_screen_pos()
            lh = imgui.get_text_line_height()
            off = hidden is not None and label in hidden
            a = col[3] * (0.3 if off else 1.0)
            dl.add_rect_filled(imgui.ImVec2(p.x, p.y + (lh - sq) / 2), imgui.ImVec2(p.x + sq, p.y + (lh + sq) / 2),
                               imgui.color_convert_float4_to_u32(imgui.ImVec4(col[0], col[1], col[2], a)))
            if hidden is None:
                imgui.dummy(imgui.ImVec2(sq, lh))
                imgui.same_line(0, 4)
                imgui.text(label)
            else:  # the square and the label as one button: a click toggles the series
                imgui.invisible_button(f"##legend-{label}", imgui.ImVec2(widths[i], lh))
                clicked = imgui.is_item_clicked(0)
                dl.add_text(imgui.ImVec2(p.x + sq + 4, p.y), imgui.get_color_u32(
                    imgui.Col_.text_disabled.value if off else imgui.Col_.text.value), label)
                if clicked:
                    hidden.symmetric_difference_update({label})
            tip = (tooltips or {}).get(label, "")
            if hidden is not None:
                tip = (tip + "\n" if tip else "") + ("hidden: click to show" if off else "click to hide")
            if tip:
                tooltip(tip)
            right = max(right, imgui.get_item_rect_max().x)
            if rects is not None:
                rects[label] = (p.x, p.y, imgui.get_item_rect_max().x - p.x, lh)
    return right, x0 + avail


def wrapped(text: str, color: imgui.ImVec4 | None = None) -> None:
    """Text wrapped at the window edge: dimmed, or in ``color``."""
    imgui.push_text_wrap_pos(0)
    if color is None:
        imgui.text_disabled(text)
    else:
        imgui.text_colored(color, text)
    imgui.pop_text_wrap_pos()


def begin_docked(name: str, rect, flags: int, bg: imgui.ImVec4, padding: tuple[float, float] | None = None) -> bool:
    """Begin a window pinned to ``rect`` (x, y, w, h) of the layout: square corners, its own
    background. Returns whether it is open; the caller calls ``imgui.end()``."""
    x, y, w, h = rect
    imgui.set_next_window_pos(imgui.ImVec2(x, y), imgui.Cond_.always.value)
    imgui.set_next_window_size(imgui.ImVec2(w, h), imgui.Cond_.always.value)
    imgui.push_style_var(imgui.StyleVar_.window_rounding.value, 0.0)
    if padding is not None:
        imgui.push_style_var(imgui.StyleVar_.window_padding.value, imgui.ImVec2(*padding))
    imgui.push_style_color(imgui.Col_.window_bg.value, bg)
    opened = imgui.begin(name, None, flags)[0]
    imgui.pop_style_color()
    imgui.pop_style_var(1 if padding is None else 2)
    return opened


TOOLTIP_EM = 32.0  # tooltips wrap at this many font heights (never wider than the window)


def tooltip(text: str) -> None:
    """A tooltip for the last item when it is hovered: wrapped, so a long line never runs off the window."""
    if imgui.is_item_hovered(imgui.HoveredFlags_.for_tooltip.value):
        show_tooltip(text)


def show_tooltip(text: str) -> None:
    """A wrapped tooltip now (the caller decided it is hovered)."""
    if not text:
        return
    wrap = imgui.get_font_size() * TOOLTIP_EM
    io = imgui.get_io()
    wrap = max(120.0, min(wrap, io.display_size.x * 0.6))
    if imgui.begin_tooltip():
        imgui.push_text_wrap_pos(wrap)
        imgui.text_unformatted(text)
        imgui.pop_text_wrap_pos()
        imgui.end_tooltip()


def error_list(errors, limit: int) -> None:
    """A bullet per (path, message), in red, at most ``limit``."""
    for path, msg in list(errors)[:limit]:
        imgui.bullet()
        wrapped(f"{path}: {msg}", ERR)



class Edits:
    """Assignments collected while drawing a frame; applied (validated) by the state afterwards."""

    def __init__(self):
        self.values: dict[str, Any] = {}

    def set(self, path: str, value: Any) -> None:
        self.values[path] = value

    def __bool__(self):
        return bool(self.values)


@dataclass
class UiContext:
    """What the windows and widgets of one imgui frame get besides imgui: the layout, where edits
    go, what editing a setting costs (the frame controller's ``cost_hint``), whether every section
    is forced open (tests), and the rectangles the UI covers (input hit-testing)."""
    layout: Any = None
    edits: Edits = dc_field(default_factory=Edits)
    cost_hint: Callable[[str], str] | None = None
    expand_all: bool = False
    rects: list[tuple[float, float, float, float]] = dc_field(default_factory=list)
    pending: dict[str, Any] = dc_field(default_factory=dict)  # typed, not yet applied values (kept across frames)

    def header(self, label: str, open_default: bool = False) -> bool:
        """A collapsing section header (forced open when ``expand_all``)."""
        flags = imgui.TreeNodeFlags_.default_open.value if open_default else 0
        if self.expand_all:
            imgui.set_next_item_open(True)
        return imgui.collapsing_header(label, flags)

    def claim(self, rect: tuple[float, float, float, float]) -> None:
        """This window covers ``rect`` (x, y, w, h): the mouse there belongs to the UI, not the view."""
        self.rects.append((rect[0], rect[1], rect[2], rect[3]))


def _unwrap_optional(ann) -> tuple[Any, bool]:
    origin = typing.get_origin(ann)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(ann) if a is not type(None)]
        if len(args) == 1:
            return args[0], True
    return ann, False


def bounds(field) -> tuple[float | None, float | None, bool, bool]:
    """(lo, hi, lo_exclusive, hi_exclusive) from a pydantic FieldInfo's annotated-types metadata."""
    lo = hi = None
    lo_x = hi_x = False
    for m in field.metadata:
        for attr, is_lo, excl in (("ge", True, False), ("gt", True, True), ("le", False, False), ("lt", False, True)):
            v = getattr(m, attr, None)
            if v is not None:
                if is_lo:
                    lo, lo_x = float(v), excl
                else:
                    hi, hi_x = float(v), excl
    return lo, hi, lo_x, hi_x


def classify(field) -> tuple[str, Any, bool]:
    """(kind, detail, optional): kind in bool, literal, int, float, vec3, color, str, model, other."""
    ann, optional = _unwrap_optional(field.annotation)
    origin = typing.get_origin(ann)
    if ann is bool:
        return "bool", None, optional
    if origin is Literal:
        return "literal", list(typing.get_args(ann)), optional
    if ann is int:
        return "int", None, optional
    if ann is float:
        return "float", None, optional
    if ann is str:
        return "str", None, optional
    if origin is tuple and typing.get_args(ann) == (float, float, float):
        return "vec3", None, optional
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return "model", ann, optional
    return "other", None, optional


def tooltip_text(field, path: str, cost_hint: Callable[[str], str] | None = None) -> str:
    """The field's tooltip, each line once: its meaning (fielddocs, else the model's description --
    both say the same thing in other words), range, setting path, and what editing it re-runs."""
    unit, text = doc(path)
    parts = [text or (field.description or "")]
    lo, hi, lo_x, hi_x = bounds(field)
    if lo is not None or hi is not None:
        rng = f"{'(' if lo_x else '['}{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}{')' if hi_x else ']'}"
        parts.append(f"range {rng}{' ' + unit if unit else ''}")
    parts.append(f"setting: {path}")
    if cost_hint is not None:
        parts.append(cost_hint(path))
    out: list[str] = []
    for p in parts:
        if p and p not in out:
            out.append(p)
    return "\n".join(out)


@dataclass
class _Field:
    """One settings field being drawn: what the per-kind widgets below need."""
    name: str
    info: Any  # pydantic FieldInfo
    value: Any
    path: str
    label: str
    detail: Any
    optional: bool
    ui: UiContext

    def set(self, value: Any) -> None:
        self.ui.edits.set(self.path, value)

    def tooltip(self) -> None:
        if imgui.is_item_hovered(imgui.HoveredFlags_.for_tooltip.value):
            show_tooltip(tooltip_text(self.info, self.path, self.ui.cost_hint))


def _w_bool(f: _Field) -> None:
    ch, v = imgui.checkbox(f.label, bool(f.value))
    if ch:
        f.set(v)


def _w_literal(f: _Field) -> None:
    opts = [str(o) for o in f.detail]
    cur = opts.index(str(f.value)) if str(f.value) in opts else 0
    ch, i = imgui.combo(f.label, cur, opts)
    if ch:
        f.set(f.detail[i])


def _w_int(f: _Field) -> None:
    lo, hi, _, _ = bounds(f.info)
    if lo is not None and hi is not None and hi - lo <= 64:
        ch, v = imgui.slider_int(f.label, int(f.value), int(lo), int(hi))
    else:
        # typed values apply when the field is left (no half-typed map sizes); +/- apply at once
        pending = f.ui.pending
        ch, v = imgui.input_int(f.label, int(pending.get(f.path, f.value)), 1, 64)
        if ch:
            pending[f.path] = int(v)
        if imgui.is_item_deactivated_after_edit() or (ch and not imgui.is_item_active()):
            v = pending.pop(f.path, v)
            ch = True
        else:
            ch = False
    if ch:
        f.set(int(v))


def _w_float(f: _Field) -> None:
    _edit_float(f.label, f.info, float(f.value), f.path, f.ui.edits)


def _w_vec3(f: _Field) -> None:
    v = [float(x) for x in f.value]
    if "color" in f.name or "colour" in f.name:
        ch, nv = imgui.color_edit3(f.label, v, imgui.ColorEditFlags_.float.value | imgui.ColorEditFlags_.hdr.value)
    else:
        ch, nv = imgui.drag_float3(f.label, v, 0.01 * max(1.0, max(abs(x) for x in v) * 0.1))
    if ch:
        f.set([float(x) for x in nv])


def _w_str(f: _Field) -> None:
    ch, text = imgui.input_text(f.label, f.value or "", _ENTER)
    if ch:
        f.set(text.strip() or (None if f.optional else ""))


def _w_model(f: _Field) -> None:
    if imgui.tree_node(f.label):
        edit_model(f.value, f.path, f.ui)
        imgui.tree_pop()


def _w_other(f: _Field) -> None:
    imgui.text_disabled(f"{f.label}: {f.value!r}")


_WIDGETS = {"bool": _w_bool, "literal": _w_literal, "int": _w_int, "float": _w_float, "vec3": _w_vec3,
            "str": _w_str, "model": _w_model}


def _auto_toggle(f: _Field, kind: str) -> bool:
    """An optional number: the "auto" checkbox; returns True when the value is auto (nothing more to draw)."""
    ch, auto_new = imgui.checkbox("auto##auto", f.value is None)
    f.tooltip()
    if ch:
        f.set(None if auto_new else _default_for(kind, f.info))
    imgui.same_line()
    if f.value is None:
        imgui.text_disabled(f"{f.label}: auto")
        return True
    return False


def edit_field(name: str, field, value: Any, path: str, ui: UiContext) -> None:
    kind, detail, optional = classify(field)
    f = _Field(name, field, value, path, label_with_unit(name, path), detail, optional, ui)
    imgui.push_id(path)
    try:
        if optional and kind in ("float", "vec3", "int") and _auto_toggle(f, kind):
            return
        _WIDGETS.get(kind, _w_other)(f)
        f.tooltip()
    finally:
        imgui.pop_id()


def _default_for(kind: str, field):
    lo, hi, lo_x, _ = bounds(field)
    if kind == "vec3":
        return [0.0, 0.0, 0.0]
    if kind == "int":
        return int(lo) if lo is not None else 0
    if lo is not None:
        return max(1.0, lo + (1e-3 if lo_x else 0.0))
    return 1.0


def _edit_float(label: str, field, value: float, path: str, edits: Edits) -> None:
    lo, hi, lo_x, hi_x = bounds(field)
    fmt = "%.4g"
    if lo is not None and hi is not None and hi - lo <= 100.0:
        vmin = lo + (1e-4 if lo_x else 0.0)
        vmax = hi - (1e-4 if hi_x else 0.0)
        ch, v = imgui.slider_float(label, value, vmin, vmax, fmt)
    else:
        speed = max(abs(value) * 0.01, 1e-3)
        vmin = -3.4e38 if lo is None else lo + (1e-6 if lo_x else 0.0)
        vmax = 3.4e38 if hi is None else hi
        ch, v = imgui.drag_float(label, value, speed, vmin, vmax, fmt)
    if ch and math.isfinite(v) and v != value:
        edits.set(path, float(v))


def edit_model(obj: BaseModel, prefix: str, ui: UiContext, skip: tuple[str, ...] = (),
               only: tuple[str, ...] | None = None) -> None:
    """Widgets for every scalar/vector field of ``obj`` (skipping lists and dicts: tables)."""
    for name, field in type(obj).model_fields.items():
        if name in skip or (only is not None and name not in only):
            continue
        kind, _, _ = classify(field)
        if kind == "other":
            continue
        path = f"{prefix}.{name}" if prefix else name
        edit_field(name, field, getattr(obj, name), path, ui)
