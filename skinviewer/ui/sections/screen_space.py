"""The screen-space technique sections: Jimenez 2009 (ssss), Jimenez 2015 separable, and the shared
screen-space settings (texturing mode, SSS mask regions, Jimenez 2010 transmittance)."""
from __future__ import annotations

from imgui_bundle import imgui

from skinviewer.core.settings import REGIONS
from skinviewer.ui.frame import FrameController
from skinviewer.ui.sections.common import change_line
from skinviewer.ui.state import ViewerState
from skinviewer.ui.widgets import UiContext, edit_model, wrapped

SCREEN_SPACE = ("ssss", "separable")


def _active(state: ViewerState, name: str) -> str:
    return "  (active)" if state.settings.technique == name else ""


class SsssSection:
    """Jimenez 2009: alpha, beta, taps, Gaussian count (the profile is deon.gaussians)."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        s = self.state.settings
        if ui.header(f"Jimenez 2009{_active(self.state, 'ssss')}###ssss", s.technique == "ssss"):
            wrapped("seed 001 §3.2, eq. 3.2: one screen-space blur per Gaussian of the d'Eon profile "
                    "(its table), width alpha / (depth + beta |depth gradient|)")
            edit_model(s.ssss, "ssss", ui)
            change_line(self.frame, ("ssss",))


class SeparableSection:
    """Jimenez 2015: taps, strength/falloff, width, follow surface, inner-tap rotation."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        s = self.state.settings
        if ui.header(f"Jimenez 2015 separable{_active(self.state, 'separable')}###separable",
                     s.technique == "separable"):
            wrapped("seed 001 §3.3: one pre-integrated separable kernel (strength / falloff), follow surface, "
                    "inner taps rotated per pixel")
            edit_model(s.separable, "separable", ui)
            change_line(self.frame, ("separable",))


class ScreenSpaceSection:
    """Texturing mode, the regions the SSS mask leaves out, the Jimenez 2010 transmittance."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        s = self.state.settings
        if ui.header("Screen space: texturing, mask, transmittance###screen", s.technique in SCREEN_SPACE):
            wrapped("seed 001 §3.5-3.6: texturing mode, non-skin regions, Jimenez 2010 transmittance")
            edit_model(s.screen, "screen", ui)
            imgui.text("not skin (no blur, nothing bleeds in):")
            for k, reg in enumerate(REGIONS):
                if k % 3:
                    imgui.same_line()
                ch, on = imgui.checkbox(f"{reg}##nonskin", reg in s.screen.non_skin_regions)
                if ch:
                    ui.edits.set("screen.non_skin_regions",
                                 [r for r in REGIONS if (r == reg and on) or (r != reg and r in s.screen.non_skin_regions)])
            edit_model(s.transmittance, "transmittance", ui)
            change_line(self.frame, ("screen", "transmittance"))
