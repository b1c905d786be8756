"""The main settings panel: a column docked to the left (or right) edge of the window, resizable by
dragging its inner edge; the 3D view takes the rest (``ui/layout.py``). It is a list of sections
(``ui/sections/``, plus the profile lab), each drawing itself under its collapsing header, built
mostly from the settings model (``widgets.edit_model``, labels, units and tooltips from
``fielddocs``); the Gaussian, per-region and light tables are hand-built. Each section shows what
the last change made in it cost (which passes re-ran, in ms), and the Quality & cost section splits the
frame cost into texture-space and view-dependent work. Adding a section is one line in ``SECTIONS``."""
from __future__ import annotations

from imgui_bundle import imgui

from skinviewer.ui.fielddocs import LABEL_MAX_PX
from skinviewer.ui.frame import FrameController
from skinviewer.ui.profile_lab import ProfileLab
from skinviewer.ui.sections.look import LookSection
from skinviewer.ui.sections.scene import CameraSection, LightsSection, SceneSection
from skinviewer.ui.sections.screen_space import ScreenSpaceSection
from skinviewer.ui.sections.shading import (
    DeonSection,
    GosselinSection,
    OtherSettingsSection,
    PhongSection,
    SpecularSection,
)
from skinviewer.ui.sections.status import StatusSection, TechniqueSection
from skinviewer.ui.sections.tools import (
    CompareSection,
    HelpSection,
    PresetsSection,
    RenderSection,
    ScreenshotSection,
    ShadersSection,
)
from skinviewer.ui.state import ViewerState
from skinviewer.ui.widgets import UiContext, begin_docked, tooltip

LABEL_COLUMN_PX = LABEL_MAX_PX + 8.0  # room for labels with units (fielddocs keeps them this short)

# the panel's sections, top to bottom: each made with (state, frame), drawn with draw(ui). Look first
# (technique, skin, specular, translucency, lights), then Quality & cost; then the scene, camera, presets,
# A/B and screenshots; the engine internals (every technique's full settings, the raw Gaussian table,
# render, shaders, the profile lab) under ADVANCED, collapsed
SECTIONS = (
    StatusSection, LookSection, LightsSection, TechniqueSection, SceneSection, CameraSection,
    PresetsSection, CompareSection, ScreenshotSection,
)
ADVANCED = (
    PhongSection, GosselinSection, DeonSection, SpecularSection, OtherSettingsSection, ScreenSpaceSection,
    RenderSection, ShadersSection, ProfileLab,
)
TAIL = (HelpSection,)
ADVANCED_TITLE = "Advanced (engine internals)"


class Panel:
    """The docked settings column: its sections, its width (the user drags its edge) and scrolling."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame
        self.sections = [cls(state, frame) for cls in SECTIONS + ADVANCED + TAIL]
        self.advanced_open = False  # the Advanced group was drawn open last frame (tests)
        self.scroll_y = 0.0  # the column's scroll position last frame (tests)
        self._scroll_to: float | None = None

    def section(self, cls):
        return next(s for s in self.sections if isinstance(s, cls))

    @property
    def lab(self) -> ProfileLab:
        return self.section(ProfileLab)

    def scroll_to(self, y: float) -> None:
        """Scroll the column to ``y`` (pixels from its top) next frame."""
        self._scroll_to = float(y)

    def draw(self, ui: UiContext) -> None:
        rect = ui.layout.panel
        if rect is None:
            return
        x, y, pw, ph = rect
        flags = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_collapse
                 | imgui.WindowFlags_.no_bring_to_front_on_focus | imgui.WindowFlags_.no_saved_settings)
        opened = begin_docked("skinviewer###panel", rect, flags, imgui.ImVec4(0.09, 0.09, 0.1, 1.0))
        size = imgui.get_window_size()
        if abs(size.x - pw) > 0.5:  # the user dragged the inner edge: remember the width
            self.state.set_panel_width(float(size.x))
        if self._scroll_to is not None:
            imgui.set_scroll_y(self._scroll_to)
            self._scroll_to = None
        self.scroll_y = float(imgui.get_scroll_y())
        if opened:
            imgui.push_item_width(-min(LABEL_COLUMN_PX, pw * 0.42))  # room for labels with units
            n, m = len(SECTIONS), len(SECTIONS) + len(ADVANCED)
            for s in self.sections[:n]:
                s.draw(ui)
            self.advanced_open = ui.header(ADVANCED_TITLE)
            tooltip_text = ("every technique's full settings (the raw Gaussian table, blur and cache switches), "
                            "render, shaders, the profile lab")
            tooltip(tooltip_text)
            if self.advanced_open:
                imgui.indent(8.0)
                for s in self.sections[n:m]:
                    s.draw(ui)
                imgui.unindent(8.0)
            for s in self.sections[m:]:
                s.draw(ui)
            imgui.pop_item_width()
        ui.claim((x, y, pw, ph))
        imgui.end()
