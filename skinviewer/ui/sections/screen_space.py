"""The shared screen-space settings: texturing mode, the regions the SSS mask leaves out (a check box
each), the Jimenez 2010 transmittance. The ``ssss`` and ``separable`` groups are drawn from the model
by the generic section (titled from the technique registry)."""
from __future__ import annotations

from imgui_bundle import imgui

from skinviewer.ground.settings import REGIONS
from skinviewer.ui.frame import FrameController
from skinviewer.ui.sections.common import change_line
from skinviewer.ui.state import ViewerState
from skinviewer.ui.widgets import UiContext, edit_model, wrapped

SCREEN_SPACE = ("ssss", "separable")


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
