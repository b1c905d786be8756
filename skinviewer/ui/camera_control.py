"""Orbit camera and key-light controller: mouse deltas in, dotted-path settings assignments out.
Pure logic (no GL, no imgui) so it is testable headless. Everything it changes lives under
``camera.*`` or ``lights.N.*`` so texture-space passes stay cached while orbiting."""
from __future__ import annotations

import math

import numpy as np

from skinviewer.ground.settings import Settings
from skinviewer.scene.camera import orbit_eye
from skinviewer.scene.mesh import framing_distance

ORBIT_DEG_PER_PX = 0.35
LIGHT_DEG_PER_PX = 0.4
ZOOM_PER_NOTCH = 0.9


def direction_to_angles(d) -> tuple[float, float]:
    """(azimuth about +Y from +Z, elevation) in degrees of a direction vector."""
    x, y, z = (float(c) for c in d)
    n = math.sqrt(x * x + y * y + z * z) or 1.0
    return math.degrees(math.atan2(x, z)), math.degrees(math.asin(max(-1.0, min(1.0, y / n))))


def angles_to_direction(az: float, el: float) -> tuple[float, float, float]:
    a, e = math.radians(az), math.radians(el)
    return (round(math.cos(e) * math.sin(a), 6), round(math.sin(e), 6), round(math.cos(e) * math.cos(a), 6))


class OrbitController:
    """Turns drags/wheel into camera (and key light) assignments for ``with_values``."""

    def __init__(self):
        self.center = np.zeros(3)
        self.radius = 1.0

    def set_scene_bounds(self, center, radius: float) -> None:
        self.center = np.asarray(center, dtype=np.float64)
        self.radius = float(radius)

    def _distance(self, s: Settings) -> float:
        cam = s.camera
        return cam.distance if cam.distance is not None else framing_distance(self.radius, cam.fov_y)

    def _target(self, s: Settings) -> np.ndarray:
        cam = s.camera
        return np.asarray(cam.target if cam.target is not None else self.center, dtype=np.float64)

    def orbit(self, s: Settings, dx: float, dy: float) -> dict:
        yaw = s.camera.yaw - dx * ORBIT_DEG_PER_PX
        yaw = (yaw + 180.0) % 360.0 - 180.0
        pitch = max(-89.0, min(89.0, s.camera.pitch + dy * ORBIT_DEG_PER_PX))
        return {"camera.yaw": round(yaw, 4), "camera.pitch": round(pitch, 4)}

    def pan(self, s: Settings, dx: float, dy: float, viewport_h: float) -> dict:
        cam = s.camera
        dist = self._distance(s)
        target = self._target(s)
        eye = orbit_eye(target, cam.yaw, cam.pitch, dist)
        fwd = target - eye
        fwd /= np.linalg.norm(fwd)
        right = np.cross(fwd, [0.0, 1.0, 0.0])
        right /= max(np.linalg.norm(right), 1e-9)
        up = np.cross(right, fwd)
        world_per_px = 2.0 * dist * math.tan(math.radians(cam.fov_y) / 2.0) / max(viewport_h, 1)
        t = target - right * dx * world_per_px + up * dy * world_per_px
        return {"camera.target": [float(v) for v in t], "camera.distance": float(dist)}

    def zoom(self, s: Settings, notches: float) -> dict:
        dist = self._distance(s) * (ZOOM_PER_NOTCH ** notches)
        dist = max(self.radius * 1e-3, min(dist, self.radius * 1e3, 1e7))
        return {"camera.distance": float(dist)}

    def move_light(self, s: Settings, index: int, dx: float, dy: float) -> dict:
        """Right-drag: swing light ``index`` about the subject (direction, or position for point/beam)."""
        if index >= len(s.lights):
            return {}
        light = s.lights[index]
        if light.kind == "environment":  # turn the environment about the vertical
            return {f"lights.{index}.yaw": float((light.yaw + dx * LIGHT_DEG_PER_PX + 180.0) % 360.0 - 180.0)}
        if light.kind == "directional":
            az, el = direction_to_angles(light.direction)
            az += dx * LIGHT_DEG_PER_PX
            el = max(-89.0, min(89.0, el - dy * LIGHT_DEG_PER_PX))
            return {f"lights.{index}.direction": list(angles_to_direction(az, el))}
        rel = np.asarray(light.position, dtype=np.float64) - self.center
        r = float(np.linalg.norm(rel)) or self.radius * 3.0
        az, el = direction_to_angles(rel if np.linalg.norm(rel) > 0 else (0, 0, 1))
        az += dx * LIGHT_DEG_PER_PX
        el = max(-89.0, min(89.0, el - dy * LIGHT_DEG_PER_PX))
        d = np.asarray(angles_to_direction(az, el))
        out = {f"lights.{index}.position": [float(v) for v in self.center + d * r]}
        if light.kind == "beam":
            out[f"lights.{index}.direction"] = [float(v) for v in d]
        return out
