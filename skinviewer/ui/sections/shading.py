"""The technique sections: Phong, Gosselin 2004 (per-region kernels), d'Eon 2007 (the Gaussian table and
the radial profile plot), the Kelemen / Szirmay-Kalos specular (per-region overrides), and a generic
section for every other settings group (a new technique's settings show up with no UI code)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from imgui_bundle import imgui

from skinviewer import techniques
from skinviewer.ground.settings import REGIONS, Settings, profile_warnings
from skinviewer.ui import profile_plot
from skinviewer.ui.fielddocs import doc
from skinviewer.ui.frame import FrameController
from skinviewer.ui.sections.common import change_line
from skinviewer.ui.state import ViewerState
from skinviewer.ui.widgets import (
    WARN,
    UiContext,
    classify,
    edit_model,
    tooltip,
    wrapped,
)


def _active(state: ViewerState, name: str) -> str:
    return "  (active)" if state.settings.technique == name else ""


def _header(ui: UiContext, name: str, active: str) -> bool:
    """A technique's section: titled with its one name (the combo's, the keys', the CLI's), the paper
    in the tooltip; open when it is the active technique."""
    tech = techniques.REGISTRY.get(name)
    opened = ui.header(f"{name}{'  (active)' if name == active else ''}###{name}", name == active)
    tooltip(tech.title if tech is not None else f"settings group '{name}'")
    return opened


class PhongSection:
    """Phong / Lambert baseline settings."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        if _header(ui, "phong", self.state.settings.technique):
            edit_model(self.state.settings.phong, "phong", ui)
            change_line(self.frame, ("phong",))


class GosselinSection:
    """Gosselin 2004 settings and the per-region blur sizes (eq. 12)."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        s = self.state.settings
        if _header(ui, "gosselin", s.technique):
            wrapped("seed 000 §4.1, eq. 8-19: texture-space light map + Poisson blurs")
            edit_model(s.gosselin, "gosselin", ui, skip=("regions",))
            self._region_kernels(ui)
            change_line(self.frame, ("gosselin",))

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


class DeonSection:
    """d'Eon 2007: the Gaussian table, the radial profile plot and the other settings."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame
        self.log_r = True  # the profile plot's radius axis (see ui/profile_plot.py)
        self.profile_hidden: set[str] = set()  # series a click on the profile's legend hid
        self.plot_rect: tuple[float, float, float, float] | None = None  # last drawn profile plot (tests)

    def draw(self, ui: UiContext) -> None:
        s = self.state.settings
        if _header(ui, "deon", s.technique):
            wrapped("seed 000 §4.2, eq. 20-35: sum-of-Gaussians diffusion in texture space")
            self._gaussians(ui)
            self._profile_plot()
            edit_model(s.deon, "deon", ui)
            for w in profile_warnings(s.deon):
                wrapped("! " + w, WARN)
            change_line(self.frame, ("deon",))

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
        self.plot_rect = profile_plot.draw("radial profile##deon", series, self.log_r, hidden=self.profile_hidden)


class SpecularSection:
    """Kelemen / Szirmay-Kalos specular and its per-region overrides."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        if ui.header("Specular (Kelemen / Szirmay-Kalos)###Specular"):
            wrapped("seed 000 eq. 14-16 (gosselin, deon)")
            edit_model(self.state.settings.specular, "specular", ui, skip=("per_region",))
            self._region_specular(ui)
            change_line(self.frame, ("specular",))

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
                    row: dict[str, Any] = ov.model_dump() if ov else {"m": None, "rho_s": None}
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


# settings groups with a section of their own (ui/sections/*.py); the rest get OtherSettingsSection
HAND_BUILT = ("scene", "camera", "render", "lights", "shadow", "phong", "specular", "gosselin", "deon",
              "screen", "transmittance")  # ui/sections/screen_space.py


def generic_groups(settings_cls=Settings) -> list[str]:
    """Settings groups (sub-models) no hand-built section draws, in model order."""
    return [name for name, f in settings_cls.model_fields.items()
            if name not in HAND_BUILT and classify(f)[0] == "model"]


class OtherSettingsSection:
    """Every other settings group, drawn from the model (labels, units and tooltips from fielddocs);
    a technique's group is titled with the technique's title and opens when it is the active one."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame
        self.groups = generic_groups(type(state.settings))

    def draw(self, ui: UiContext) -> None:
        s = self.state.settings
        for name in self.groups:
            if _header(ui, name, s.technique):
                edit_model(getattr(s, name), name, ui)
                change_line(self.frame, (name,))
