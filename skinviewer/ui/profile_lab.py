"""Profile lab panel: pick a diffusion model (dipole / multipole / Burley) from a measured material
or parameters, see r R(r), fit K Gaussians (``skinviewer.physics.fitting``, in a background thread) and
apply them to the current settings' ``deon.gaussians``."""
from __future__ import annotations

import threading

import numpy as np
from imgui_bundle import imgui

from skinviewer.ui import profile_plot
from skinviewer.ui.widgets import ERR, UiContext, tooltip, wrapped

MODELS = ("dipole", "multipole", "burley")
R_MAX = 8.0


class ProfileLab:
    def __init__(self, state, frame=None):
        from skinviewer.physics import profiles as P
        self.state = state
        self.P = P
        self.model = "dipole"
        self.materials = list(P.MATERIALS)
        self.material = self.materials.index("Skin1") if "Skin1" in P.MATERIALS else 0
        self.use_material = True
        m = P.MATERIALS[self.materials[self.material]]
        self.ssp = list(m.sigma_s_prime)
        self.sa = list(m.sigma_a)
        self.eta = 1.3
        self.thickness = 2.0
        self.three_layer = False
        self.albedo = [0.8, 0.6, 0.5]
        self.mfp = [1.0, 0.5, 0.25]
        self.k = 4
        self.shared = True
        self.normalize = True
        self.log_r = True  # the plot's radius axis (ui/profile_plot.py)
        self.hidden: set[str] = set()  # series a click on the plot's legend hid
        # fit / fit_error belong to the UI thread; the background fit only hands its outcome over
        # through _result (one assignment), picked up by _collect() on the UI thread
        self.fit = None
        self.fit_error = ""
        self.model_error = ""
        self._thread: threading.Thread | None = None
        self._result = None  # (model key, fit or None, error text) of the finished background fit
        self._cache_key = None
        self._curve = None  # (r, r*R)

    @property
    def busy(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # -- model -------------------------------------------------------------------------------
    def _key(self):
        return (self.model, self.use_material, self.material, tuple(self.ssp), tuple(self.sa), self.eta,
                self.thickness, self.three_layer, tuple(self.albedo), tuple(self.mfp))

    def build_model(self):
        P = self.P
        if self.use_material:
            m = P.MATERIALS[self.materials[self.material]]
            ssp, sa, eta = m.sigma_s_prime, m.sigma_a, m.eta
        else:
            ssp, sa, eta = tuple(self.ssp), tuple(self.sa), self.eta
        if self.model == "dipole":
            return P.Dipole(ssp, sa, eta)
        if self.model == "multipole":
            if self.three_layer:
                return P.three_layer_skin()
            return P.Multipole(ssp, sa, self.thickness, eta)
        if self.use_material:
            if min(sa) <= 0:
                raise ValueError("Burley from a material needs sigma_a > 0 in every channel")
            A = P.Dipole(ssp, sa, eta).total_reflectance()
            return P.Burley(A, P.diffuse_mean_free_path(ssp, sa), "searchlight-dmfp")
        return P.Burley(tuple(self.albedo), tuple(self.mfp), "searchlight-dmfp")

    def curve(self):
        """(r, R(r)) of the model on the plot's radii (cached per model and axis)."""
        key = (self._key(), self.log_r)
        if key != self._cache_key:
            if self._cache_key is None or key[0] != self._cache_key[0]:
                self.fit = None
            self._cache_key = key
            try:
                r = profile_plot.radii(0.01, R_MAX, self.log_r, 240)
                r = r[r > 0]
                R = np.asarray(self.build_model()(r), dtype=np.float64)
                self._curve = (r, R)
                self.model_error = ""
            except Exception as exc:
                self._curve = None
                self.model_error = f"{type(exc).__name__}: {exc}"
        return self._curve

    # -- fitting -----------------------------------------------------------------------------
    def start_fit(self, wait: bool = False) -> None:
        if self.busy:
            return
        from skinviewer.physics.fitting import fit_gaussians
        try:
            model = self.build_model()
        except Exception as exc:
            self.fit_error = f"{type(exc).__name__}: {exc}"
            return
        self.fit_error = ""
        self._result = None
        key, k, shared = self._key(), self.k, self.shared

        def work():
            try:
                self._result = (key, fit_gaussians(model, k, shared=shared), "")
            except Exception as exc:
                self._result = (key, None, f"{type(exc).__name__}: {exc}")

        self._thread = threading.Thread(target=work, daemon=True)
        self._thread.start()
        if wait:
            self._thread.join()
            self._collect()

    def _collect(self) -> None:
        """Take over the finished background fit, unless the model was edited while it ran (a fit
        of the previous model must not be shown, or applied, as the fit of this one)."""
        res, self._result = self._result, None
        if res is None:
            return
        key, fit, error = res
        if key != self._key():
            self.fit_error = "the model changed while fitting: fit again"
            return
        self.fit, self.fit_error = fit, error

    def rows(self):
        if self.fit is None:
            return []
        return self.fit.table(normalize=self.normalize)

    def apply(self) -> bool:
        rows = self.rows()
        if not rows:
            return False
        if len(rows) > 8:
            self.fit_error = f"the d'Eon table holds at most 8 Gaussians (this fit has {len(rows)})"
            return False
        return self.state.apply({"deon.gaussians": [{"variance": v, "weights": list(w)} for v, w in rows]},
                              "profile lab")

    # -- UI ----------------------------------------------------------------------------------
    def draw(self, ui: UiContext) -> None:
        if not ui.header("Profile lab"):
            return
        self._collect()
        ch, i = imgui.combo("model", MODELS.index(self.model), list(MODELS))
        if ch:
            self.model = MODELS[i]
        if self.model == "multipole":
            _, self.three_layer = imgui.checkbox("three-layer skin example", self.three_layer)
        if not (self.model == "multipole" and self.three_layer):
            _, self.use_material = imgui.checkbox("measured material (Jensen 2001)", self.use_material)
            if self.use_material:
                _, self.material = imgui.combo("material", self.material, self.materials)
            elif self.model == "burley":
                _, self.albedo = imgui.drag_float3("albedo A", self.albedo, 0.005, 0.0, 1.0)
                _, self.mfp = imgui.drag_float3("mfp d (mm)", self.mfp, 0.01, 0.001, 100.0)
            else:
                _, self.ssp = imgui.drag_float3("sigma_s' (1/mm)", self.ssp, 0.01, 0.0, 1000.0)
                _, self.sa = imgui.drag_float3("sigma_a (1/mm)", self.sa, 0.001, 0.0, 1000.0)
                _, self.eta = imgui.slider_float("eta", self.eta, 1.0, 2.0)
            if self.model == "multipole":
                _, self.thickness = imgui.drag_float("thickness (mm)", self.thickness, 0.01, 0.01, 100.0)
        _, self.k = imgui.slider_int("K Gaussians", self.k, 1, 8)
        _, self.shared = imgui.checkbox("shared variances", self.shared)
        imgui.same_line()
        _, self.normalize = imgui.checkbox("normalise", self.normalize)
        cur = self.curve()
        if self.model_error:
            wrapped(self.model_error, ERR)
        if imgui.button("fitting..." if self.busy else "fit"):
            self.start_fit()
        imgui.same_line()
        imgui.begin_disabled(self.fit is None)
        if imgui.button("apply to d'Eon gaussians"):
            self.apply()
        imgui.end_disabled()
        if self.fit_error:
            imgui.text_colored(ERR, self.fit_error)
        if self.fit is not None:
            e = self.fit.errors
            imgui.text_disabled(f"error R {e[0]:.3f}  G {e[1]:.3f}  B {e[2]:.3f}  ({self.fit.seconds:.2f} s)")
        _, self.log_r = imgui.checkbox("log radius axis##lab", self.log_r)
        tooltip("linear: r·R(r) against r (GPU Gems 3 §14.4.6); log: r²·R(r) against log r (the same area rule)")
        if cur is not None:
            r, R = cur
            series = []
            for c, (name, col) in enumerate(profile_plot.CHANNELS):
                series.append((f"model {name}", r, profile_plot.weighted(r, R, self.log_r)[:, c], (*col, 0.6), 1.0))
            if self.fit is not None:
                F = profile_plot.weighted(r, np.asarray(self.fit(r), dtype=np.float64), self.log_r)
                for c, (name, col) in enumerate(profile_plot.CHANNELS):
                    series.append((f"fit {name}", r, F[:, c], (*col, 1.0), 2.5))
            profile_plot.draw("model (thin) and fit##lab", series, self.log_r, hidden=self.hidden)
