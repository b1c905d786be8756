"""Render options, presets (with the "discard unsaved changes?" question), screenshot, A/B compare,
shaders (hot reload) and the shortcut help."""
from __future__ import annotations

from pathlib import Path

from imgui_bundle import imgui

from skinviewer.ui.compare import MODES as COMPARE_MODES
from skinviewer.ui.exchange import ExchangeTools
from skinviewer.ui.frame import FrameController
from skinviewer.ui.sections.common import change_line, shader_errors
from skinviewer.ui.state import PANEL_SIDES, ViewerState
from skinviewer.ui.widgets import (
    ERR,
    OK,
    WARN,
    UiContext,
    edit_model,
    error_list,
    tooltip,
    wrapped,
)

_ENTER = imgui.InputTextFlags_.enter_returns_true.value
CONFIRM_POPUP = "Unsaved changes###confirm_load"
SAVE_AS_POPUP = "Save preset as###save_as"


def shortcuts(technique_names: list[str]) -> tuple[tuple[str, str], ...]:
    """The keyboard and mouse help; technique keys 1..N from the registry."""
    n = min(len(technique_names), 9)
    keys = " / ".join(str(i + 1) for i in range(n))
    return (
        ("LMB drag (view)", "orbit"), ("MMB / Shift+LMB drag", "pan"), ("wheel", "zoom"),
        ("RMB drag (view)", "move the key light"), ("R", "reset view"),
        (keys, " / ".join(technique_names[:n])),
        ("F1", "hide / show the UI"), ("F12", "screenshot"),
        ("Ctrl+S", "save the named preset (none yet: asks for a name; a shipped one: a copy in your folder)"),
        ("Ctrl+Shift+S", "save as: asks for a name"),
        ("Space", "A/B: toggle A and B (compare on)"), ("Esc", "leave the pass inspector"),
    )


class RenderSection:
    """Render settings, vsync, UI visibility and the panel side."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
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
        change_line(self.frame, ("render",))


class PresetsSection:
    """Load / save / save as, the shipped and user preset folders, the confirmation before loading over unsaved changes;
    Export... / Import... for the engines and a background Turntable (ui/exchange.py)."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame
        self.exchange = ExchangeTools()

    def draw(self, ui: UiContext) -> None:
        st = self.state
        p = st.presets
        self._confirm_load_popup()
        self._save_as_popup()
        if not ui.header("Presets"):
            return
        # Enter in the path field loads it (same as the button below)
        entered, text = imgui.input_text("path", p.edit_path, _ENTER)
        if text != p.edit_path:
            st.set_preset_path_text(text)
        # the whole path first: a 960x600 panel shows only its start in the field (issue 34)
        tooltip((f"{p.edit_path}\n" if p.edit_path else "")
                + "a preset .json; Enter or 'load' loads it (asking first if there are unsaved changes), "
                "'save as' writes the current state there")
        if (imgui.button("load") or entered) and p.edit_path.strip():
            st.request_preset(p.edit_path.strip())
        imgui.same_line()
        if imgui.button("save (Ctrl+S)"):
            st.save_preset()
        tooltip("write the current preset file; a shipped preset is read-only: a copy goes to your folder")
        imgui.same_line()
        if imgui.button("save as... (Ctrl+Shift+S)"):
            st.request_save_as()
        tooltip("asks for a name: the preset goes to your folder as NAME.json (or type a path)")
        ch, on = imgui.checkbox("camera is part of the preset", p.track_camera)
        if ch:
            p.set_track_camera(on)
        tooltip("off (default): orbiting and zooming are not unsaved changes and presets are saved without the "
                "camera (loading one keeps your view); on: the camera is saved and its moves count as changes")
        for title, files in p.listing():
            imgui.text_disabled(title + ":")
            if not files:
                imgui.text_disabled("  (none)")
            for f in files:
                if imgui.selectable(f"  {f.name}##{f}", str(f) == p.path)[0]:
                    st.set_preset_path_text(str(f))
                    st.request_preset(str(f))
                tooltip(str(f))
        self.exchange.draw(st, ui)
        if p.message:
            wrapped(p.message, ERR if p.errors else OK)
        if p.errors:
            imgui.text_colored(ERR, f"{p.error_source}: state kept")
            error_list(p.errors, 12)

    def _save_as_popup(self) -> None:
        """*Save as*: a name field (Enter saves), the folder it goes to, save / cancel."""
        st = self.state
        p = st.presets
        if not p.naming:
            return
        if not imgui.is_popup_open(SAVE_AS_POPUP):
            imgui.open_popup(SAVE_AS_POPUP)
            self._focus_name = True
        imgui.set_next_window_size(imgui.ImVec2(min(440.0, imgui.get_io().display_size.x * 0.9), 0.0))
        if imgui.begin_popup_modal(SAVE_AS_POPUP, None, imgui.WindowFlags_.no_saved_settings.value)[0]:
            from skinviewer.ui.presets import name_to_path
            if getattr(self, "_focus_name", False):
                imgui.set_keyboard_focus_here()
                self._focus_name = False
            imgui.set_next_item_width(-60)
            entered, text = imgui.input_text("name", p.name_text, _ENTER)
            if text != p.name_text:
                p.set_name_text(text)
            target = name_to_path(p.name_text)
            if target is not None:
                wrapped(f"-> {target}" + ("  (exists: it will be replaced)" if target.exists() else ""),
                        WARN if target.exists() else None)
            if (imgui.button("save") or entered) and target is not None and st.save_preset_named(p.name_text):
                imgui.close_current_popup()
            imgui.same_line()
            if imgui.button("cancel") or imgui.is_key_pressed(imgui.Key.escape):
                p.close_naming()
                st.say("save as cancelled")
                imgui.close_current_popup()
            if p.errors:
                error_list(p.errors, 3)
            imgui.end_popup()

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


class ScreenshotSection:
    """Screenshot folder and options."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
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
        ch, v = imgui.checkbox("also linear OpenEXR", o.save_linear_exr)
        if ch:
            st.set_screenshot_options(save_linear_exr=v)
        tooltip("also save the linear (before exposure and tone mapping) image as OpenEXR (float32 RGBA), "
                "for compositing and comparison tools")
        if imgui.button("screenshot (F12)"):
            fr.request_screenshot()
        if fr.screenshots_written:
            wrapped(str(fr.screenshots_written[-1]))


class CompareSection:
    """A/B compare: capture or load the slots, the view mode."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
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


class ShadersSection:
    """Shader hot reload: what is watched, the last reload, errors."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
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
            shader_errors(self.frame.watcher)
        else:
            imgui.text_colored(OK, "all programs compile")


class HelpSection:
    """Keyboard and mouse shortcuts."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        if not ui.header("Help: shortcuts"):
            return
        if imgui.begin_table("keys", 2, imgui.TableFlags_.row_bg.value):
            imgui.table_setup_column("key", imgui.TableColumnFlags_.width_fixed.value,
                                     imgui.calc_text_size("MMB / Shift+LMB drag").x)
            imgui.table_setup_column("what", imgui.TableColumnFlags_.width_stretch.value)
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
