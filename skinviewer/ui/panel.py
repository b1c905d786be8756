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
from imgui_bundle import imgui, implot

from skinviewer import techniques
from skinviewer.core.settings import REGIONS, profile_warnings
from skinviewer.scene.scenes import SCENES
from skinviewer.ui.camera_control import angles_to_direction, direction_to_angles
from skinviewer.ui.fielddocs import doc
from skinviewer.ui.profile_lab import ProfileLab
from skinviewer.ui.scheduler import MODES as RENDER_MODES
from skinviewer.ui.scheduler import split_ms
from skinviewer.ui.widgets import (  # noqa: F401  (tests open every section)
    DIM,
    ERR,
    EXPAND_ALL,
    OK,
    WARN,
    Edits,
    begin_docked,
    edit_model,
    error_list,
    wrapped,
)
from skinviewer.ui.widgets import header as _header

_ENTER = imgui.InputTextFlags_.enter_returns_true.value
TEX_COL = imgui.ImVec4(0.35, 0.6, 1.0, 1.0)  # texture-space cost
VIEW_COL = imgui.ImVec4(1.0, 0.62, 0.3, 1.0)  # view-dependent cost
SHORTCUTS = (
    ("LMB drag (view)", "orbit"), ("MMB / Shift+LMB drag", "pan"), ("wheel", "zoom"),
    ("RMB drag (view)", "move the key light"), ("R", "reset view"), ("1 / 2 / 3 / ...", " / ".join(techniques.names())),
    ("F1", "hide / show the UI"), ("F12", "screenshot"), ("Ctrl+S", "save preset (new file if none)"),
    ("Space", "A/B: toggle A and B (compare on)"), ("Esc", "leave the pass inspector"),
)


def gaussian_profile(gaussians, r: np.ndarray) -> np.ndarray:
    """R(r) = sum_i w_i exp(-r^2 / 2 v_i) / (2 pi v_i) per RGB channel: shape (len(r), 3)."""
    out = np.zeros((len(r), 3))
    for g in gaussians:
        v = max(g.variance, 1e-6)
        out += np.outer(np.exp(-r * r / (2.0 * v)) / (2.0 * math.pi * v), g.weights)
    return out


def _short(source: str, n: int = 38) -> str:
    return source if len(source) <= n else source[: n - 3] + "..."




def _same_line_if_fits(text: str, spacing: float = -1.0) -> None:
    """Continue the current line with ``text`` if it fits there, else start a new line."""
    imgui.same_line(0, spacing)
    if imgui.calc_text_size(text).x > imgui.get_content_region_avail().x:
        imgui.new_line()




DRAG_RESOLUTIONS = ("auto", "full", "0.5", "0.25")


class Panel:
    def __init__(self, app):
        self.app = app
        self.mesh_path = ""
        self.save_as_path = ""
        self.lab = ProfileLab(app)

    # ------------------------------------------------------------------------------------------
    def draw(self) -> None:
        app = self.app
        rect = app.layout.panel
        if rect is None:
            return
        x, y, pw, ph = rect
        flags = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_collapse
                 | imgui.WindowFlags_.no_bring_to_front_on_focus | imgui.WindowFlags_.no_saved_settings)
        opened = begin_docked("skinviewer###panel", rect, flags, imgui.ImVec4(0.09, 0.09, 0.1, 1.0))
        size = imgui.get_window_size()
        if abs(size.x - pw) > 0.5:  # the user dragged the inner edge: remember the width
            app.panel_width = float(size.x)
        if opened:
            imgui.push_item_width(-min(165.0, pw * 0.42))  # room for labels with units
            edits = Edits()
            self._status()
            self._technique(edits)
            self._scene(edits)
            self._camera(edits)
            self._lights(edits)
            self._technique_sections(edits)
            self._render(edits)
            self._presets()
            self._screenshot()
            self._compare()
            self._shaders()
            self.lab.draw()
            self._help()
            imgui.pop_item_width()
            if edits:
                app.apply(edits.values)
        app.ui_rects.append((x, y, pw, ph))
        imgui.end()

    # ------------------------------------------------------------------------------------------
    def _status(self) -> None:
        app = self.app
        s = app.settings
        scene = app.renderer.scene
        wrapped(scene.description if scene else "-", DIM)
        p = app.presets
        marker = " (unsaved changes, Ctrl+S)" if p.dirty(s) else ""
        imgui.text_colored(WARN if marker else DIM, f"preset: {Path(p.path).name if p.path else '(none)'}{marker}")
        if p.path and imgui.is_item_hovered():
            imgui.set_item_tooltip(p.path)
        self._change_line(None)
        if app.errors:
            imgui.text_colored(ERR, f"refused: {app.error_title}")
            error_list(app.errors, 8)
            if imgui.small_button("dismiss##err"):
                app.errors = []
        if app.render_error:
            wrapped(f"render: {app.render_error}", ERR)
        errs = app.watcher.errors
        if errs:
            n = sum(len(v) for v in errs.values())
            imgui.text_colored(ERR, f"shader errors ({n}) - last good programs still running:")
            self._shader_errors(limit=4)
        for note in app.notices[-4:]:
            wrapped(note, DIM)
        imgui.separator()

    def _shader_errors(self, limit: int = 100) -> None:
        k = 0
        for name, errs in self.app.watcher.errors.items():
            for e in errs:
                if k >= limit:
                    return
                wrapped(f"{e.file}:{e.line}: {e.message}  [{name}]", ERR)
                k += 1

    # -- cost accounting ----------------------------------------------------------------------
    def _change_line(self, sections: tuple[str, ...] | None) -> None:
        """'last change: N ms (passes ...)' -- everywhere (None) or when the change came from ``sections``."""
        app = self.app
        ch = app.last_change
        if app.render_deferred:
            imgui.text_colored(WARN, "preview paused: release (or hold still) to render")
            if imgui.is_item_hovered():
                imgui.set_item_tooltip(f"the last change cost {ch.total_ms:.0f} ms > the "
                                       f"{app.scheduler.budget_ms:.0f} ms budget (Technique > scheduling)"
                                       if ch else "render scheduling: on release")
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
        if imgui.is_item_hovered():
            rows = "\n".join(f"  {n:<22} {ms:8.1f} ms" for n, ms in ch.passes)
            imgui.set_item_tooltip(f"caused by: {ch.source}\npasses re-run ({ch.timing_mode} timing):\n{rows}")
        imgui.push_text_wrap_pos(0)
        imgui.text_disabled("  passes: " + ", ".join(f"{n} {ms:.0f}" for n, ms in ch.passes[:4])
                            + (f", +{len(ch.passes) - 4} more" if len(ch.passes) > 4 else ""))
        imgui.pop_text_wrap_pos()

    def _cost_split(self) -> None:
        """The technique's frame cost: this frame, and a full frame at the passes' last-run costs,
        split into texture-space (cached while orbiting) and view-dependent work."""
        app = self.app
        rep = app.report
        if rep is None:
            imgui.text_disabled("no frame yet")
            return
        vset = app.view_passes()
        live = [p for p in rep.passes if p.status != "pruned"]
        now_tex, now_view = split_ms(rep, vset, lambda p: p.ms if p.status == "ran" else None)
        full_tex, full_view = split_ms(rep, vset, lambda p: app.last_ms.get(p.name) if p.status != "pruned" else None)
        imgui.text(f"this frame: {now_tex + now_view:.1f} ms")
        imgui.same_line()
        imgui.text_disabled(f"({len(rep.ran)} of {len(live)} passes ran, {rep.timing_mode} timing)")
        if imgui.is_item_hovered():
            from skinviewer.core.graph import TIMING_NOTES
            imgui.set_item_tooltip(TIMING_NOTES.get(rep.timing_mode, ""))
        total = full_tex + full_view
        imgui.text("full frame:")
        imgui.same_line()
        imgui.text_colored(TEX_COL, f"texture-space {full_tex:.0f} ms")
        imgui.same_line()
        imgui.text("+")
        imgui.same_line()
        imgui.text_colored(VIEW_COL, f"view {full_view:.0f} ms")
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("at each live pass's last measured cost.\n"
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

    def _technique(self, edits: Edits) -> None:
        app = self.app
        if not _header("Technique & cost", True):
            return
        names = techniques.names()
        cur = names.index(app.settings.technique) if app.settings.technique in names else 0
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
        ch, i = imgui.combo("technique (1/2/3/...)", cur, names)
        if ch:
            app.set_technique(names[i])
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("keys 1 / 2 / 3: phong / gosselin / deon. Each technique keeps its own cached "
                                   "graph: switching back is instant")
        self._cost_split()
        sch = app.scheduler
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
        ch, i = imgui.combo("while dragging", RENDER_MODES.index(sch.mode), list(RENDER_MODES))
        if ch:
            sch.mode = RENDER_MODES[i]
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("adaptive: render every frame while a slider is dragged unless the last change "
                                   "cost more than the budget; then render when it is released or held still.\n"
                                   "live: always render (the UI may freeze on slow GL).\n"
                                   "on release: render only on release / when held still.")
        if sch.mode == "adaptive":
            imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
            _, sch.budget_ms = imgui.slider_float("budget (ms)", sch.budget_ms, 10.0, 2000.0, "%.0f ms",
                                                  imgui.SliderFlags_.logarithmic.value)
        spread = app.frame_budget_ms is not None
        ch, spread = imgui.checkbox("spread long frames", spread)
        if ch:
            app.frame_budget_ms = 100.0 if spread else None
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("a change whose passes take longer than the budget is rendered over several "
                                   "frames: the UI stays responsive and the image changes once, complete")
        if app.frame_budget_ms is not None:
            imgui.same_line()
            imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
            _, app.frame_budget_ms = imgui.slider_float("frame budget", app.frame_budget_ms, 16.0, 1000.0, "%.0f ms",
                                                        imgui.SliderFlags_.logarithmic.value)
        modes = list(DRAG_RESOLUTIONS)
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
        ch, i = imgui.combo("orbit resolution", modes.index(app.drag_resolution), modes)
        if ch:
            app.drag_resolution = modes[i]
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("resolution of the view while the camera is dragged; full size again on release.\n"
                                   "auto: lower it just enough that the view-dependent passes fit "
                                   f"{app.drag_budget_ms:.0f} ms (texture-space passes stay cached either way)")

    def _scene(self, edits: Edits) -> None:
        app = self.app
        if not _header("Scene"):
            return
        sc = app.settings.scene
        cur = SCENES.index(sc.name) if sc.name in SCENES else 0
        label = "built-in scene" + (" (mesh overrides)" if sc.mesh else "")
        ch, i = imgui.combo(label, cur, list(SCENES))
        if ch:
            app.select_scene(SCENES[i])
        if not self.mesh_path and sc.mesh and not imgui.is_any_item_active():
            self.mesh_path = sc.mesh
        entered, self.mesh_path = imgui.input_text("mesh path", self.mesh_path, _ENTER)
        if imgui.button("load mesh") or (entered and self.mesh_path.strip()):
            app.load_mesh(self.mesh_path.strip())
        imgui.same_line()
        if imgui.button("use built-in"):
            self.mesh_path = ""
            app.apply({"scene.mesh": None}, "scene")
        edit_model(sc, "scene", edits, skip=("name", "mesh"))
        self._change_line(("scene",))

    def _camera(self, edits: Edits) -> None:
        app = self.app
        if not _header("Camera"):
            return
        wrapped("in the view: LMB orbit, MMB / shift+LMB pan, wheel zoom, RMB key light")
        edit_model(app.settings.camera, "camera", edits)
        if imgui.button("reset view (R)"):
            app.reset_camera()
        self._change_line(("camera",))

    def _lights(self, edits: Edits) -> None:
        app = self.app
        if not _header("Lights", True):
            return
        lights = app.settings.lights
        remove = None
        for i, l in enumerate(lights):
            imgui.push_id(f"light{i}")
            name = {0: "key", 1: "rim"}.get(i, f"light {i}")
            open_ = imgui.tree_node_ex(f"{name} ({l.kind}{'' if l.enabled else ', off'})###l{i}",
                                       imgui.TreeNodeFlags_.default_open.value if i == 0 else 0)
            if open_:
                if l.kind == "directional":
                    az, el = direction_to_angles(l.direction)
                    ch1, az = imgui.slider_float("azimuth", az, -180.0, 180.0, "%.1f deg")
                    ch2, el = imgui.slider_float("elevation", el, -89.0, 89.0, "%.1f deg")
                    if ch1 or ch2:
                        edits.set(f"lights.{i}.direction", list(angles_to_direction(az, el)))
                    self._direction_pad(i, az, el, edits)
                edit_model(l, f"lights.{i}", edits)
                if len(lights) > 1 and imgui.small_button("remove light"):
                    remove = i
                imgui.tree_pop()
            imgui.pop_id()
        if len(lights) < 4 and imgui.small_button("add light"):
            edits.set(f"lights.{len(lights)}", {"intensity": 1.0})
        if remove is not None:
            data = [x.model_dump(mode="json") for k, x in enumerate(lights) if k != remove]
            app.apply({"lights": data}, "lights")
        if imgui.tree_node("shadows"):
            edit_model(app.settings.shadow, "shadow", edits)
            imgui.tree_pop()
        self._change_line(("lights", "shadow"))

    def _direction_pad(self, i: int, az: float, el: float, edits: Edits) -> None:
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
            edits.set(f"lights.{i}.direction", list(angles_to_direction(new_az, max(-89.0, min(89.0, new_el)))))
        imgui.same_line()
        imgui.text_disabled("drag to aim\ncentre = above\ninner ring = horizon\nbottom = front, top = behind")

    # ------------------------------------------------------------------------------------------
    def _technique_sections(self, edits: Edits) -> None:
        s = self.app.settings
        tag = {True: "  (active)", False: ""}
        if _header(f"Phong{tag[s.technique == 'phong']}###Phong"):
            edit_model(s.phong, "phong", edits)
            self._change_line(("phong",))
        if _header(f"Gosselin 2004{tag[s.technique == 'gosselin']}###Gosselin", s.technique == "gosselin"):
            wrapped("seed 000 §4.1, eq. 8-19: texture-space light map + Poisson blurs")
            edit_model(s.gosselin, "gosselin", edits, skip=("regions",))
            self._region_kernels(edits)
            self._change_line(("gosselin",))
        if _header(f"d'Eon 2007{tag[s.technique == 'deon']}###deon", s.technique == "deon"):
            wrapped("seed 000 §4.2, eq. 20-35: sum-of-Gaussians diffusion in texture space")
            self._gaussians(edits)
            edit_model(s.deon, "deon", edits)
            for w in profile_warnings(s.deon):
                wrapped("! " + w, WARN)
            self._change_line(("deon",))
            self._profile_plot()
        screen = s.technique in ("ssss", "separable", "burley", "burley2")
        if _header(f"Jimenez 2009{tag[s.technique == 'ssss']}###ssss", s.technique == "ssss"):
            wrapped("seed 001 §3.2, eq. 3.2: one screen-space blur per Gaussian of the d'Eon profile, "
                    "width alpha / (depth + beta |depth gradient|)")
            edit_model(s.ssss, "ssss", edits)
            self._change_line(("ssss",))
        if _header(f"Jimenez 2015 separable{tag[s.technique == 'separable']}###separable",
                   s.technique == "separable"):
            wrapped("seed 001 §3.3: one pre-integrated separable kernel (strength / falloff), follow surface, "
                    "inner taps rotated per pixel")
            edit_model(s.separable, "separable", edits)
            self._change_line(("separable",))
        if _header(f"Burley / Golubev 2018{tag[s.technique == 'burley']}###burley", s.technique in ("burley", "burley2")):
            wrapped("seed 001 §3.4, eq. 2.83-2.89, 3.9-3.13: Burley normalized diffusion sampled on a disk in screen "
                    "space (HDRP); its profile is also burley2's")
            edit_model(s.burley, "burley", edits)
            self._burley_count()
            self._change_line(("burley",))
        if _header(f"Two-level sampling (thesis ch. 4){tag[s.technique == 'burley2']}###burley2",
                   s.technique == "burley2"):
            wrapped("seed 001 ch. 4, Algorithm 1, eq. 4.1-4.2: extra samples where the ring contrast exceeds the "
                    "threshold; burley.view = extra shows where")
            edit_model(s.burley2, "burley2", edits)
            self._change_line(("burley2",))
        if _header("Screen space: texturing, mask, transmittance###screen", screen):
            wrapped("seed 001 §3.5-3.6: texturing mode, non-skin regions, Jimenez 2010 transmittance")
            edit_model(s.screen, "screen", edits)
            imgui.text("not skin (no blur, nothing bleeds in):")
            for k, reg in enumerate(REGIONS):
                if k % 3:
                    imgui.same_line()
                ch, on = imgui.checkbox(f"{reg}##nonskin", reg in s.screen.non_skin_regions)
                if ch:
                    edits.set("screen.non_skin_regions",
                              [r for r in REGIONS if (r == reg and on) or (r != reg and r in s.screen.non_skin_regions)])
            edit_model(s.transmittance, "transmittance", edits)
            self._change_line(("screen", "transmittance"))
        if _header("Specular (Kelemen / Szirmay-Kalos)###Specular"):
            wrapped("seed 000 eq. 14-16 (gosselin, deon)")
            edit_model(s.specular, "specular", edits, skip=("per_region",))
            self._region_specular(edits)
            self._change_line(("specular",))

    def _burley_count(self) -> None:
        """The samples this frame took, counted on the GPU (the burley_count pass's report)."""
        rep = self.app.report
        rec = next((p for p in rep.passes if p.name == "burley_count"), None) if rep is not None else None
        if rec is not None and rec.note:
            wrapped(rec.note)

    def _region_kernels(self, edits: Edits) -> None:
        regions = self.app.settings.gosselin.regions
        imgui.text("per-region kernels")
        imgui.same_line()
        imgui.text_disabled("(eq. 12)")
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("radius = size * (kernel_size * scale_x + scale_y), per region of the region map;\n"
                                   "size = 1/1024: radii are texels at a 1024 light map (rescaled to light_map_size)")
        flags = imgui.TableFlags_.borders.value | imgui.TableFlags_.row_bg.value | imgui.TableFlags_.sizing_stretch_same.value
        if imgui.begin_table("kernels", 4, flags):
            for col in ("region", "kernel size", "scale x", "scale y (texels)"):
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
                    if imgui.is_item_hovered(imgui.HoveredFlags_.for_tooltip.value):
                        imgui.set_tooltip(f"{reg}: " + doc(f"gosselin.regions.{reg}.{fname}")[1])
                    if ch:
                        row = rk.model_dump() if rk else {"kernel_size": 1.0, "scale_x": 1.0, "scale_y": 0.0}
                        row[fname] = float(nv)
                        edits.set(f"gosselin.regions.{reg}", row)
            imgui.end_table()

    def _region_specular(self, edits: Edits) -> None:
        s = self.app.settings.specular
        imgui.text("per-region overrides (unchecked: global value)")
        flags = imgui.TableFlags_.borders.value | imgui.TableFlags_.row_bg.value
        if imgui.begin_table("specreg", 3, flags):
            for col in ("region", "roughness m", "rho_s"):
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
                    row = ov.model_dump() if ov else {"m": None, "rho_s": None}
                    if ch:
                        row[fname] = float(glob) if on else None
                        edits.set(f"specular.per_region.{reg}", row)
                    if cur is not None:
                        imgui.same_line()
                        imgui.set_next_item_width(-1)
                        ch, nv = imgui.drag_float("##v", float(cur), 0.005, 0.0, hi, "%.3f")
                        if ch:
                            row[fname] = float(nv)
                            edits.set(f"specular.per_region.{reg}", row)
                    imgui.pop_id()
            imgui.end_table()

    def _gaussians(self, edits: Edits) -> None:
        d = self.app.settings.deon
        gs = d.gaussians
        imgui.text("R(r) = sum_i w_i G(v_i, r)")
        imgui.same_line()
        imgui.text_disabled("(eq. 20-21)")
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("diffusion profile as a sum of Gaussians, seed 000 eq. 20-21;\n"
                                   "G(v, r) = exp(-r²/2v) / (2 pi v), v in mm², r in mm")
        flags = imgui.TableFlags_.borders.value | imgui.TableFlags_.row_bg.value
        remove = None
        if imgui.begin_table("gauss", 4, flags):
            imgui.table_setup_column("#", imgui.TableColumnFlags_.width_fixed.value, 18)
            imgui.table_setup_column("variance v_i (mm²)")
            imgui.table_setup_column("weights w_i  R G B")
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
                    edits.set(f"deon.gaussians.{i}.variance", float(v))
                if imgui.is_item_hovered(imgui.HoveredFlags_.for_tooltip.value):
                    imgui.set_tooltip(f"{doc('deon.gaussians.*.variance')[1]}\n"
                                      f"sigma = {math.sqrt(max(g.variance, 0.0)):.3f} mm")
                imgui.table_next_column()
                imgui.set_next_item_width(-1)
                ch, w = imgui.drag_float3("##w", [float(x) for x in g.weights], 0.002, 0.0, 10.0, "%.3f")
                if ch:
                    edits.set(f"deon.gaussians.{i}.weights", [float(x) for x in w])
                if imgui.is_item_hovered(imgui.HoveredFlags_.for_tooltip.value):
                    imgui.set_tooltip(doc("deon.gaussians.*.weights")[1])
                imgui.table_next_column()
                if len(gs) > 1 and imgui.small_button("x"):
                    remove = i
                imgui.pop_id()
            imgui.end_table()
        if len(gs) < 8 and imgui.small_button("add row"):
            last = gs[-1]
            edits.set(f"deon.gaussians.{len(gs)}", {"variance": round(last.variance * 2.0 + 0.01, 4),
                                                     "weights": [0.0, 0.0, 0.0]})
        imgui.same_line()
        if imgui.small_button("normalise weights"):
            tot = np.array([sum(g.weights[c] for g in gs) for c in range(3)])
            tot[tot <= 0] = 1.0
            edits.set("deon.gaussians", [{"variance": g.variance, "weights": [float(g.weights[c] / tot[c]) for c in range(3)]}
                                         for g in gs])
        imgui.same_line()
        if imgui.small_button("sort"):
            edits.set("deon.gaussians", [g.model_dump(mode="json") for g in sorted(gs, key=lambda g: g.variance)])
        if remove is not None:
            self.app.apply({"deon.gaussians": [g.model_dump(mode="json") for k, g in enumerate(gs) if k != remove]},
                           "gaussians")

    def _profile_plot(self, extra: dict | None = None) -> None:
        gs = self.app.settings.deon.gaussians
        r = np.linspace(0.0, 8.0, 200)
        R = gaussian_profile(gs, r)
        if implot.begin_plot("r R(r) of the Gaussian profile", imgui.ImVec2(-1, 190)):
            implot.setup_axes("r (mm)", "r R(r) (1/mm)")
            for c, (name, col) in enumerate((("R", (1.0, 0.35, 0.3)), ("G", (0.35, 0.9, 0.4)), ("B", (0.4, 0.6, 1.0)))):
                implot.set_next_line_style(imgui.ImVec4(*col, 1.0), 2.0)
                implot.plot_line(name, r, np.ascontiguousarray(r * R[:, c]))
            for label, (xs, ys) in (extra or {}).items():
                implot.plot_line(label, xs, ys)
            implot.end_plot()

    # ------------------------------------------------------------------------------------------
    def _render(self, edits: Edits) -> None:
        app = self.app
        if not _header("Render"):
            return
        edit_model(app.settings.render, "render", edits, skip=("width", "height"))
        s = app.settings.render
        sx, sy = app.layout.scale
        imgui.text_disabled(f"render size {s.width} x {s.height} px (3D view region"
                            f"{f', framebuffer scale {sx:g}' if abs(sx - 1) > 1e-3 else ''})")
        ch, v = imgui.checkbox("vsync", app.vsync_on)
        if ch:
            app.set_vsync(v)
        ch, v = imgui.checkbox("show UI (F1)", app.show_ui)
        if ch:
            app.show_ui = v
        sides = ("left", "right")
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.4)
        ch, i = imgui.combo("panel side", sides.index(app.panel_side), list(sides))
        if ch:
            app.panel_side = sides[i]
        imgui.text_disabled(f"panel {app.layout.panel[2] if app.layout.panel else 0:.0f} px wide: drag its edge")
        self._change_line(("render",))

    def _presets(self) -> None:
        app = self.app
        p = app.presets
        if not _header("Presets"):
            return
        # Enter in the path field loads it (same as the button below)
        entered, p.edit_path = imgui.input_text("path", p.edit_path, _ENTER)
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("a preset .json; Enter or 'load' loads it, 'save as' writes the current state there")
        if (imgui.button("load") or entered) and p.edit_path.strip():
            app.load_preset(p.edit_path.strip())
        imgui.same_line()
        if imgui.button("save (Ctrl+S)"):
            app.save_preset()
        imgui.same_line()
        if imgui.button("save as"):
            if p.edit_path.strip():
                app.save_preset(p.edit_path.strip())
        files = p.listing()
        if files:
            imgui.text_disabled("presets/:")
            for f in files:
                if imgui.selectable(f.name, str(f) == p.path)[0]:
                    p.edit_path = str(f)
                    app.load_preset(str(f))
        else:
            imgui.text_disabled("presets/ is empty")
        if p.message:
            imgui.text_colored(ERR if p.errors else OK, p.message)
        if p.errors:
            imgui.text_colored(ERR, f"{p.error_source}: state kept")
            error_list(p.errors, 12)

    def _screenshot(self) -> None:
        app = self.app
        o = app.shot_options
        if not _header("Screenshot"):
            return
        _, o.folder = imgui.input_text("folder", o.folder)
        _, o.include_ui = imgui.checkbox("include UI", o.include_ui)
        imgui.same_line()
        _, o.save_linear_npy = imgui.checkbox("also linear .npy", o.save_linear_npy)
        if imgui.button("screenshot (F12)"):
            app.request_screenshot()
        if app.screenshots_written:
            imgui.text_disabled(str(app.screenshots_written[-1]))

    def _compare(self) -> None:
        app = self.app
        cmp = app.compare
        if not _header("A/B compare"):
            return
        for slot in cmp.slots:
            imgui.push_id(slot.label)
            if imgui.button(f"capture -> {slot.label}"):
                slot.settings = app.settings
                slot.source = f"captured ({app.settings.technique})"
            imgui.same_line()
            if imgui.button(f"preset -> {slot.label}"):
                path = app.presets.edit_path.strip()
                from skinviewer.core.settings import SettingsError, load_preset
                try:
                    slot.settings = load_preset(path)
                    slot.source = Path(path).name
                    slot.error = ""
                except SettingsError as exc:
                    slot.error = "; ".join(f"{a}: {b}" for a, b in exc.errors)
            imgui.same_line()
            imgui.text_disabled(slot.source or "(empty)")
            if slot.error:
                wrapped(slot.error, ERR)
            imgui.pop_id()
        from skinviewer.ui.compare import MODES
        ch, i = imgui.combo("view", MODES.index(cmp.mode), list(MODES))
        if ch:
            cmp.mode = MODES[i]
        if cmp.mode != "off" and not cmp.ready():
            imgui.text_colored(WARN, "capture both A and B first")
        if cmp.mode == "split":
            _, cmp.divider = imgui.slider_float("divider (drag it in the view)", cmp.divider, 0.0, 1.0)
        if cmp.mode == "toggle":
            _, cmp.show_b = imgui.checkbox("show B", cmp.show_b)
        if cmp.mode == "difference":
            _, cmp.diff_gain = imgui.slider_float("gain", cmp.diff_gain, 1.0, 100.0, "%.1f", imgui.SliderFlags_.logarithmic.value)
        _, cmp.follow_camera = imgui.checkbox("both use the live camera", cmp.follow_camera)
        imgui.text_disabled("each slot has its own renderer & caches (~2x frame cost)")

    def _help(self) -> None:
        if not _header("Help: shortcuts"):
            return
        flags = imgui.TableFlags_.row_bg.value | imgui.TableFlags_.sizing_fixed_fit.value
        if imgui.begin_table("keys", 2, flags):
            for k, what in SHORTCUTS:
                imgui.table_next_row()
                imgui.table_next_column()
                imgui.text_colored(WARN, k)
                imgui.table_next_column()
                imgui.text(what)
            imgui.end_table()
        wrapped("Keys other than F1 / F12 / Ctrl+S are ignored while a text field has the keyboard. "
                "Hover a setting for its meaning, unit, range and seed equation.")

    def _shaders(self) -> None:
        app = self.app
        if not _header("Shaders"):
            return
        w = app.watcher
        imgui.text_disabled(f"watching {app.shaders.root} every {w.interval:.1f}s")
        if w.last_reloaded:
            imgui.text_disabled("last reload: " + ", ".join(w.last_reloaded))
        if imgui.button("reload all now"):
            w.poll(force=True)
        if w.errors:
            self._shader_errors()
        else:
            imgui.text_colored(OK, "all programs compile")
