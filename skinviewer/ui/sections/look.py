"""The look-first top of the panel: *Look* (the technique, the skin in an artist's terms -- scatter
colour and radius, engine/look.py -- specular, translucency) and *Quality & cost* (the active
technique's map sizes and sample counts). Engine internals stay in the technique sections under
*Advanced*. One name per technique everywhere (the registry's key); the paper is in the tooltip."""
from __future__ import annotations

import numpy as np
from imgui_bundle import imgui

from skinviewer import techniques
from skinviewer.engine.look import BURLEY_TECHNIQUES, shown_look
from skinviewer.physics import artist
from skinviewer.ui import profile_plot
from skinviewer.ui.frame import FrameController
from skinviewer.ui.sections.common import change_line
from skinviewer.ui.state import ViewerState
from skinviewer.ui.widgets import DIM, UiContext, edit_model, tooltip, wrapped

# the look controls a technique has of its own (its paper's terms), besides the artist model
OWN_LOOK: dict[str, tuple[str, tuple[str, ...]]] = {"separable": ("separable", ("strength", "falloff", "width_mm"))}
SPECULAR: dict[str, tuple[str, tuple[str, ...]]] = {"phong": ("phong", ("specular", "shininess"))}  # the rest: Kelemen / Szirmay-Kalos
TRANSLUCENCY: dict[str, tuple[str, tuple[str, ...]]] = {
    "deon": ("deon", ("tsm",)),
    "ssss": ("transmittance", ("enabled", "translucency")),
    "separable": ("transmittance", ("enabled", "translucency")),
    "burley": ("burley", ("transmission",)),
    "burley2": ("burley", ("transmission",)),
}
# Quality & cost: the active technique's resolution and sample knobs (the rest is under Advanced)
QUALITY = {
    "phong": (),
    "gosselin": (("gosselin", ("light_map_size", "iterations")),),
    "deon": (("deon", ("irradiance_size", "irradiance_size_mode", "tsm_size")),),
    "ssss": (("ssss", ("taps", "gaussians")),),
    "separable": (("separable", ("taps",)),),
    "burley": (("burley", ("samples", "budget")),),
    "burley2": (("burley2", ("mode", "base", "extra")),),
    "penner": (("penner", ("lut_size",)),),
}
SHADOW_QUALITY = ("shadow", ("map_size", "map_size_mode", "pcf"))


def technique_title(name: str) -> str:
    t = techniques.REGISTRY.get(name)
    return t.title if t is not None else name


def technique_combo(state: ViewerState, label: str = "technique") -> None:
    """The technique combo (keys 1..9), each name's paper in its tooltip."""
    names = state.technique_names()
    cur = state.settings.technique
    imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
    if imgui.begin_combo(f"{label} (keys 1-{min(len(names), 9)})", cur):
        for k, n in enumerate(names):
            if imgui.selectable(f"{n}##t{k}", n == cur)[0] and n != cur:
                state.set_technique(n)
            tooltip(f"key {k + 1}: {technique_title(n)}" if k < 9 else technique_title(n))
        imgui.end_combo()
    tooltip(f"{cur}: {technique_title(cur)}. Each technique keeps its own cached graph: switching back is instant")


class LookSection:
    """Skin (scatter colour / radius, or the technique's own look controls), specular, translucency."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame
        self.log_r = True
        self.profile_hidden: set[str] = set()  # series a click on the profile's legend hid
        self.legend_rects: dict[str, tuple] = {}  # its items' screen rects (tests)
        self.plot_rect: tuple[float, float, float, float] | None = None  # last drawn profile plot (tests)
        self.legend_extent: list[float] = []  # (rightmost x of the profile legend, the right edge it may use): tests

    def draw(self, ui: UiContext) -> None:
        st = self.state
        s = st.settings
        if not ui.header("Look", True):
            return
        technique_combo(st)
        t = s.technique
        imgui.separator_text("skin")
        if t in OWN_LOOK:
            group, fields = OWN_LOOK[t]
            wrapped(f"{t}: Jimenez's own strength (colour) and falloff (per-channel width)", DIM)
            edit_model(getattr(s, group), group, ui, only=fields)
        elif t == "phong":
            wrapped("phong: no scattering (the baseline)", DIM)
        else:
            self._artist(ui)
        imgui.separator_text("specular")
        group, fields = SPECULAR.get(t, ("specular", ("m", "rho_s", "f0")))
        edit_model(getattr(s, group), group, ui, only=fields)
        if t in TRANSLUCENCY:
            imgui.separator_text("translucency")
            group, fields = TRANSLUCENCY[t]
            edit_model(getattr(s, group), group, ui, only=fields)
        change_line(self.frame, ("look", "deon", "burley", "separable", "specular", "phong", "transmittance"))

    def _artist(self, ui: UiContext) -> None:
        s = self.state.settings
        t = s.technique
        color, radius, where = shown_look(s)
        ch1, c = imgui.color_edit3("scatter colour", [float(x) for x in color], imgui.ColorEditFlags_.float.value)
        tooltip("surface albedo A per channel (Burley, as in Unreal's and HDRP's profiles): the profile's total "
                "diffuse reflectance (seed 001 eq. 2.84) and its shape s(A) (eq. 2.88)")
        ch2, r = imgui.drag_float3("scatter radius mm", [float(x) for x in radius], 0.01, 0.01, 50.0, "%.3f")
        tooltip("mean free path per channel in mm (Unreal: mean free path colour x distance): how far light "
                "travels under the skin; the profile's mean radius is 2.5 radius / s(A). "
                + ("Sets burley.albedo / burley.mfp" if t in BURLEY_TECHNIQUES else
                   "Fitted to the Gaussian table every Gaussian technique uses (deon.gaussians, Advanced)"))
        if ch1 or ch2:
            ui.edits.set("look.scatter_color", [min(max(float(x), 0.0), 1.0) for x in c])
            ui.edits.set("look.scatter_radius", [min(max(float(x), 0.01), 50.0) for x in r])
        if where != "look":
            wrapped(f"shown: {where}; a change makes the look drive", DIM)
        else:
            wrapped("the look drives the profile (a hand edit of the table under Advanced takes over)", DIM)
        if t not in BURLEY_TECHNIQUES:
            edit_model(s.look, "look", ui, only=("gaussians", "energy"))
            if t == "gosselin":
                edit_model(s.gosselin, "gosselin", ui, only=("radius_mode",))
                if s.gosselin.radius_mode != "mm":
                    wrapped("gosselin follows the look in mm radius mode", DIM)
        self._plot(color, radius)

    def _plot(self, color, radius) -> None:
        """The profile in use (the table, or Burley's) beside the look's Burley profile, updated live."""
        s = self.state.settings
        _, self.log_r = imgui.checkbox("log radius##look", self.log_r)
        d = artist.shape_distance(np.clip(color, 0, 1), np.clip(radius, 0.01, 50))
        r = profile_plot.radii(0.01 * float(d.min()), 30.0 * float(d.max()), self.log_r, 300)
        r = r[r > 0]
        norm = np.where(np.asarray(color) > 0, np.asarray(color), 1.0)
        burley = artist.burley_profile(r, color, radius) / norm  # per unit energy, as the techniques use it
        series = []
        if s.technique not in BURLEY_TECHNIQUES:
            v = np.array([g.variance for g in s.deon.gaussians])
            w = np.array([g.weights for g in s.deon.gaussians])
            tot = w.sum(axis=0)
            table = artist.profile_of_table(r, v, w) / np.where(tot > 0, tot, 1.0)
            yt = profile_plot.weighted(r, table, self.log_r)
            series += [(f"{n} table", r, yt[:, c], (*col, 1.0), 2.0) for c, (n, col) in enumerate(profile_plot.CHANNELS)]
        yb = profile_plot.weighted(r, burley, self.log_r)
        series += [(f"{n} look", r, yb[:, c], (*col, 0.45), 1.0) for c, (n, col) in enumerate(profile_plot.CHANNELS)]
        self.plot_rect = profile_plot.draw("scatter profile##look", series, self.log_r, 170.0, self.legend_extent,
                                           self.profile_hidden, self.legend_rects)


class QualitySection:
    """The active technique's resolutions and sample counts, and the shadow maps'."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        s = self.state.settings
        groups = QUALITY.get(s.technique, ())
        if not groups and s.technique not in QUALITY:
            return
        imgui.separator_text(f"{s.technique}: resolution and samples")
        for group, fields in groups:
            edit_model(getattr(s, group), group, ui, only=fields)
        group, fields = SHADOW_QUALITY
        edit_model(getattr(s, group), group, ui, only=fields)
