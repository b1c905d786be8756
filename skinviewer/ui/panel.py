"""The main settings panel: a column docked to the left (or right) edge of the window, resizable by
dragging its inner edge; the 3D view takes the rest (``ui/layout.py``). Collapsing sections built
mostly from the settings model (``widgets.edit_model``, units and tooltips from ``fielddocs``); the
Gaussian, per-region and light tables are hand-built. Each section shows what the last change made
in it cost (which passes re-ran, in ms), and the Technique section splits the frame cost into
texture-space and view-dependent work."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from imgui_bundle import imgui

from skinviewer.core.settings import REGIONS, profile_warnings
from skinviewer.scene.scenes import SCENES
from skinviewer.ui import profile_plot
from skinviewer.ui.camera_control import angles_to_direction, direction_to_angles
from skinviewer.ui.compare import MODES as COMPARE_MODES
from skinviewer.ui.fielddocs import LABEL_MAX_PX, doc
from skinviewer.ui.frame import DRAG_RESOLUTIONS, FrameController
from skinviewer.ui.profile_lab import ProfileLab
from skinviewer.ui.scheduler import MODES as RENDER_MODES
from skinviewer.ui.scheduler import split_ms
from skinviewer.ui.state import PANEL_SIDES, ViewerState
from skinviewer.ui.widgets import (
    DIM,
    ERR,
    OK,
    WARN,
    UiContext,
    begin_docked,
    edit_model,
    error_list,
    tooltip,
    wrapped,
)

_ENTER = imgui.InputTextFlags_.enter_returns_true.value
TEX_COL = imgui.ImVec4(0.35, 0.6, 1.0, 1.0)  # texture-space cost
VIEW_COL = imgui.ImVec4(1.0, 0.62, 0.3, 1.0)  # view-dependent cost
LABEL_COLUMN_PX = LABEL_MAX_PX + 8.0  # room for labels with units (fielddocs keeps them this short)
CONFIRM_POPUP = "Unsaved changes###confirm_load"


def shortcuts(technique_names: list[str]) -> tuple[tuple[str, str], ...]:
    """The keyboard and mouse help; technique keys 1..N from the registry."""
    n = min(len(technique_names), 9)
    keys = " / ".join(str(i + 1) for i in range(n))
    return (
        ("LMB drag (view)", "orbit"), ("MMB / Shift+LMB drag", "pan"), ("wheel", "zoom"),
        ("RMB drag (view)", "move the key light"), ("R", "reset view"),
        (keys, " / ".join(technique_names[:n])),
        ("F1", "hide / show the UI"), ("F12", "screenshot"),
        ("Ctrl+S", "save preset (a shipped one: a copy in your folder)"),
        ("Space", "A/B: toggle A and B (compare on)"), ("Esc", "leave the pass inspector"),
    )


def _short(source: str, n: int = 38) -> str:
    return source if len(source) <= n else source[: n - 3] + "..."


def _same_line_if_fits(text: str, spacing: float = -1.0) -> None:
    """Continue the current line with ``text`` if it fits there, else start a new line."""
    imgui.same_line(0, spacing)
    if imgui.calc_text_size(text).x > imgui.get_content_region_avail().x:
        imgui.new_line()


class Panel:
    """The docked settings column. Reads the state and the frame controller; changes them only
    through their methods (settings edits through ``ui.edits`` or ``state.apply``)."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame
        self.mesh_path = ""
        self.lab = ProfileLab(state)
        self.log_r = True  # the profile plot's radius axis (see ui/profile_plot.py)
        self.plot_rect: tuple[float, float, float, float] | None = None  # last drawn profile plot (tests)
        self.scroll_y = 0.0  # the column's scroll position last frame (tests)
        self._scroll_to: float | None = None

    def scroll_to(self, y: float) -> None:
        """Scroll the column to ``y`` (pixels from its top) next frame."""
        self._scroll_to = float(y)

    # ------------------------------------------------------------------------------------------
    def draw(self, ui: UiContext) -> None:
        st = self.state
        rect = ui.layout.panel
        if rect is None:
            return
        x, y, pw, ph = rect
        flags = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_collapse
                 | imgui.WindowFlags_.no_bring_to_front_on_focus | imgui.WindowFlags_.no_saved_settings)
        opened = begin_docked("skinviewer###panel", rect, flags, imgui.ImVec4(0.09, 0.09, 0.1, 1.0))
        size = imgui.get_window_size()
        if abs(size.x - pw) > 0.5:  # the user dragged the inner edge: remember the width
            st.set_panel_width(float(size.x))
        if self._scroll_to is not None:
            imgui.set_scroll_y(self._scroll_to)
            self._scroll_to = None
        self.scroll_y = float(imgui.get_scroll_y())
        if opened:
            imgui.push_item_width(-min(LABEL_COLUMN_PX, pw * 0.42))  # room for labels with units
            self._status(ui)
            self._technique(ui)
            self._scene(ui)
            self._camera(ui)
            self._lights(ui)
            self._technique_sections(ui)
            self._render(ui)
            self._presets(ui)
            self._screenshot(ui)
            self._compare(ui)
            self._shaders(ui)
            self.lab.draw(ui)
            self._help(ui)
            imgui.pop_item_width()
            self._confirm_load_popup()
        ui.claim((x, y, pw, ph))
        imgui.end()

    # ------------------------------------------------------------------------------------------
    def _status(self, ui: UiContext) -> None:
        st, fr = self.state, self.frame
        s = st.settings
        wrapped(st.scene.description if st.scene else "-", DIM)
        p = st.presets
        marker = " (unsaved changes, Ctrl+S)" if p.dirty(s) else ""
        ro = " (shipped, read-only)" if p.read_only else ""
        imgui.text_colored(WARN if marker else DIM, f"preset: {Path(p.path).name if p.path else '(none)'}{ro}{marker}")
        if p.path:
            tooltip(p.path)
        self._change_line(None)
        if st.errors:
            imgui.text_colored(ERR, f"refused: {st.error_title}")
            error_list(st.errors, 8)
            if imgui.small_button("dismiss##err"):
                st.dismiss_errors()
        if fr.render_error:
            wrapped(f"render: {fr.render_error}", ERR)
        errs = fr.watcher.errors
        if errs:
            n = sum(len(v) for v in errs.values())
            imgui.text_colored(ERR, f"shader errors ({n}) - last good programs still running:")
            self._shader_errors(limit=4)
        for note in st.notices[-4:]:
            wrapped(note, DIM)
        imgui.separator()

    def _shader_errors(self, limit: int = 100) -> None:
        k = 0
        for name, errs in self.frame.watcher.errors.items():
            for e in errs:
                if k >= limit:
                    return
                wrapped(f"{e.file}:{e.line}: {e.message}  [{name}]", ERR)
                k += 1

    # -- cost accounting ----------------------------------------------------------------------
    def _change_line(self, sections: tuple[str, ...] | None) -> None:
        """'last change: N ms (passes ...)' -- everywhere (None) or when the change came from ``sections``."""
        fr = self.frame
        ch = fr.last_change
        if fr.render_deferred:
            imgui.text_colored(WARN, "preview paused: release (or hold still) to render")
            tooltip(f"the last change cost {ch.total_ms:.0f} ms > the {fr.scheduler.budget_ms:.0f} ms budget "
                    "(Technique > scheduling)" if ch else "render scheduling: on release")
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

    def _cost_split(self) -> None:
        """The technique's frame cost: this frame, and a full frame at the passes' last-run costs,
        split into texture-space (cached while orbiting) and view-dependent work."""
        fr = self.frame
        rep = fr.report
        if rep is None:
            imgui.text_disabled("no frame yet")
            return
        vset = fr.view_passes()
        live = [p for p in rep.passes if p.status != "pruned"]
        now_tex, now_view = split_ms(rep, vset, lambda p: p.ms if p.status == "ran" else None)
        full_tex, full_view = split_ms(rep, vset, lambda p: fr.last_ms.get(p.name) if p.status != "pruned" else None)
        imgui.text(f"this frame: {now_tex + now_view:.1f} ms")
        imgui.same_line()
        imgui.text_disabled(f"({len(rep.ran)} of {len(live)} passes ran, {rep.timing_mode} timing)")
        from skinviewer.core.graph import TIMING_NOTES
        tooltip(TIMING_NOTES.get(rep.timing_mode, ""))
        total = full_tex + full_view
        imgui.text("full frame:")
        imgui.same_line()
        imgui.text_colored(TEX_COL, f"texture-space {full_tex:.0f} ms")
        imgui.same_line()
        imgui.text("+")
        imgui.same_line()
        imgui.text_colored(VIEW_COL, f"view {full_view:.0f} ms")
        tooltip("at each live pass's last measured cost.\n"
                "texture-space: re-run only when their settings / lights / mesh change;\n"
                "view-dependent: re-run on every camera move (orbit cost).")
        # a two-colour bar: the share of each
        w = imgui.get_content_region_avail().x
        p0 = imgui.get_cursor_screen_pos()
        hbar = 6.0
        dl = imgui.get_window_draw_list()
        dl.add_rect_filled(p0, imgui.ImVec2(p0.x + w, p0.y + hbar), imgui.get_color_u32(imgui.ImVec4(0.2, 0.2, 0.24, 1)))
        if total > 0:
            xt = p0.x + w * full_tex / total
            dl.add_rect_filled(p0, imgui.ImVec2(xt, p0.y + hbar), imgui.get_color_u32(TEX_COL))
            dl.add_rect_filled(imgui.ImVec2(xt, p0.y), imgui.ImVec2(p0.x + w, p0.y + hbar), imgui.get_color_u32(VIEW_COL))
        imgui.dummy(imgui.ImVec2(w, hbar + 2))

    def _technique(self, ui: UiContext) -> None:
        st, fr = self.state, self.frame
        if not ui.header("Technique & cost", True):
            return
        names = st.technique_names()
        cur = names.index(st.settings.technique) if st.settings.technique in names else 0
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
        ch, i = imgui.combo(f"technique (keys 1-{min(len(names), 9)})", cur, names)
        if ch:
            st.set_technique(names[i])
        tooltip("keys " + " / ".join(f"{k + 1}: {n}" for k, n in enumerate(names[:9]))
                + ". Each technique keeps its own cached graph: switching back is instant")
        self._cost_split()
        sch = fr.scheduler
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
        ch, i = imgui.combo("while dragging", RENDER_MODES.index(sch.mode), list(RENDER_MODES))
        if ch:
            fr.set_schedule(mode=RENDER_MODES[i])
        tooltip("adaptive: render every frame while a slider is dragged unless the last change cost more than "
                "the budget; then render when it is released or held still.\n"
                "live: always render (the UI may freeze on slow GL).\n"
                "on release: render only on release / when held still.")
        if sch.mode == "adaptive":
            imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
            ch, v = imgui.slider_float("budget (ms)", sch.budget_ms, 10.0, 2000.0, "%.0f ms",
                                       imgui.SliderFlags_.logarithmic.value)
            if ch:
                fr.set_schedule(budget_ms=v)
        spread = fr.frame_budget_ms is not None
        ch, spread = imgui.checkbox("spread long frames", spread)
        if ch:
            fr.set_frame_budget(100.0 if spread else None)
        tooltip("a change whose passes take longer than the budget is rendered over several frames: the UI "
                "stays responsive and the image changes once, complete")
        if fr.frame_budget_ms is not None:
            imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
            ch, v = imgui.slider_float("frame budget", fr.frame_budget_ms, 16.0, 1000.0, "%.0f ms",
                                       imgui.SliderFlags_.logarithmic.value)
            if ch:
                fr.set_frame_budget(v)
        modes = list(DRAG_RESOLUTIONS)
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
        ch, i = imgui.combo("orbit resolution", modes.index(fr.drag_resolution), modes)
        if ch:
            fr.set_drag_resolution(modes[i])
        tooltip("resolution of the view while the camera is dragged; full size again on release.\n"
                "auto: lower it just enough that the view-dependent passes fit "
                f"{fr.drag_budget_ms:.0f} ms (texture-space passes stay cached either way)")

    def _scene(self, ui: UiContext) -> None:
        st = self.state
        if not ui.header("Scene"):
            return
        sc = st.settings.scene
        cur = SCENES.index(sc.name) if sc.name in SCENES else 0
        label = "built-in scene" + (" (mesh overrides)" if sc.mesh else "")
        ch, i = imgui.combo(label, cur, list(SCENES))
        if ch:
            st.select_scene(SCENES[i])
        if not self.mesh_path and sc.mesh and not imgui.is_any_item_active():
            self.mesh_path = sc.mesh
        entered, self.mesh_path = imgui.input_text("mesh path", self.mesh_path, _ENTER)
        if imgui.button("load mesh") or (entered and self.mesh_path.strip()):
            st.load_mesh(self.mesh_path.strip())
        imgui.same_line()
        if imgui.button("use built-in"):
            self.mesh_path = ""
            st.apply({"scene.mesh": None}, "scene")
        edit_model(sc, "scene", ui, skip=("name", "mesh"))
        self._change_line(("scene",))

    def _camera(self, ui: UiContext) -> None:
        st = self.state
        if not ui.header("Camera"):
            return
        wrapped("in the view: LMB orbit, MMB / shift+LMB pan, wheel zoom, RMB key light")
        edit_model(st.settings.camera, "camera", ui)
        if imgui.button("reset view (R)"):
            st.reset_camera()
        self._change_line(("camera",))

    def _lights(self, ui: UiContext) -> None:
        st = self.state
        if not ui.header("Lights", True):
            return
        lights = st.settings.lights
        remove = None
        for i, light in enumerate(lights):
            imgui.push_id(f"light{i}")
            name = {0: "key", 1: "rim"}.get(i, f"light {i}")
            open_ = imgui.tree_node_ex(f"{name} ({light.kind}{'' if light.enabled else ', off'})###l{i}",
                                       imgui.TreeNodeFlags_.default_open.value if i == 0 else 0)
            if open_:
                if light.kind == "directional":
                    az, el = direction_to_angles(light.direction)
                    ch1, az = imgui.slider_float("azimuth", az, -180.0, 180.0, "%.1f deg")
                    ch2, el = imgui.slider_float("elevation", el, -89.0, 89.0, "%.1f deg")
                    if ch1 or ch2:
                        ui.edits.set(f"lights.{i}.direction", list(angles_to_direction(az, el)))
                    self._direction_pad(i, az, el, ui)
                edit_model(light, f"lights.{i}", ui)
                if len(lights) > 1 and imgui.small_button("remove light"):
                    remove = i
                imgui.tree_pop()
            imgui.pop_id()
        if len(lights) < 4 and imgui.small_button("add light"):
            ui.edits.set(f"lights.{len(lights)}", {"intensity": 1.0})
        if remove is not None:
            data = [x.model_dump(mode="json") for k, x in enumerate(lights) if k != remove]
            st.apply({"lights": data}, "lights")
        if imgui.tree_node("shadows"):
            edit_model(st.settings.shadow, "shadow", ui)
            imgui.tree_pop()
        self._change_line(("lights", "shadow"))

    def _direction_pad(self, i: int, az: float, el: float, ui: UiContext) -> None:
        """A little disc: drag the dot to aim the light (azimuth around, elevation from the centre)."""
        size = 84.0
        p = imgui.get_cursor_screen_pos()
        imgui.invisible_button("dirpad", imgui.ImVec2(size, size))
        dl = imgui.get_window_draw_list()
        c = imgui.ImVec2(p.x + size / 2, p.y + size / 2)
        rad = size / 2 - 3
        dl.add_circle_filled(c, rad, imgui.get_color_u32(imgui.ImVec4(0.16, 0.16, 0.2, 1.0)))
        dl.add_circle(c, rad, imgui.get_color_u32(imgui.ImVec4(0.5, 0.5, 0.55, 1.0)))
        dl.add_circle(c, rad * 0.5, imgui.get_color_u32(imgui.ImVec4(0.3, 0.3, 0.35, 1.0)))
        # polar: centre = straight up, inner ring = horizon, rim = straight down; down the pad = front (+Z)
        rr = min(rad, (90.0 - el) / 180.0 * rad)
        a = math.radians(az)
        dot = imgui.ImVec2(c.x + math.sin(a) * rr, c.y + math.cos(a) * rr)
        dl.add_circle_filled(dot, 5.0, imgui.get_color_u32(imgui.ImVec4(1.0, 0.85, 0.3, 1.0)))
        if imgui.is_item_active():
            m = imgui.get_io().mouse_pos
            dx, dy = m.x - c.x, m.y - c.y
            d = min(math.hypot(dx, dy), rad)
            new_el = 90.0 - d / rad * 180.0
            new_az = math.degrees(math.atan2(dx, dy))
            ui.edits.set(f"lights.{i}.direction", list(angles_to_direction(new_az, max(-89.0, min(89.0, new_el)))))
        imgui.same_line()
        imgui.text_disabled("drag to aim\ncentre = above\ninner ring = horizon\nbottom = front, top = behind")

    # ------------------------------------------------------------------------------------------
    def _technique_sections(self, ui: UiContext) -> None:
        s = self.state.settings
        tag = {True: "  (active)", False: ""}
        if ui.header(f"Phong{tag[s.technique == 'phong']}###Phong"):
            edit_model(s.phong, "phong", ui)
            self._change_line(("phong",))
        if ui.header(f"Gosselin 2004{tag[s.technique == 'gosselin']}###Gosselin", s.technique == "gosselin"):
            wrapped("seed 000 §4.1, eq. 8-19: texture-space light map + Poisson blurs")
            edit_model(s.gosselin, "gosselin", ui, skip=("regions",))
            self._region_kernels(ui)
            self._change_line(("gosselin",))
        if ui.header(f"d'Eon 2007{tag[s.technique == 'deon']}###deon", s.technique == "deon"):
            wrapped("seed 000 §4.2, eq. 20-35: sum-of-Gaussians diffusion in texture space")
            self._gaussians(ui)
            self._profile_plot()
            edit_model(s.deon, "deon", ui)
            for w in profile_warnings(s.deon):
                wrapped("! " + w, WARN)
            self._change_line(("deon",))
        if ui.header("Specular (Kelemen / Szirmay-Kalos)###Specular"):
            wrapped("seed 000 eq. 14-16 (gosselin, deon)")
            edit_model(s.specular, "specular", ui, skip=("per_region",))
            self._region_specular(ui)
            self._change_line(("specular",))

    def _region_kernels(self, ui: UiContext) -> None:
        regions = self.state.settings.gosselin.regions
        imgui.text("blur size per face region")
        imgui.same_line()
        imgui.text_disabled("(eq. 12)")
        tooltip("blur radius = size * (kernel size * scale + offset), per region of the region map; "
                "size = 1/1024: radii are texels at a 1024² light map (rescaled to the light map size)")
        flags = imgui.TableFlags_.borders.value | imgui.TableFlags_.row_bg.value | imgui.TableFlags_.sizing_stretch_same.value
        if imgui.begin_table("kernels", 4, flags):
            for col in ("region", "kernel", "scale", "offset"):
                imgui.table_setup_column(col)
            imgui.table_headers_row()
            for reg in REGIONS:
                rk = regions.get(reg)
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text(reg)
                vals = (rk.kernel_size, rk.scale_x, rk.scale_y) if rk else (1.0, 1.0, 0.0)
                for fname, v in zip(("kernel_size", "scale_x", "scale_y"), vals):
                    imgui.table_next_column()
                    imgui.set_next_item_width(-1)
                    ch, nv = imgui.drag_float(f"##{reg}{fname}", float(v), 0.01, 0.0, 1000.0, "%.3g")
                    unit, text = doc(f"gosselin.regions.{reg}.{fname}")
                    tooltip(f"{reg}: {text}" + (f" ({unit})" if unit else ""))
                    if ch:
                        row = rk.model_dump() if rk else {"kernel_size": 1.0, "scale_x": 1.0, "scale_y": 0.0}
                        row[fname] = float(nv)
                        ui.edits.set(f"gosselin.regions.{reg}", row)
            imgui.end_table()

    def _region_specular(self, ui: UiContext) -> None:
        s = self.state.settings.specular
        imgui.text("per-region overrides (unchecked: global value)")
        flags = imgui.TableFlags_.borders.value | imgui.TableFlags_.row_bg.value
        if imgui.begin_table("specreg", 3, flags):
            for col in ("region", "roughness", "intensity"):
                imgui.table_setup_column(col)
            imgui.table_headers_row()
            for reg in REGIONS:
                ov = s.per_region.get(reg)
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text(reg)
                for fname, glob, hi in (("m", s.m, 1.0), ("rho_s", s.rho_s, 10.0)):
                    imgui.table_next_column()
                    cur = getattr(ov, fname) if ov else None
                    imgui.push_id(f"{reg}{fname}")
                    ch, on = imgui.checkbox("##on", cur is not None)
                    tooltip(f"{reg}: its own {'roughness m' if fname == 'm' else 'intensity rho_s'} "
                            "(unchecked: the global value)")
                    row = ov.model_dump() if ov else {"m": None, "rho_s": None}
                    if ch:
                        row[fname] = float(glob) if on else None
                        ui.edits.set(f"specular.per_region.{reg}", row)
                    if cur is not None:
                        imgui.same_line()
                        imgui.set_next_item_width(-1)
                        ch, nv = imgui.drag_float("##v", float(cur), 0.005, 0.0, hi, "%.3f")
                        if ch:
                            row[fname] = float(nv)
                            ui.edits.set(f"specular.per_region.{reg}", row)
                    imgui.pop_id()
            imgui.end_table()

    def _gaussians(self, ui: UiContext) -> None:
        st = self.state
        gs = st.settings.deon.gaussians
        imgui.text("diffusion profile: R(r) = sum of Gaussians")
        imgui.same_line()
        imgui.text_disabled("(eq. 20-21)")
        tooltip("the diffusion profile as a sum of Gaussians, seed 000 eq. 20-21: R(r) = sum_i w_i G(v_i, r), "
                "G(v, r) = exp(-r²/2v) / (2 pi v); v in mm², r in mm. Wider Gaussians (larger v) carry light "
                "further under the skin; the weights say how much of each colour goes into each")
        flags = imgui.TableFlags_.borders.value | imgui.TableFlags_.row_bg.value
        remove = None
        if imgui.begin_table("gauss", 4, flags):
            imgui.table_setup_column("#", imgui.TableColumnFlags_.width_fixed.value, 18)
            imgui.table_setup_column("width v (mm²)")
            imgui.table_setup_column("weight  R G B")
            imgui.table_setup_column("", imgui.TableColumnFlags_.width_fixed.value, 22)
            imgui.table_headers_row()
            for i, g in enumerate(gs):
                imgui.push_id(f"g{i}")
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text(str(i + 1))
                imgui.table_next_column()
                imgui.set_next_item_width(-1)
                ch, v = imgui.drag_float("##var", float(g.variance), max(g.variance * 0.01, 1e-4), 0.0, 1e4, "%.4g")
                if ch:
                    ui.edits.set(f"deon.gaussians.{i}.variance", float(v))
                tooltip(f"{doc('deon.gaussians.*.variance')[1]}\nsigma = {math.sqrt(max(g.variance, 0.0)):.3f} mm")
                imgui.table_next_column()
                imgui.set_next_item_width(-1)
                ch, w = imgui.drag_float3("##w", [float(x) for x in g.weights], 0.002, 0.0, 10.0, "%.3f")
                if ch:
                    ui.edits.set(f"deon.gaussians.{i}.weights", [float(x) for x in w])
                tooltip(doc("deon.gaussians.*.weights")[1])
                imgui.table_next_column()
                if len(gs) > 1 and imgui.small_button("x"):
                    remove = i
                tooltip("remove this Gaussian")
                imgui.pop_id()
            imgui.end_table()
        if len(gs) < 8 and imgui.small_button("add row"):
            last = gs[-1]
            ui.edits.set(f"deon.gaussians.{len(gs)}", {"variance": round(last.variance * 2.0 + 0.01, 4),
                                                        "weights": [0.0, 0.0, 0.0]})
        imgui.same_line()
        if imgui.small_button("normalise weights"):
            tot = np.array([sum(g.weights[c] for g in gs) for c in range(3)])
            tot[tot <= 0] = 1.0
            ui.edits.set("deon.gaussians", [{"variance": g.variance,
                                             "weights": [float(g.weights[c] / tot[c]) for c in range(3)]} for g in gs])
        tooltip("scale each colour's weights to sum to 1 (energy, eq. 21)")
        imgui.same_line()
        if imgui.small_button("sort"):
            ui.edits.set("deon.gaussians", [g.model_dump(mode="json") for g in sorted(gs, key=lambda g: g.variance)])
        tooltip("order the rows by width (the blurs are incremental, eq. 24)")
        if remove is not None:
            st.apply({"deon.gaussians": [g.model_dump(mode="json") for k, g in enumerate(gs) if k != remove]},
                     "gaussians")

    def _profile_plot(self) -> None:
        gs = self.state.settings.deon.gaussians
        _, self.log_r = imgui.checkbox("log radius axis", self.log_r)
        tooltip("linear: r·R(r) against r, as GPU Gems 3 §14.4.6 plots it (the area is the diffuse response). "
                "log: r²·R(r) against log r -- the same area rule, so each Gaussian is a bump as high as its weight")
        r, y = profile_plot.gaussian_curve(gs, self.log_r)
        series = [(name, r, y[:, c], (*col, 1.0), 2.0) for c, (name, col) in enumerate(profile_plot.CHANNELS)]
        self.plot_rect = profile_plot.draw("radial profile##deon", series, self.log_r)

    # ------------------------------------------------------------------------------------------
    def _render(self, ui: UiContext) -> None:
        st = self.state
        if not ui.header("Render"):
            return
        edit_model(st.settings.render, "render", ui, skip=("width", "height"))
        s = st.settings.render
        sx, sy = ui.layout.scale
        imgui.text_disabled(f"render size {s.width} x {s.height} px (3D view region"
                            f"{f', framebuffer scale {sx:g}' if abs(sx - 1) > 1e-3 else ''})")
        ch, v = imgui.checkbox("vsync", st.view.vsync)
        if ch:
            st.set_vsync(v)
        ch, v = imgui.checkbox("show UI (F1)", st.view.show_ui)
        if ch:
            st.set_show_ui(v)
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.4)
        ch, i = imgui.combo("panel side", PANEL_SIDES.index(st.view.panel_side), list(PANEL_SIDES))
        if ch:
            st.set_panel_side(PANEL_SIDES[i])
        imgui.text_disabled(f"panel {ui.layout.panel[2] if ui.layout.panel else 0:.0f} px wide: drag its edge")
        self._change_line(("render",))

    def _presets(self, ui: UiContext) -> None:
        st = self.state
        p = st.presets
        if not ui.header("Presets"):
            return
        # Enter in the path field loads it (same as the button below)
        entered, text = imgui.input_text("path", p.edit_path, _ENTER)
        if text != p.edit_path:
            st.set_preset_path_text(text)
        tooltip("a preset .json; Enter or 'load' loads it (asking first if there are unsaved changes), "
                "'save as' writes the current state there")
        if (imgui.button("load") or entered) and p.edit_path.strip():
            st.request_preset(p.edit_path.strip())
        imgui.same_line()
        if imgui.button("save (Ctrl+S)"):
            st.save_preset()
        tooltip("write the current preset file; a shipped preset is read-only: a copy goes to your folder")
        imgui.same_line()
        if imgui.button("save as") and p.edit_path.strip():
            st.save_preset(p.edit_path.strip())
        for title, files in p.listing():
            imgui.text_disabled(title + ":")
            if not files:
                imgui.text_disabled("  (none)")
            for f in files:
                if imgui.selectable(f"  {f.name}##{f}", str(f) == p.path)[0]:
                    st.set_preset_path_text(str(f))
                    st.request_preset(str(f))
                tooltip(str(f))
        if p.message:
            wrapped(p.message, ERR if p.errors else OK)
        if p.errors:
            imgui.text_colored(ERR, f"{p.error_source}: state kept")
            error_list(p.errors, 12)

    def _confirm_load_popup(self) -> None:
        """"Discard unsaved changes?" before a preset is loaded over them."""
        st = self.state
        pending = st.presets.pending_load
        if pending is None:
            return
        if not imgui.is_popup_open(CONFIRM_POPUP):
            imgui.open_popup(CONFIRM_POPUP)
        imgui.set_next_window_size(imgui.ImVec2(min(420.0, imgui.get_io().display_size.x * 0.9), 0.0))
        if imgui.begin_popup_modal(CONFIRM_POPUP, None, imgui.WindowFlags_.no_saved_settings.value)[0]:
            wrapped(f"The current settings have unsaved changes. Load {Path(pending).name} and discard them?")
            if imgui.button("save, then load"):
                st.answer_pending("save")
                imgui.close_current_popup()
            imgui.same_line()
            if imgui.button("discard and load"):
                st.answer_pending("discard")
                imgui.close_current_popup()
            imgui.same_line()
            if imgui.button("cancel") or imgui.is_key_pressed(imgui.Key.escape):
                st.answer_pending("cancel")
                imgui.close_current_popup()
            imgui.end_popup()

    def _screenshot(self, ui: UiContext) -> None:
        st, fr = self.state, self.frame
        o = st.shots
        if not ui.header("Screenshot"):
            return
        ch, folder = imgui.input_text("folder", o.folder)
        if ch:
            st.set_screenshot_options(folder=folder)
        ch, v = imgui.checkbox("include UI", o.include_ui)
        if ch:
            st.set_screenshot_options(include_ui=v)
        imgui.same_line()
        ch, v = imgui.checkbox("also linear .npy", o.save_linear_npy)
        if ch:
            st.set_screenshot_options(save_linear_npy=v)
        tooltip("also save the linear (before tone mapping) image as float32 .npy, for scripts")
        if imgui.button("screenshot (F12)"):
            fr.request_screenshot()
        if fr.screenshots_written:
            wrapped(str(fr.screenshots_written[-1]))

    def _compare(self, ui: UiContext) -> None:
        st = self.state
        cmp = st.compare
        if not ui.header("A/B compare"):
            return
        for slot in cmp.slots:
            imgui.push_id(slot.label)
            if imgui.button(f"capture -> {slot.label}"):
                st.capture_slot(slot.label)
            imgui.same_line()
            if imgui.button(f"preset -> {slot.label}"):
                st.load_slot(slot.label, st.presets.edit_path.strip())
            tooltip("load the preset named in Presets > path into this slot")
            imgui.same_line()
            imgui.text_disabled(slot.source or "(empty)")
            if slot.error:
                wrapped(slot.error, ERR)
            imgui.pop_id()
        ch, i = imgui.combo("view", COMPARE_MODES.index(cmp.mode), list(COMPARE_MODES))
        if ch:
            cmp.set_mode(COMPARE_MODES[i])
        if cmp.mode != "off" and not cmp.ready():
            imgui.text_colored(WARN, "capture both A and B first")
        if cmp.mode == "split":
            ch, v = imgui.slider_float("divider", cmp.divider, 0.0, 1.0)
            if ch:
                cmp.set_divider(v)
            tooltip("or drag it in the view")
        if cmp.mode == "toggle":
            ch, v = imgui.checkbox("show B", cmp.show_b)
            if ch:
                cmp.set_show_b(v)
        if cmp.mode == "difference":
            ch, v = imgui.slider_float("gain", cmp.diff_gain, 1.0, 100.0, "%.1f", imgui.SliderFlags_.logarithmic.value)
            if ch:
                cmp.set_gain(v)
        ch, v = imgui.checkbox("both use the live camera", cmp.follow_camera)
        if ch:
            cmp.set_follow_camera(v)
        wrapped("each slot has its own renderer & caches (~2x frame cost)")

    def _help(self, ui: UiContext) -> None:
        if not ui.header("Help: shortcuts"):
            return
        flags = imgui.TableFlags_.row_bg.value | imgui.TableFlags_.sizing_fixed_fit.value
        if imgui.begin_table("keys", 2, flags):
            for k, what in shortcuts(self.state.technique_names()):
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text_colored(WARN, k)
                imgui.table_next_column()
                imgui.push_text_wrap_pos(0)
                imgui.text(what)
                imgui.pop_text_wrap_pos()
            imgui.end_table()
        wrapped("Keys other than F1 / F12 / Ctrl+S are ignored while a text field has the keyboard. "
                "Hover a setting for its meaning, unit, range and seed equation.")

    def _shaders(self, ui: UiContext) -> None:
        fr = self.frame
        if not ui.header("Shaders"):
            return
        w = fr.watcher
        wrapped(f"watching {fr.shaders.root} every {w.interval:.1f}s")
        if w.last_reloaded:
            wrapped("last reload: " + ", ".join(w.last_reloaded))
        if imgui.button("reload all now"):
            w.poll(force=True)
        if w.errors:
            self._shader_errors()
        else:
            imgui.text_colored(OK, "all programs compile")
