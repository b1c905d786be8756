"""What several panel sections share: the cost line of the last change, the shader error list."""
from __future__ import annotations

from imgui_bundle import imgui

from skinviewer.ui.frame import FrameController
from skinviewer.ui.widgets import DIM, ERR, OK, WARN, tooltip, wrapped

TEX_COL = imgui.ImVec4(0.35, 0.6, 1.0, 1.0)  # texture-space cost
VIEW_COL = imgui.ImVec4(1.0, 0.62, 0.3, 1.0)  # view-dependent cost


def _short(source: str, n: int = 38) -> str:
    return source if len(source) <= n else source[: n - 3] + "..."


def _same_line_if_fits(text: str, spacing: float = -1.0) -> None:
    """Continue the current line with ``text`` if it fits there, else start a new line."""
    imgui.same_line(0, spacing)
    if imgui.calc_text_size(text).x > imgui.get_content_region_avail().x:
        imgui.new_line()


def change_line(frame: FrameController, sections: tuple[str, ...] | None) -> None:
    """'last change: N ms (passes ...)' -- everywhere (None) or when the change came from ``sections``."""
    fr = frame
    ch = fr.last_change
    if fr.render_deferred:
        imgui.text_colored(WARN, "preview paused: release (or hold still) to render")
        tooltip(f"the last change cost {ch.total_ms:.0f} ms > the {fr.scheduler.budget_ms:.0f} ms budget "
                "(Quality & cost > scheduling)" if ch else "render scheduling: on release")
    if ch is None or (sections is not None and ch.section() not in sections):
        return
    if sections is not None and ch.source in ("render size",):
        return
    imgui.push_text_wrap_pos(0)
    imgui.text_colored(DIM, f"last change ({_short(ch.source)}): ")
    col = ERR if ch.total_ms > 1000 else (WARN if ch.total_ms > 100 else OK)
    # a part that does not fit after a long source goes on the next line (wrapped into the
    # few pixels left, it came out one or two letters per line)
    _same_line_if_fits(f"{ch.total_ms:.0f} ms", 0.0)
    imgui.text_colored(col, f"{ch.total_ms:.0f} ms")
    tail = f"= texture {ch.texture_ms:.0f} + view {ch.view_ms:.0f}"
    _same_line_if_fits(tail)
    imgui.text_colored(DIM, tail)
    imgui.pop_text_wrap_pos()
    rows = "\n".join(f"  {n:<22} {ms:8.1f} ms" for n, ms in ch.passes)
    tooltip(f"caused by: {ch.source}\npasses re-run ({ch.timing_mode} timing):\n{rows}")
    imgui.push_text_wrap_pos(0)
    imgui.text_disabled("  passes: " + ", ".join(f"{n} {ms:.0f}" for n, ms in ch.passes[:4])
                        + (f", +{len(ch.passes) - 4} more" if len(ch.passes) > 4 else ""))
    imgui.pop_text_wrap_pos()


def shader_errors(watcher, limit: int = 100) -> None:
    k = 0
    for name, errs in watcher.errors.items():
        for e in errs:
            if k >= limit:
                return
            wrapped(f"{e.file}:{e.line}: {e.message}  [{name}]", ERR)
            k += 1
