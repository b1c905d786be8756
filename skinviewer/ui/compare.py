"""A/B compare: two captured Settings states shown split-screen (movable divider), toggled, or as a
difference heat map.

Cost: each slot owns its own Renderer (sharing the GL context and the shader library), so each slot
keeps its own graph caches and mesh upload. While comparing, a frame renders both slots; with the
live camera applied to both, orbiting re-runs only the view-dependent passes of each slot (about 2x
the single-view cost), and texture-space passes of both stay cached. Memory: a second set of the
technique's textures and a second copy of the mesh."""
from __future__ import annotations

from skinviewer.core.settings import Settings, with_values

MODES = ("off", "split", "toggle", "difference")


class Slot:
    def __init__(self, label: str):
        self.label = label
        self.settings: Settings | None = None
        self.renderer = None  # Renderer, made on first use
        self.source = ""
        self.error = ""
        self._framed: tuple[tuple, Settings] | None = None  # frame_settings' last (inputs, result)


class CompareState:
    def __init__(self):
        self.a = Slot("A")
        self.b = Slot("B")
        self.mode = "off"
        self.divider = 0.5
        self.show_b = False  # toggle mode: which slot is on screen
        self.diff_gain = 8.0
        self.follow_camera = True  # both slots use the live camera

    @property
    def slots(self):
        return (self.a, self.b)

    def ready(self) -> bool:
        return self.a.settings is not None and self.b.settings is not None

    def frame_settings(self, slot: Slot, live: Settings) -> Settings:
        """The slot's settings at the live window size (and camera, when following). Validated once
        per change of those inputs, not every frame."""
        s = slot.settings
        cam = live.camera if self.follow_camera else None
        key = (live.render.width, live.render.height, cam)
        if slot._framed is not None and slot._framed[0][0] is s and slot._framed[0][1:] == key:
            return slot._framed[1]
        upd = {"render.width": live.render.width, "render.height": live.render.height}
        if cam is not None:
            upd["camera"] = cam.model_dump(mode="json")
        out = with_values(s, upd)
        slot._framed = ((s, *key), out)
        return out

    def release(self):
        for slot in self.slots:
            if slot.renderer is not None:
                slot.renderer.release()
                slot.renderer = None
