"""Orbit camera and light-space matrices (seed 000 eq. 1-6). Matrices returned for GLSL are
column-major float32 bytes-ready arrays (``.T`` of the row-major numpy form) with GL clip z in [-1, 1]."""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np
from pyglm import glm

from skinviewer.scene.mesh import framing_distance


@dataclass
class View:
    """A camera for one frame: what view-dependent passes read."""
    view: np.ndarray  # 4x4 row-major (column-vector convention: clip = proj @ view @ p)
    proj: np.ndarray
    eye: np.ndarray
    size: tuple[int, int]

    @property
    def view_proj(self) -> np.ndarray:
        return self.proj @ self.view

    def key(self) -> str:
        h = hashlib.sha1(self.view.astype(np.float32).tobytes() + self.proj.astype(np.float32).tobytes())
        return h.hexdigest()[:16] + f"@{self.size[0]}x{self.size[1]}"


def gl_bytes(m: np.ndarray) -> bytes:
    """Row-major numpy 4x4 -> column-major bytes for a GLSL mat4 uniform."""
    return np.ascontiguousarray(m.T, dtype=np.float32).tobytes()


def orbit_eye(target, yaw_deg: float, pitch_deg: float, distance: float) -> np.ndarray:
    """yaw 0 looks at the face from +Z; positive pitch looks from above."""
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    offset = np.array([math.cos(p) * math.sin(y), math.sin(p), math.cos(p) * math.cos(y)])
    return np.asarray(target, dtype=np.float64) + distance * offset


def orbit_view(cam, center: np.ndarray, radius: float, size: tuple[int, int],
               frame: tuple[np.ndarray, float] | None = None) -> View:
    """A View from CameraSettings. (center, radius) bound the whole scene (near/far); the camera
    looks at and frames ``frame`` = (centre, radius), e.g. MeshData.frame (the head of a bust),
    when target / distance are None; without ``frame`` it frames the bounding sphere."""
    f_center, f_radius = frame if frame is not None else (center, radius)
    target = np.asarray(cam.target if cam.target is not None else f_center, dtype=np.float64)
    distance = cam.distance if cam.distance is not None else framing_distance(f_radius, cam.fov_y)
    eye = orbit_eye(target, cam.yaw, cam.pitch, distance)
    view = np.array(glm.lookAt(glm.vec3(*eye), glm.vec3(*target), glm.vec3(0, 1, 0)).to_list(), dtype=np.float64).T
    # near/far hug the scene's bounding sphere as seen from the eye (depth precision)
    d_center = float(np.linalg.norm(eye - center))
    # no absolute floor: a mesh 1e-6 units across is framed like one 1e3 across (the near plane
    # scales with the distance, which scales with the mesh)
    near = max(d_center - radius * 1.5, distance * 1e-3)
    far = max(d_center + radius * 1.5, near * (1.0 + 1e-6))
    aspect = size[0] / max(size[1], 1)
    proj = np.array(glm.perspective(math.radians(cam.fov_y), aspect, near, far).to_list(), dtype=np.float64).T
    return View(view=view, proj=proj, eye=eye, size=size)


def framed_view(cam, scene, size: tuple[int, int]) -> View:
    """The rendered camera: ``orbit_view`` of a scene (anything with ``center``, ``radius`` and
    ``frame``, e.g. the renderer's GpuScene) framing ``scene.frame`` -- the head of a bust. The one
    place the renderer, the reference and the rules build the camera from settings."""
    return orbit_view(cam, scene.center, scene.radius, size, scene.frame)


# ---------------------------------------------------------------------------------------------
# light space, seed 000 eq. (1)-(6), in the seed's row-vector form p' = p * M * View * P

def light_basis(light_pos: np.ndarray, target: np.ndarray, up=(0.0, 1.0, 0.0)):
    """eq. (2)-(4) with the light looking at ``target`` (the seed's L is relative to the origin)."""
    L = np.asarray(light_pos, dtype=np.float64) - np.asarray(target, dtype=np.float64)
    Z = -L / np.linalg.norm(L)  # eq. (2)
    upv = np.asarray(up, dtype=np.float64)
    if abs(np.dot(upv, Z)) > 0.999:  # light straight above/below: any other up
        upv = np.array([0.0, 0.0, 1.0])
    X = -np.cross(upv, Z)  # eq. (3)
    X /= np.linalg.norm(X)
    Y = np.cross(Z, X)  # eq. (4)
    return X, Y, Z


def light_view_rowvec(light_pos, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """eq. (1): the view matrix for row vectors (translation in the last row)."""
    X, Y, Z = light_basis(light_pos, target, up)
    Lp = np.asarray(light_pos, dtype=np.float64)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = X, Y, Z
    m[3, :3] = [-X @ Lp, -Y @ Lp, -Z @ Lp]
    return m


def light_projection_rowvec(fov: float, w: float, h: float, near: float, far: float) -> np.ndarray:
    """eq. (5): perspective projection (row vectors, depth z/w in [0, 1])."""
    t = math.tan(fov / 2.0)
    m = np.zeros((4, 4))
    m[0, 0] = h / (t * w)
    m[1, 1] = 1.0 / t
    m[2, 2] = far / (far - near)
    m[2, 3] = 1.0
    m[3, 2] = -far * near / (far - near)
    return m


def ortho_projection_rowvec(half: float, near: float, far: float) -> np.ndarray:
    """The limit of eq. (5) for a directional light (parallel rays): orthographic, depth in [0, 1]."""
    m = np.zeros((4, 4))
    m[0, 0] = m[1, 1] = 1.0 / half
    m[2, 2] = 1.0 / (far - near)
    m[3, 2] = -near / (far - near)
    m[3, 3] = 1.0
    return m


# D3D-style clip (z in [0,1], row vectors) -> GL clip (z in [-1,1], column vectors)
_Z_TO_GL = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 2, 0], [0, 0, -1, 1]], dtype=np.float64)


@dataclass
class LightSpace:
    view_proj_rowvec: np.ndarray  # eq. (6): p' = p * (View * P)
    position: np.ndarray  # light position (point) or a far virtual position (directional)
    directional: bool
    extent: float = 1.0  # world width the map covers at the subject's centre

    def texel_world(self, map_size: int) -> float:
        return self.extent / max(int(map_size), 1)

    @property
    def gl_matrix(self) -> np.ndarray:
        """Column-vector GL matrix: clip_gl = M @ p, clip z in [-1, 1]."""
        return (self.view_proj_rowvec @ _Z_TO_GL).T

    def depth(self, p: np.ndarray) -> np.ndarray:
        """z/w in [0, 1] (eq. 6, step 4) for points (N, 3): the value the shadow map stores."""
        ph = np.hstack([p, np.ones((len(p), 1))]) @ self.view_proj_rowvec
        return ph[:, 2] / ph[:, 3]


def light_space(light, center: np.ndarray, radius: float, points: np.ndarray | None = None) -> LightSpace:
    """Shadow-map matrices fitted to the mesh's bounding sphere (seed 000 §4.1.1 step 2). A point
    light's frustum narrows to the cone that holds ``points`` (the mesh's vertices) when that is
    tighter than the sphere's: near the head the sphere's cone wastes most of the map."""
    center = np.asarray(center, dtype=np.float64)
    radius = max(float(radius), 1e-6)
    if light.kind == "point":
        pos = np.asarray(light.position, dtype=np.float64)
        dist = float(np.linalg.norm(pos - center))
        if dist <= radius * 1.05:  # light inside the bounds: back it off along its direction so eq. (5) fits
            d = (pos - center) / dist if dist > radius * 1e-9 else np.array([0.0, 0.0, 1.0])
            pos = center + d * radius * 1.05
            dist = radius * 1.05
        elif dist > radius * 1e4:  # so far that its rays are parallel: bring it in, or near == far (eq. 5 / 0)
            pos = center + (pos - center) / dist * radius * 1e4
            dist = radius * 1e4
        fov = 2.0 * math.asin(min(radius / dist, 0.999))
        if points is not None and len(points):
            rel = np.asarray(points, np.float64) - pos
            cos = rel @ ((center - pos) / dist) / np.maximum(np.linalg.norm(rel, axis=1), 1e-300)
            fov = min(fov, 2.0 * math.acos(float(np.clip(cos.min(), -1.0, 1.0))) * 1.02)  # 2 % margin
        near, far = max(dist - radius, dist * 1e-3), dist + radius
        vp = light_view_rowvec(pos, center) @ light_projection_rowvec(fov, 1.0, 1.0, near, far)
        return LightSpace(vp, pos, False, 2.0 * dist * math.tan(fov / 2.0))
    d = np.asarray(light.direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    pos = center + d * radius * 2.0
    vp = light_view_rowvec(pos, center) @ ortho_projection_rowvec(radius * 1.02, radius * 0.98, radius * 3.02)
    return LightSpace(vp, pos, True, 2.0 * radius * 1.02)
