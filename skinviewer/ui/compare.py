"""A/B compare: two captured Settings states shown split-screen (movable divider), toggled, or as a
difference heat map. This is the user's choice (part of the viewer state, edited through methods);
the frame controller renders the slots.

Cost: each slot gets its own Renderer (sharing the GL context and the shader library), so each slot
keeps its own graph caches and mesh upload. While comparing, a frame renders both slots; with the
live camera applied to both, orbiting re-runs only the view-dependent passes of each slot (about 2x
the single-view cost), and texture-space passes of both stay cached. Memory: a second set of the
technique's textures and a second copy of the mesh."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from skinviewer.ground.settings import Settings, SettingsError, load_preset, with_values

MODES = ("off", "split", "toggle", "difference")


class Slot:
    def __init__(self, label: str):
        self.label = label
        self.settings: Settings | None = None
        self.source = ""
        self.error = ""

    def set(self, s: Settings | None, source: str) -> None:
        self.settings, self.source, self.error = s, source, ""

    def set_error(self, text: str) -> None:
        self.error = text


class CompareState:
    def __init__(self):
        self.a = Slot("A")
        self.b = Slot("B")
        self.mode = "off"
        self.divider = 0.5
        self.show_b = False  # toggle mode: which slot is on screen
        self.diff_gain = 8.0
        self.follow_camera = True  # both slots use the live camera
        self._framed: dict[str, tuple[tuple, Settings]] = {}  # frame_settings' last (inputs, result) per slot

    @property
    def slots(self):
        return (self.a, self.b)

    def ready(self) -> bool:
        return self.a.settings is not None and self.b.settings is not None

    @property
    def active(self) -> bool:
        return self.mode != "off" and self.ready()

    # -- edits -------------------------------------------------------------------------------
    def capture(self, slot: Slot, s: Settings, source: str = "") -> None:
        slot.set(s, source or f"captured ({s.technique})")

    def load_into(self, slot: Slot, path: str) -> bool:
        try:
            slot.set(load_preset(path), Path(path).name)
        except SettingsError as exc:
            slot.set_error("; ".join(f"{a}: {b}" for a, b in exc.errors))
            return False
        return True

    def set_mode(self, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"compare mode '{mode}' (have: {', '.join(MODES)})")
        self.mode = mode

    def set_divider(self, fraction: float) -> None:
        self.divider = float(min(1.0, max(0.0, fraction)))

    def set_show_b(self, on: bool) -> None:
        self.show_b = bool(on)

    def set_gain(self, gain: float) -> None:
        self.diff_gain = float(gain)

    def set_follow_camera(self, on: bool) -> None:
        self.follow_camera = bool(on)

    def slot_name(self, slot: Slot) -> str:
        """'A: deon (captured)' -- the slot, its technique and where it came from."""
        if slot.settings is None:
            return f"{slot.label}: (empty)"
        src = slot.source if slot.source and not slot.source.startswith("captured") else "captured"
        return f"{slot.label}: {slot.settings.technique} ({src})"

    def shown(self) -> str:
        """What the 3D view shows while comparing, for every readout (status bar, passes, accuracy):
        '' when not comparing."""
        if not self.active:
            return ""
        if self.mode == "toggle":
            return f"showing {self.slot_name(self.b if self.show_b else self.a)}"
        if self.mode == "split":
            return f"left {self.slot_name(self.a)} | right {self.slot_name(self.b)}"
        return f"|A - B| x {self.diff_gain:g}: {self.slot_name(self.a)} vs {self.slot_name(self.b)}"

    def flip(self) -> str:
        """Space: switch to toggle mode, then flip A / B; returns the slot shown."""
        if self.mode != "toggle":
            self.mode = "toggle"
        else:
            self.show_b = not self.show_b
        return "B" if self.show_b else "A"

    # -- rendering input -----------------------------------------------------------------------
    def frame_settings(self, slot: Slot, live: Settings) -> Settings:
        """The slot's settings at the live window size (and camera, when following). Validated once
        per change of those inputs, not every frame."""
        s = slot.settings
        assert s is not None, "only a filled slot is shown"
        cam = live.camera if self.follow_camera else None
        key = (live.render.width, live.render.height, cam)
        last = self._framed.get(slot.label)
        if last is not None and last[0][0] is s and last[0][1:] == key:
            return last[1]
        upd: dict[str, Any] = {"render.width": live.render.width, "render.height": live.render.height}
        if cam is not None:
            upd["camera"] = cam.model_dump(mode="json")
        out = with_values(s, upd)
        self._framed[slot.label] = ((s, *key), out)
        return out
