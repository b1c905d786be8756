"""Scene, camera and lights sections."""
from __future__ import annotations

import math

from imgui_bundle import imgui

from skinviewer.physics.environment import BUILTIN_ENVIRONMENTS
from skinviewer.scene.scenes import SCENES
from skinviewer.ui.camera_control import angles_to_direction, direction_to_angles
from skinviewer.ui.frame import FrameController
from skinviewer.ui.sections.common import change_line
from skinviewer.ui.state import ViewerState
from skinviewer.ui.widgets import (
    UiContext,
    edit_model,
    tooltip,
    wrapped,
)

_ENTER = imgui.InputTextFlags_.enter_returns_true.value
# a light's fields that do not apply to its kind (settings.LightSettings)
_ENV_FIELDS = ("environment", "layout", "yaw", "sh_order", "occlusion", "ao_rays", "transfer_order")
LIGHT_SKIP = {"directional": ("position", "beam_radius") + _ENV_FIELDS, "point": ("direction", "beam_radius") + _ENV_FIELDS,
              "beam": _ENV_FIELDS, "environment": ("direction", "position", "beam_radius", "cast_shadow")}


def _thumbnail(spec: str, layout: str, yaw: float, w: int = 64):
    """(h, w, 3) display colours of an environment: turned by ``yaw``, Reinhard-mapped, gamma 2.2."""
    import numpy as np

    from skinviewer.physics.environment import downsample
    from skinviewer.scene.environment import EnvironmentMapError, environment_image
    try:
        img = downsample(environment_image(spec, layout), w)
    except EnvironmentMapError:
        return None
    shift = round(yaw / 360.0 * img.shape[1])
    img = np.roll(img, -shift, axis=1)  # the view from the head at phi shows L(phi + yaw)
    return np.clip(img / (1.0 + img), 0.0, 1.0) ** (1 / 2.2)


class SceneSection:
    """The built-in scene or a mesh file, and the scene settings."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame
        self.mesh_path = ""

    def draw(self, ui: UiContext) -> None:
        st = self.state
        if not ui.header("Scene"):
            return
        sc = st.settings.scene
        cur = SCENES.index(sc.name) if sc.name in SCENES else 0
        label = "built-in scene" + (" (mesh overrides)" if sc.mesh else "")
        ch, i = imgui.combo(label, cur, list(SCENES))
        if ch:
            st.select_scene(SCENES[i])
        if not self.mesh_path and sc.mesh and not imgui.is_any_item_active():
            self.mesh_path = sc.mesh
        entered, self.mesh_path = imgui.input_text("mesh path", self.mesh_path, _ENTER)
        if imgui.button("load mesh") or (entered and self.mesh_path.strip()):
            st.load_mesh(self.mesh_path.strip())
        imgui.same_line()
        if imgui.button("use built-in"):
            self.mesh_path = ""
            st.apply({"scene.mesh": None}, "scene")
        edit_model(sc, "scene", ui, skip=("name", "mesh"))
        change_line(self.frame, ("scene",))


class CameraSection:
    """The camera settings and the reset button."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        st = self.state
        if not ui.header("Camera"):
            return
        wrapped("in the view: LMB orbit, MMB / shift+LMB pan, wheel zoom, RMB key light")
        edit_model(st.settings.camera, "camera", ui)
        if imgui.button("reset view (R)"):
            st.reset_camera()
        change_line(self.frame, ("camera",))


class LightsSection:
    """Each light (direction pad for directional ones), add / remove, shadow settings."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        st = self.state
        if not ui.header("Lights", True):
            return
        lights = st.settings.lights
        remove = None
        for i, light in enumerate(lights):
            imgui.push_id(f"light{i}")
            name = {0: "key", 1: "rim"}.get(i, f"light {i}")
            open_ = imgui.tree_node_ex(f"{name} ({light.kind}{'' if light.enabled else ', off'})###l{i}",
                                       imgui.TreeNodeFlags_.default_open.value if i == 0 else 0)
            if open_:
                if light.kind == "directional":
                    az, el = direction_to_angles(light.direction)
                    ch1, az = imgui.slider_float("azimuth", az, -180.0, 180.0, "%.1f deg")
                    ch2, el = imgui.slider_float("elevation", el, -89.0, 89.0, "%.1f deg")
                    if ch1 or ch2:
                        ui.edits.set(f"lights.{i}.direction", list(angles_to_direction(az, el)))
                    self._direction_pad(i, az, el, ui)
                if light.kind == "environment":
                    self._environment_row(i, light, ui)
                edit_model(light, f"lights.{i}", ui, skip=LIGHT_SKIP[light.kind])
                if len(lights) > 1 and imgui.small_button("remove light"):
                    remove = i
                imgui.tree_pop()
            imgui.pop_id()
        if len(lights) < 4 and imgui.small_button("add light"):
            ui.edits.set(f"lights.{len(lights)}", {"intensity": 1.0})
        if remove is not None:
            data = [x.model_dump(mode="json") for k, x in enumerate(lights) if k != remove]
            st.apply({"lights": data}, "lights")
        if imgui.tree_node("shadows"):
            edit_model(st.settings.shadow, "shadow", ui)
            imgui.tree_pop()
        change_line(self.frame, ("lights", "shadow"))

    def _environment_row(self, i: int, light, ui: UiContext) -> None:
        """The environment light's row (issue 32): built-in picker, its thumbnail (the panorama as seen
        from the head, turned by the yaw, tone-mapped) and a rotation dial for the yaw."""
        names = list(BUILTIN_ENVIRONMENTS)
        cur = names.index(light.environment) if light.environment in names else len(names)
        ch, k = imgui.combo("environment##env", cur, names + ["(file)"])
        if ch and k < len(names):
            ui.edits.set(f"lights.{i}.environment", names[k])
        key = (light.environment, light.layout, round(light.yaw, 1))
        if getattr(self, "_thumb_key", None) != key:
            self._thumb_key, self._thumb = key, _thumbnail(light.environment, light.layout, light.yaw)
        p = imgui.get_cursor_screen_pos()
        cw = 3.0
        if self._thumb is not None:
            dl = imgui.get_window_draw_list()
            th, tw = self._thumb.shape[:2]
            for y in range(th):
                for x in range(tw):
                    r, g, b = self._thumb[y, x]
                    dl.add_rect_filled(imgui.ImVec2(p.x + x * cw, p.y + y * cw),
                                       imgui.ImVec2(p.x + (x + 1) * cw, p.y + (y + 1) * cw),
                                       imgui.get_color_u32(imgui.ImVec4(r, g, b, 1.0)))
            imgui.dummy(imgui.ImVec2(tw * cw, th * cw))
        else:
            imgui.text_disabled("(no thumbnail: the file cannot be read)")
        imgui.same_line()
        size = 48.0
        q = imgui.get_cursor_screen_pos()
        imgui.invisible_button("yawdial", imgui.ImVec2(size, size))
        dl = imgui.get_window_draw_list()
        c = imgui.ImVec2(q.x + size / 2, q.y + size / 2)
        rad = size / 2 - 3
        dl.add_circle_filled(c, rad, imgui.get_color_u32(imgui.ImVec4(0.16, 0.16, 0.2, 1.0)))
        a = math.radians(light.yaw)
        dl.add_line(c, imgui.ImVec2(c.x + math.sin(a) * rad, c.y - math.cos(a) * rad),
                    imgui.get_color_u32(imgui.ImVec4(1.0, 0.85, 0.3, 1.0)), 2.0)
        if imgui.is_item_active():
            m = imgui.get_io().mouse_pos
            yaw = math.degrees(math.atan2(m.x - c.x, -(m.y - c.y)))
            ui.edits.set(f"lights.{i}.yaw", round(yaw, 1))
        tooltip("drag to turn the environment about the vertical (lights.N.yaw)")

    def _direction_pad(self, i: int, az: float, el: float, ui: UiContext) -> None:
        """A little disc: drag the dot to aim the light (azimuth around, elevation from the centre)."""
        size = 84.0
        p = imgui.get_cursor_screen_pos()
        imgui.invisible_button("dirpad", imgui.ImVec2(size, size))
        dl = imgui.get_window_draw_list()
        c = imgui.ImVec2(p.x + size / 2, p.y + size / 2)
        rad = size / 2 - 3
        dl.add_circle_filled(c, rad, imgui.get_color_u32(imgui.ImVec4(0.16, 0.16, 0.2, 1.0)))
        dl.add_circle(c, rad, imgui.get_color_u32(imgui.ImVec4(0.5, 0.5, 0.55, 1.0)))
        dl.add_circle(c, rad * 0.5, imgui.get_color_u32(imgui.ImVec4(0.3, 0.3, 0.35, 1.0)))
        # polar: centre = straight up, inner ring = horizon, rim = straight down; down the pad = front (+Z)
        rr = min(rad, (90.0 - el) / 180.0 * rad)
        a = math.radians(az)
        dot = imgui.ImVec2(c.x + math.sin(a) * rr, c.y + math.cos(a) * rr)
        dl.add_circle_filled(dot, 5.0, imgui.get_color_u32(imgui.ImVec4(1.0, 0.85, 0.3, 1.0)))
        if imgui.is_item_active():
            m = imgui.get_io().mouse_pos
            dx, dy = m.x - c.x, m.y - c.y
            d = min(math.hypot(dx, dy), rad)
            new_el = 90.0 - d / rad * 180.0
            new_az = math.degrees(math.atan2(dx, dy))
            ui.edits.set(f"lights.{i}.direction", list(angles_to_direction(new_az, max(-89.0, min(89.0, new_el)))))
        imgui.same_line()
        imgui.text_disabled("drag to aim\ncentre = above\ninner ring = horizon\nbottom = front, top = behind")
