"""The input controller: mouse and keys in the 3D view become state changes.

Left-drag orbits, middle-drag (or Shift+left) pans, the wheel zooms, right-drag swings the key
light (``camera_control.OrbitController`` turns deltas into settings assignments); a drag near the
A/B divider moves it. Keys: 1..N pick the techniques in the registry's order, Space flips A/B,
R resets the camera, F1 hides the UI, F12 takes a screenshot, Ctrl+S saves the preset, Esc leaves
the pass inspector. Input over the UI (the docked panel, the status bar, a floating window) is the
UI's: the window forwards every event to imgui as well."""
from __future__ import annotations

from skinviewer.ui.camera_control import OrbitController
from skinviewer.ui.frame import FrameController
from skinviewer.ui.state import ViewerState

MAX_TECHNIQUE_KEYS = 9


def shift_keys(keys) -> set:
    codes = {getattr(keys, n, None) for n in ("LEFT_SHIFT", "RIGHT_SHIFT")}
    try:
        import glfw
        if keys.__module__.startswith("moderngl_window.context.glfw"):
            codes |= {glfw.KEY_LEFT_SHIFT, glfw.KEY_RIGHT_SHIFT}
    except Exception:
        pass
    codes.discard(None)
    return codes


def technique_keys(keys, count: int) -> dict:
    """Key code -> technique index for keys 1..N (and the keypad's), N = the registry's size (at most 9)."""
    out = {}
    for i in range(min(count, MAX_TECHNIQUE_KEYS)):
        for name in (f"NUMBER_{i + 1}", f"NUMPAD_{i + 1}"):
            code = getattr(keys, name, None)
            if code is not None:
                out[code] = i
    return out


class InputController:
    def __init__(self, state: ViewerState, frame: FrameController, ui, keys, mouse):
        """``ui``: what the UI covers and wants (``UiHost.covers / wants_mouse / wants_keyboard``);
        ``keys`` / ``mouse``: the window's key and button codes."""
        self.state, self.frame, self.ui = state, frame, ui
        self.keys, self.mouse = keys, mouse
        self.orbit = OrbitController()
        self._shift_codes = shift_keys(keys)
        self._buttons: set[int] = set()
        self._drag_owner: str | None = None  # "ui", "divider" or "view" while a button is held
        self._drag_moved = False  # the current view drag has moved the camera / light (not a mere click)
        self._shift = False
        self._mouse = (0.0, 0.0)

    # -- where the mouse is --------------------------------------------------------------------
    def over_ui(self, x: float, y: float) -> bool:
        """True over the docked panel / status bar (outside the 3D view) or a floating UI window."""
        if not self.state.view.show_ui:
            return False
        if not self.frame.layout.in_view(x, y) or self.ui.covers(x, y):
            return True
        try:
            return self.ui.wants_mouse() and self._drag_owner == "ui"
        except Exception:
            return False

    def _view_fraction(self, x: float) -> float:
        vx, _, vw, _ = self.frame.layout.view
        return float(min(1.0, max(0.0, (x - vx) / max(vw, 1.0))))

    def _near_divider(self, x: float) -> bool:
        cmp = self.state.compare
        vx, _, vw, _ = self.frame.layout.view
        return cmp.mode == "split" and cmp.ready() and abs(x - (vx + cmp.divider * vw)) < 8

    def _apply(self, assignments: dict, source: str) -> None:
        scene = self.state.scene
        if scene is not None:
            self.orbit.set_scene_bounds(*scene.gpu.frame)
        self.state.apply(assignments, source)

    # -- mouse ---------------------------------------------------------------------------------
    def position(self, x, y) -> None:
        self._mouse = (float(x), float(y))

    def press(self, x, y, button) -> None:
        self._mouse = (float(x), float(y))
        self._buttons.add(button)
        if self._drag_owner is None:
            if self.over_ui(x, y):
                self._drag_owner = "ui"
            elif button == self.mouse.left and self._near_divider(x):
                self._drag_owner = "divider"
            else:
                self._drag_owner = "view"
                self._drag_moved = False

    def release(self, x, y, button) -> None:
        self._buttons.discard(button)
        if not self._buttons:
            self._drag_owner = None
            self.frame.set_dragging(False)

    def drag(self, x, y, dx, dy, shift_held: bool = False) -> None:
        self._mouse = (float(x), float(y))
        if self._drag_owner == "divider":
            self.state.compare.set_divider(self._view_fraction(x))
            return
        if self._drag_owner != "view":
            return
        self._drag_moved = True
        m = self.mouse
        shift = self._shift or shift_held
        s = self.state.settings
        if m.middle in self._buttons or (m.left in self._buttons and shift):
            self.frame.set_dragging(True)
            self._apply(self.orbit.pan(s, dx, dy, self.frame.layout.view[3]), "camera (pan)")
        elif m.left in self._buttons:
            self.frame.set_dragging(True)
            self._apply(self.orbit.orbit(s, dx, dy), "camera (orbit)")
        elif m.right in self._buttons:
            self.frame.set_dragging(True)
            self._apply(self.orbit.move_light(s, 0, dx, dy), "lights.0 (key light drag)")

    def scroll(self, x_offset, y_offset) -> None:
        if self.over_ui(*self._mouse):
            return
        if self.state.view.show_ui and self.ui.wants_mouse():
            return
        self._apply(self.orbit.zoom(self.state.settings, y_offset), "camera (zoom)")

    # -- keys ----------------------------------------------------------------------------------
    def key(self, key, action, modifiers) -> None:
        keys = self.keys
        self._shift = bool(getattr(modifiers, "shift", False))
        if key in self._shift_codes and action in (keys.ACTION_PRESS, keys.ACTION_RELEASE):
            # X11 reports the modifiers from before the event: a Shift release still says "shift",
            # which left shift+left-drag panning stuck on after Shift was let go
            self._shift = action == keys.ACTION_PRESS
        if action != keys.ACTION_PRESS:
            return
        ctrl = bool(getattr(modifiers, "ctrl", False))
        st = self.state
        # function keys and Ctrl+S work even while a text field has the keyboard
        if key == keys.F12:
            self.frame.request_screenshot()
            return
        if key == keys.F1:
            st.toggle_ui()
            return
        if ctrl and key == keys.S:
            if self._shift:
                st.request_save_as()  # Ctrl+Shift+S: always ask for a name
            else:
                st.save_preset()  # the named preset; without one it asks
            return
        if st.view.show_ui and self.ui.wants_keyboard():
            return
        tech = technique_keys(keys, len(st.technique_names()))
        if key == keys.R:
            st.reset_camera()
            st.say("camera reset (R)")
        elif key in tech and not ctrl:
            st.technique_by_key(tech[key])
        elif key == keys.SPACE and st.compare.mode != "off":
            st.flip_compare()
        elif key == keys.ESCAPE and st.inspect.resource is not None:
            st.set_inspect(None)
