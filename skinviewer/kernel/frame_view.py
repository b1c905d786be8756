"""One frame's view of the scene and camera (issue 28): the rendered camera, what it frames and the
screen coverage that follows, built once per frame by the renderer (``engine/renderer.Renderer``,
the one place the camera is made from settings) and read by the passes (``ExecuteContext.view`` is
its camera) and by the scene rules in reflect (``Reflection.view``) alike, so a rule measures the
camera that is drawn -- the portrait framing of a bust included."""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from skinviewer.scene.camera import View


@dataclass(frozen=True, eq=False)
class FrameView:
    """The frame's camera (``camera``: scene/camera.framed_view of the settings' camera at the render
    size) over ``scene`` (a GpuScene: ``frame`` = (centre, radius) of what the camera frames, e.g. the
    head of a bust, and ``mm_per_unit``), with its vertical field of view in degrees. The light spaces
    do not depend on the camera: they are the scene's, one per light pose (GpuScene.light_space)."""
    camera: View
    scene: Any
    fov_y: float

    @property
    def key(self) -> str:
        """The camera's key (the cache key of view-dependent passes)."""
        return self.camera.key()

    @functools.cached_property
    def screen_diameter_px(self) -> float:
        """The projected diameter (pixels, along the image height) of the framed part's bounding
        sphere (the head of a bust, not its shoulders); inf when the eye is inside it."""
        h = self.camera.size[1]
        f_center, f_radius = self.scene.frame
        d = float(np.linalg.norm(np.asarray(self.camera.eye, np.float64) - f_center))
        if d <= f_radius:
            return float("inf")
        half = math.asin(min(f_radius / d, 1.0))
        return h * math.tan(half) / math.tan(math.radians(self.fov_y) / 2.0)

    @property
    def px_per_mm(self) -> float:
        """Pixels per millimetre at the framed part on screen: D_px / (2 r mm)."""
        px: float = self.screen_diameter_px / (2.0 * self.scene.frame[1] * self.scene.mm_per_unit)
        return px
