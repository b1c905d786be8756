"""A headless harness for the Burley blur passes on synthetic buffers (plane, edge, impulse): a pass
that uploads given irradiance / depth / mask arrays as the screen-space framework's resources."""
from __future__ import annotations

import math

import numpy as np

from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.graph import FrameInputs, Pass, RenderGraph, TexSpec
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.passes import burley as PB
from skinviewer.scene.camera import View


class UploadPass(Pass):
    name = "upload"
    uses_scene = False

    def __init__(self, E, z, mask):
        self.set(E, z, mask)

    def set(self, E, z, mask):
        self.E = np.ascontiguousarray(np.concatenate([E, np.asarray(mask)[..., None]], -1), np.float32)
        z = np.asarray(z, np.float32)
        self.z = np.ascontiguousarray(np.stack([z, 0 * z, 0 * z, np.ones_like(z)], -1), np.float32)
        self.version = getattr(self, "version", 0) + 1

    def reflect(self, r):
        r.depends("upload", self.version)  # the arrays are the pass's own state, set from outside
        h, w = self.z.shape[:2]
        r.output(PB.IRRADIANCE, TexSpec((w, h), 4, PB.IRRADIANCE_DTYPE, filter="nearest"))
        r.output(PB.DEPTH, TexSpec((w, h), 4, "f4", filter="nearest"))

    def execute(self, ec):
        ec.output(PB.IRRADIANCE).write(self.E.tobytes())
        ec.output(PB.DEPTH).write(self.z.tobytes())


FOV = 30.0


def proj_scale(height: int, fov: float = FOV) -> float:
    return (1.0 / math.tan(math.radians(fov) / 2.0)) * height / 2.0


def view_for(w: int, h: int, fov: float = FOV) -> View:
    f = 1.0 / math.tan(math.radians(fov) / 2.0)
    proj = np.zeros((4, 4))
    proj[0, 0], proj[1, 1] = f * h / w, f
    proj[2, 2], proj[2, 3], proj[3, 2] = -1.0, -1.0, -1.0
    return View(np.eye(4), proj, np.zeros(3), (w, h))


class Harness:
    """Runs [upload, blur, count] on a headless context; ``run`` returns (blurred rgb, stats, count)."""

    def __init__(self, ctx, blur: PB.BurleyBlurPass):
        self.ctx = ctx
        self.shaders = ShaderLibrary(ctx)
        self.blur = blur
        self.count = PB.BurleyCountPass()
        self.upload = None
        self.graph = None
        self.extra: list = []  # more passes (e.g. the reuse pass)

    def run(self, E, z, mask, settings: Settings | None = None, **assign):
        h, w = z.shape
        s = with_values(settings or Settings(), {"render.width": w, "render.height": h, **assign})
        if self.graph is None:
            self.upload = UploadPass(E, z, mask)
            self.graph = RenderGraph(self.ctx, self.shaders, [self.upload, self.blur, self.count] + self.extra,
                                     [PB.BLURRED, PB.STATS, PB.COUNT])
        else:
            self.upload.set(E, z, mask)
        v = view_for(w, h)
        frame = FrameInputs(settings=s, scene=None, scene_version=0, view=v, view_key=f"{v.key()}#{self.upload.version}")
        self.graph.run(frame, force=True)
        return (self.graph.read(PB.BLURRED)[..., :3].astype(np.float64), self.graph.read(PB.STATS),
                self.count.last)

    def release(self):
        if self.graph is not None:
            self.graph.release()
            self.graph.pool.release()
        self.shaders.release()


def plane(w, h, z_mm=100.0, E=None):
    z = np.full((h, w), z_mm)
    mask = np.ones((h, w))
    if E is None:
        E = np.ones((h, w, 3))
    return E, z, mask


def mm_per_px(z_mm: float, height: int) -> float:
    return z_mm / proj_scale(height)
