"""The viewer's one state object: the settings (and the scene they load), the presets, the
messages, the A/B compare choices, the pass inspector, screenshot options and the window layout
options. Panels and windows read its fields and change them **only through its methods**: every
settings change is validated here (``apply`` / ``set_settings``), refused edits keep the state and
list their errors, and listeners (the frame controller) hear of each accepted change.

No GL, no imgui: the scene is loaded through the ``load_scene`` function it is given (the
renderer's ``ensure_scene``), so a state whose mesh cannot load is refused like any invalid value."""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from skinviewer import techniques
from skinviewer.engine.look import apply_look
from skinviewer.engine.look import resolve as resolve_look
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, SettingsError, with_values
from skinviewer.scene.environment import environment_problems
from skinviewer.scene.scenes import scene_overrides
from skinviewer.ui.compare import CompareState
from skinviewer.ui.display import CHANNELS
from skinviewer.ui.layout import PANEL_DEFAULT_W
from skinviewer.ui.presets import PresetState
from skinviewer.ui.screenshot import ScreenshotOptions

PREFERRED_TECHNIQUES = ("deon", "gosselin", "phong")
FALLBACK_SCENE = "backlit-ear"
PANEL_SIDES = ("left", "right")


def best_technique(preferred: str | None = None) -> str:
    have = techniques.names()
    if preferred and preferred in have:
        return preferred
    return next((t for t in PREFERRED_TECHNIQUES if t in have), have[0])


@dataclass(frozen=True)
class ViewerOptions:
    """Fixed for a session, given at start (no module-level switches)."""
    debug: bool = False  # print tracebacks of render errors (run_viewer: SKINVIEWER_DEBUG=1)


@dataclass
class ViewOptions:
    show_ui: bool = True
    panel_width: float = PANEL_DEFAULT_W
    panel_side: str = "left"
    vsync: bool = True
    expand_all: bool = False  # open every section so every widget is drawn (tests)


@dataclass
class InspectState:
    resource: str | None = None  # pass output shown full-window (None: the image)
    channel: str = "RGB"
    exposure: float = 1.0


class ViewerState:
    def __init__(self, settings: Settings | None, load_scene: Callable[[Settings], Any],
                 preset_path: str | None = None, notices: list[str] | None = None,
                 options: ViewerOptions | None = None, vsync: bool = True, defer_scene: bool = False):
        self._load_scene = load_scene
        self._listeners: list[Callable[[str], None]] = []
        self.options = options or ViewerOptions()
        self.view = ViewOptions(vsync=bool(vsync))
        self.inspect = InspectState()
        self.shots = ScreenshotOptions()
        self.compare = CompareState()
        self.notices: list[str] = list(notices or [])
        self.errors: list[tuple[str, str]] = []  # the last refused edit
        self.error_title = ""
        self.message = ("", False)  # status bar: (text, is_error)
        self.scene: Any = None  # the loaded scene (description, notes, bounds)
        s = settings or Settings()
        if s.technique not in techniques.names():
            s = with_values(s, {"technique": best_technique(s.technique)})
        self._preset_path = preset_path
        # defer_scene: the start shows the panel before the mesh is read and uploaded (issue 34);
        # load_initial_scene() follows (an edit before it loads the scene itself, set_settings)
        self.settings = s if defer_scene else self._initial_scene(s)
        self.home_camera = self.settings.camera.model_dump(mode="json")
        self.presets = PresetState(self.settings, preset_path)

    def load_initial_scene(self) -> None:
        """The scene of a start whose panel came first (``defer_scene``); the fallback scene, said
        in the notices, if it cannot be loaded. Nothing if a scene is loaded already."""
        if self.scene is not None:
            return
        s = self._initial_scene(self.settings)
        if s is not self.settings:  # the fallback scene: its settings are the start's
            self.settings = s
            self.home_camera = s.camera.model_dump(mode="json")
            self.presets = PresetState(s, self._preset_path)

    # -- listeners ---------------------------------------------------------------------------
    def subscribe(self, fn: Callable[[str], None]) -> None:
        """``fn(source)`` is called after each accepted change of the settings."""
        self._listeners.append(fn)

    # -- settings ----------------------------------------------------------------------------
    def _initial_scene(self, s: Settings) -> Settings:
        try:
            self.scene = self._load_scene(s)
        except Exception as exc:
            if s.scene.mesh or s.scene.name == FALLBACK_SCENE:
                raise
            self.notices.append(f"scene '{s.scene.name}' is not available ({type(exc).__name__}: {exc}); "
                                f"showing '{FALLBACK_SCENE}' instead")
            s = with_values(s, {"scene.name": FALLBACK_SCENE, **scene_overrides(FALLBACK_SCENE)})
            self.scene = self._load_scene(s)
        self.notices += self.scene.notes
        return s

    def technique_names(self) -> list[str]:
        return techniques.names()

    def apply(self, assignments: dict[str, Any], source: str = "") -> bool:
        """Validate and apply dotted-path assignments. Refused edits leave the state untouched and
        put their (path, message) list in ``errors``."""
        if not assignments:
            return True
        try:
            new = resolve_look(with_values(self.settings, assignments), assignments)
        except SettingsError as exc:
            self.refuse(exc.errors, source or "invalid setting")
            return False
        return self.set_settings(new, source or ", ".join(assignments))

    def set_settings(self, new: Settings, source: str = "") -> bool:
        if new.technique not in techniques.names():
            self.refuse([("technique", f"'{new.technique}' is not available (have: {', '.join(techniques.names())})")],
                        source or "technique")
            return False
        if self.scene is None or Renderer.scene_key(new) != Renderer.scene_key(self.settings):
            try:
                self.scene = self._load_scene(new)
            except Exception as exc:
                self.refuse([("scene", f"{type(exc).__name__}: {exc}")], source or "scene")
                return False
            self.notices = list(self.scene.notes)
        if [l.environment for l in new.lights] != [l.environment for l in self.settings.lights] or \
                [l.layout for l in new.lights] != [l.layout for l in self.settings.lights]:
            bad = environment_problems(new)  # a bad HDR file: refused, the last good environment stays
            if bad:
                self.refuse(bad, source or "environment")
                return False
        changed = new != self.settings
        self.settings = new
        self.errors = []
        self.error_title = ""
        if changed:
            for fn in self._listeners:
                fn(source or "settings")
        return True

    def set_render_size(self, width: int, height: int) -> bool:
        """The render size follows the 3D view (frame controller): not a user edit, so no listener
        hears of it and presets never store it. Returns whether it changed."""
        if (width, height) == (self.settings.render.width, self.settings.render.height):
            return False
        try:
            self.settings = with_values(self.settings, {"render.width": width, "render.height": height})
        except SettingsError:
            return False
        return True

    def refuse(self, errors: list[tuple[str, str]], title: str) -> None:
        self.errors = list(errors)
        self.error_title = title
        if errors:
            path, msg = errors[0]
            self.say(f"refused {title}: {path}: {msg}", error=True)

    def dismiss_errors(self) -> None:
        self.errors = []

    def say(self, text: str, error: bool = False) -> None:
        """The status bar's message (errors in red)."""
        self.message = (text, bool(error))

    def select_scene(self, name: str) -> bool:
        ok = self.apply({"scene.name": name, "scene.mesh": None, **scene_overrides(name)}, f"scene {name}")
        if ok:
            self.home_camera = self.settings.camera.model_dump(mode="json")
        return ok

    def load_mesh(self, path: str) -> bool:
        ok = self.apply({"scene.mesh": path or None}, f"mesh {path}")
        if ok:
            self.home_camera = self.settings.camera.model_dump(mode="json")
        return ok

    def set_technique(self, name: str) -> bool:
        self.inspect = InspectState(channel=self.inspect.channel, exposure=self.inspect.exposure)
        ok = self.apply({"technique": name}, "technique")
        if ok:
            self.say(f"technique: {name}")
        return ok

    def technique_by_key(self, index: int) -> bool:
        """Keys 1..N: the technique at ``index`` of the registry (its order)."""
        names = techniques.names()
        return 0 <= index < len(names) and self.set_technique(names[index])

    def reset_camera(self) -> None:
        self.apply({"camera": dict(self.home_camera)}, "camera reset")

    # -- presets -----------------------------------------------------------------------------
    def load_preset(self, path: str) -> bool:
        """Load now (unsaved changes are lost: the UI asks first, through ``request_preset``)."""
        s = self.presets.load(path, self.settings)
        if s is None:
            errs = self.presets.errors
            self.say(f"refused preset {path}" + (f": {errs[0][0]}: {errs[0][1]}" if errs else ""), error=True)
            return False
        try:
            s = apply_look(s)  # a preset whose look drives the profile: its tables re-derived (the same values)
        except SettingsError as exc:
            self.presets.refused(path, exc.errors)
            self.say(f"refused preset {path}: {exc}", error=True)
            return False
        if not self.set_settings(s, f"preset {path}"):
            # refused after loading: the current preset file and its saved baseline stay (Ctrl+S
            # must not write this state over the file that was refused)
            self.presets.refused(path, self.errors)
            return False
        self.presets.accepted(self.settings, path)
        self.home_camera = self.settings.camera.model_dump(mode="json")
        self.say(f"loaded preset {path}")
        return True

    def request_preset(self, path: str) -> bool:
        """A click on a preset: load it, unless that would discard unsaved changes — then ask
        (``presets.pending_load``; the panel's popup answers with ``answer_pending``)."""
        if self.presets.dirty(self.settings):
            self.presets.ask_before_loading(path)
            self.say(f"unsaved changes: load {path} anyway?")
            return False
        return self.load_preset(path)

    def answer_pending(self, choice: str) -> bool:
        """The answer to "discard unsaved changes?": "discard" (load), "save" (save, then load) or "cancel"."""
        path = self.presets.pending_load
        self.presets.cancel_pending()
        if path is None or choice == "cancel":
            self.say("load cancelled: unsaved changes kept")
            return False
        if choice == "save" and not self.save_preset():
            return False
        return self.load_preset(path)

    def save_preset(self, path: str | None = None) -> bool:
        """Save as ``path``; without one (Ctrl+S): the current preset file, or a new file in the
        user folder when there is none or the current one is a shipped (read-only) preset."""
        p = self.presets
        if path:
            ok = p.save(self.settings, path)
        elif not p.path:  # no name yet: ask for one (Save as), never a timestamped file
            self.request_save_as()
            return False
        else:
            target, note = p.save_target()
            ok = p.save(self.settings, target, note)
        self.say(p.message, error=not ok)
        return ok

    def request_save_as(self) -> None:
        """Ctrl+Shift+S (or Ctrl+S without a named preset): the *Save as* popup asks for a name."""
        self.presets.ask_name()
        self.say("save as: name the preset")

    def save_preset_named(self, name: str) -> bool:
        """*Save as* answered: a bare name goes to the user folder as NAME.json (a shipped folder is
        refused by ``save``); the named file is then what Ctrl+S writes."""
        from skinviewer.ui.presets import name_to_path
        target = name_to_path(name)
        if target is None:
            self.say("save as: type a name", error=True)
            return False
        ok = self.save_preset(str(target))
        if ok:
            self.presets.close_naming()
        return ok

    def set_preset_path_text(self, text: str) -> None:
        self.presets.set_edit_path(text)

    # -- compare, inspector, screenshots, window ---------------------------------------------
    def capture_slot(self, label: str) -> None:
        slot = self.compare.a if label == "A" else self.compare.b
        self.compare.capture(slot, self.settings)

    def load_slot(self, label: str, path: str) -> bool:
        slot = self.compare.a if label == "A" else self.compare.b
        return self.compare.load_into(slot, path)

    def flip_compare(self) -> None:
        self.say(f"A/B: showing {self.compare.flip()}")

    def set_inspect(self, resource: str | None) -> None:
        self.inspect = replace(self.inspect, resource=resource)

    def set_inspect_channel(self, channel: str) -> None:
        if channel in CHANNELS:
            self.inspect = replace(self.inspect, channel=channel)

    def set_inspect_exposure(self, exposure: float) -> None:
        self.inspect = replace(self.inspect, exposure=float(exposure))

    def set_screenshot_options(self, **changes) -> None:
        """folder=..., include_ui=..., save_linear_npy=..."""
        self.shots = replace(self.shots, **changes)

    def set_show_ui(self, on: bool) -> None:
        self.view = replace(self.view, show_ui=bool(on))

    def toggle_ui(self) -> None:
        self.view = replace(self.view, show_ui=not self.view.show_ui)

    def set_panel_width(self, width: float) -> None:
        self.view = replace(self.view, panel_width=float(width))

    def set_panel_side(self, side: str) -> None:
        if side in PANEL_SIDES:
            self.view = replace(self.view, panel_side=side)

    def set_vsync(self, on: bool) -> None:
        self.view = replace(self.view, vsync=bool(on))

    def set_expand_all(self, on: bool) -> None:
        self.view = replace(self.view, expand_all=bool(on))
