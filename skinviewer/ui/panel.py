"""The main settings panel (left side): collapsing sections built mostly from the settings model
(``widgets.edit_model``); the Gaussian, per-region and light tables are hand-built."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from imgui_bundle import imgui, implot

from .. import techniques
from ..scenes import SCENES
from ..settings import REGIONS, profile_warnings
from .camera_control import angles_to_direction, direction_to_angles
from .widgets import Edits, edit_model

ERR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)
WARN = imgui.ImVec4(1.0, 0.8, 0.35, 1.0)
OK = imgui.ImVec4(0.55, 0.9, 0.55, 1.0)
DIM = imgui.ImVec4(0.65, 0.65, 0.7, 1.0)
_ENTER = imgui.InputTextFlags_.enter_returns_true.value
PANEL_W = 380.0


def gaussian_profile(gaussians, r: np.ndarray) -> np.ndarray:
    """R(r) = sum_i w_i exp(-r^2 / 2 v_i) / (2 pi v_i) per RGB channel: shape (len(r), 3)."""
    out = np.zeros((len(r), 3))
    for g in gaussians:
        v = max(g.variance, 1e-6)
        out += np.outer(np.exp(-r * r / (2.0 * v)) / (2.0 * math.pi * v), g.weights)
    return out


EXPAND_ALL = {"on": False}  # tests: open every section so every widget is drawn


def _header(label: str, open_default: bool = False) -> bool:
    flags = imgui.TreeNodeFlags_.default_open.value if open_default else 0
    if EXPAND_ALL["on"]:
        imgui.set_next_item_open(True)
    return imgui.collapsing_header(label, flags)


class Panel:
    def __init__(self, app):
        self.app = app
        self.mesh_path = ""
        self.save_as_path = ""
        self.lab = None
        try:
            from .profile_lab import ProfileLab, available
            if available():
                self.lab = ProfileLab(app)
        except Exception:
            self.lab = None

    # ------------------------------------------------------------------------------------------
    def draw(self) -> None:
        app = self.app
        io = imgui.get_io()
        w, h = io.display_size.x, io.display_size.y
        pw = min(PANEL_W, max(200.0, w * 0.45))
        imgui.set_next_window_pos(imgui.ImVec2(0, 0), imgui.Cond_.first_use_ever.value)
        imgui.set_next_window_size(imgui.ImVec2(pw, h), imgui.Cond_.first_use_ever.value)
        dirty = app.presets.dirty(app.settings)
        title = f"skinviewer{'  *' if dirty else ''}###panel"
        if imgui.begin(title)[0]:
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
            if self.lab is not None:
                self.lab.draw()
            if edits:
                app.apply(edits.values)
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        app.ui_rects.append((pos.x, pos.y, size.x, size.y))
        imgui.end()

    # ------------------------------------------------------------------------------------------
    def _status(self) -> None:
        app = self.app
        s = app.settings
        scene = app.renderer.scene
        imgui.push_text_wrap_pos(0)
        imgui.text_colored(DIM, f"{s.technique}  |  {scene.description if scene else '-'}")
        imgui.pop_text_wrap_pos()
        p = app.presets
        marker = " (unsaved changes)" if p.dirty(s) else ""
        imgui.text_colored(WARN if marker else DIM, f"preset: {p.path or '(none)'}{marker}")
        if app.errors:
            imgui.text_colored(ERR, f"refused: {app.error_title}")
            for path, msg in app.errors[:8]:
                imgui.bullet()
                imgui.push_text_wrap_pos(0)
                imgui.text_colored(ERR, f"{path}: {msg}")
                imgui.pop_text_wrap_pos()
            if imgui.small_button("dismiss##err"):
                app.errors = []
        if app.render_error:
            imgui.push_text_wrap_pos(0)
            imgui.text_colored(ERR, f"render: {app.render_error}")
            imgui.pop_text_wrap_pos()
        errs = app.watcher.errors
        if errs:
            n = sum(len(v) for v in errs.values())
            imgui.text_colored(ERR, f"shader errors ({n}) - last good programs still running:")
            self._shader_errors(limit=4)
        for note in app.notices[-4:]:
            imgui.push_text_wrap_pos(0)
            imgui.text_colored(DIM, note)
            imgui.pop_text_wrap_pos()
        imgui.separator()

    def _shader_errors(self, limit: int = 100) -> None:
        k = 0
        for name, errs in self.app.watcher.errors.items():
            for e in errs:
                if k >= limit:
                    return
                imgui.push_text_wrap_pos(0)
                imgui.text_colored(ERR, f"{e.file}:{e.line}: {e.message}  [{name}]")
                imgui.pop_text_wrap_pos()
                k += 1

    def _technique(self, edits: Edits) -> None:
        app = self.app
        names = techniques.names()
        cur = names.index(app.settings.technique) if app.settings.technique in names else 0
        ch, i = imgui.combo("technique", cur, names)
        if ch:
            app.set_technique(names[i])
        imgui.same_line()
        imgui.text_disabled("(?)")
        if imgui.is_item_hovered():
            imgui.set_item_tooltip("each technique keeps its own cached graph: switching back is instant")

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
        if self.mesh_path is None or (not self.mesh_path and sc.mesh and not imgui.is_any_item_active()):
            self.mesh_path = sc.mesh or ""
        ch, self.mesh_path = imgui.input_text("mesh path", self.mesh_path)
        if imgui.button("load mesh"):
            app.load_mesh(self.mesh_path.strip())
        imgui.same_line()
        if imgui.button("use built-in"):
            self.mesh_path = ""
            app.apply({"scene.mesh": None}, "scene")
        edit_model(sc, "scene", edits, skip=("name", "mesh"))

    def _camera(self, edits: Edits) -> None:
        app = self.app
        if not _header("Camera"):
            return
        imgui.text_disabled("LMB orbit, MMB / shift+LMB pan, wheel zoom, R reset, RMB key light")
        edit_model(app.settings.camera, "camera", edits)
        if imgui.button("reset (R)"):
            app.reset_camera()

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
        if _header("Phong"):
            edit_model(s.phong, "phong", edits)
        if _header("Gosselin"):
            edit_model(s.gosselin, "gosselin", edits, skip=("regions",))
            self._region_kernels(edits)
        if _header("d'Eon", s.technique == "deon"):
            self._gaussians(edits)
            edit_model(s.deon, "deon", edits)
            for w in profile_warnings(s.deon):
                imgui.push_text_wrap_pos(0)
                imgui.text_colored(WARN, "! " + w)
                imgui.pop_text_wrap_pos()
            self._profile_plot()
        if _header("Specular"):
            edit_model(s.specular, "specular", edits, skip=("per_region",))
            self._region_specular(edits)

    def _region_kernels(self, edits: Edits) -> None:
        regions = self.app.settings.gosselin.regions
        imgui.text("per-region kernels")
        flags = imgui.TableFlags_.borders.value | imgui.TableFlags_.row_bg.value | imgui.TableFlags_.sizing_stretch_same.value
        if imgui.begin_table("kernels", 4, flags):
            for col in ("region", "kernel size", "scale x", "scale y"):
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
            for col in ("region", "m", "rho_s"):
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
        imgui.text("Gaussian sum: variance (mm^2) and RGB weights")
        flags = imgui.TableFlags_.borders.value | imgui.TableFlags_.row_bg.value
        remove = None
        if imgui.begin_table("gauss", 4, flags):
            imgui.table_setup_column("#", imgui.TableColumnFlags_.width_fixed.value, 18)
            imgui.table_setup_column("variance")
            imgui.table_setup_column("weights R G B")
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
                imgui.table_next_column()
                imgui.set_next_item_width(-1)
                ch, w = imgui.drag_float3("##w", [float(x) for x in g.weights], 0.002, 0.0, 10.0, "%.3f")
                if ch:
                    edits.set(f"deon.gaussians.{i}.weights", [float(x) for x in w])
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
        imgui.text_disabled(f"render size {s.width} x {s.height} (window framebuffer)")
        ch, v = imgui.checkbox("vsync", app.vsync_on)
        if ch:
            app.set_vsync(v)
        ch, v = imgui.checkbox("show UI (F1)", app.show_ui)
        if ch:
            app.show_ui = v

    def _presets(self) -> None:
        app = self.app
        p = app.presets
        if not _header("Presets"):
            return
        ch, p.edit_path = imgui.input_text("path", p.edit_path)
        if imgui.button("load"):
            app.load_preset(p.edit_path.strip())
        imgui.same_line()
        if imgui.button("save"):
            p.save(app.settings)
        imgui.same_line()
        if imgui.button("save as"):
            if p.edit_path.strip():
                p.save(app.settings, p.edit_path.strip())
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
            for path, msg in p.errors[:12]:
                imgui.bullet()
                imgui.push_text_wrap_pos(0)
                imgui.text_colored(ERR, f"{path}: {msg}")
                imgui.pop_text_wrap_pos()

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
                from ..settings import SettingsError, load_preset
                try:
                    slot.settings = load_preset(path)
                    slot.source = Path(path).name
                    slot.error = ""
                except SettingsError as exc:
                    slot.error = "; ".join(f"{a}: {b}" for a, b in exc.errors)
            imgui.same_line()
            imgui.text_disabled(slot.source or "(empty)")
            if slot.error:
                imgui.push_text_wrap_pos(0)
                imgui.text_colored(ERR, slot.error)
                imgui.pop_text_wrap_pos()
            imgui.pop_id()
        from .compare import MODES
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
