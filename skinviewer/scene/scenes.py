"""Built-in scenes, selectable by name: ``head`` (the default) and analysis scenes for seeing a
profile's behaviour (and for tests). All built-ins are modelled in millimetres.

Each scene also brings settings overrides (its lights and camera) that the CLI and the viewer apply
when the scene is chosen."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from skinviewer.scene.mesh import MeshData

SCENES = ("head", "laser", "shadow-edge", "backlit-ear", "stretch-plane", "regions-plane")


@dataclass
class SceneDef:
    name: str
    mesh: MeshData
    overrides: dict = field(default_factory=dict)  # dotted settings paths -> values
    description: str = ""


def grid(nx: int, ny: int, size_x: float, size_y: float, uv_rect=(0.02, 0.02, 0.98, 0.98), z: float = 0.0,
         flip: bool = False):
    """A plane in XY (normal +Z, or -Z when ``flip``), centred at the origin, UVs mapped into uv_rect."""
    xs = np.linspace(-size_x / 2, size_x / 2, nx + 1)
    ys = np.linspace(-size_y / 2, size_y / 2, ny + 1)
    X, Y = np.meshgrid(xs, ys)
    pos = np.stack([X.ravel(), Y.ravel(), np.full(X.size, z)], axis=1)
    u0, v0, u1, v1 = uv_rect
    s = (X.ravel() + size_x / 2) / size_x
    t = (Y.ravel() + size_y / 2) / size_y
    if flip:
        s = 1.0 - s  # mirrored island keeps a consistent tangent frame when seen from -Z
        pos[:, 0] = pos[:, 0]
    uv = np.stack([u0 + s * (u1 - u0), v0 + t * (v1 - v0)], axis=1)
    idx = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            b, c, d = a + 1, a + nx + 1, a + nx + 2
            idx += [(a, b, d), (a, d, c)] if not flip else [(a, d, b), (a, c, d)]
    nrm = np.tile([0.0, 0.0, -1.0 if flip else 1.0], (len(pos), 1))
    return pos, nrm, uv, np.asarray(idx, dtype=np.int64)


def _merge(parts):
    pos, nrm, uv, idx, off = [], [], [], [], 0
    for p, n, u, i in parts:
        pos.append(p)
        nrm.append(n)
        uv.append(u)
        idx.append(i + off)
        off += len(p)
    return np.vstack(pos), np.vstack(nrm), np.vstack(uv), np.vstack(idx)


def _box(center, size, uv_rect):
    """A closed box (shadow caster) with all six faces packed into one UV rectangle (2x3 cells)."""
    cx, cy, cz = center
    sx, sy, sz = size
    u0, v0, u1, v1 = uv_rect
    cw, ch = (u1 - u0) / 3, (v1 - v0) / 2
    faces = []
    # (origin, edge a, edge b) with normal a x b pointing outwards
    specs = [((cx - sx / 2, cy - sy / 2, cz + sz / 2), (sx, 0, 0), (0, sy, 0)),
             ((cx + sx / 2, cy - sy / 2, cz - sz / 2), (-sx, 0, 0), (0, sy, 0)),
             ((cx + sx / 2, cy - sy / 2, cz + sz / 2), (0, 0, -sz), (0, sy, 0)),
             ((cx - sx / 2, cy - sy / 2, cz - sz / 2), (0, 0, sz), (0, sy, 0)),
             ((cx - sx / 2, cy + sy / 2, cz + sz / 2), (sx, 0, 0), (0, 0, -sz)),
             ((cx - sx / 2, cy - sy / 2, cz - sz / 2), (sx, 0, 0), (0, 0, sz))]
    for k, spec in enumerate(specs):
        o, a, b = map(np.asarray, spec)
        n = np.cross(a, b)
        n = n / np.linalg.norm(n)
        cu, cv = u0 + (k % 3) * cw, v0 + (k // 3) * ch
        pad = 0.15
        p = np.array([o, o + a, o + a + b, o + b], dtype=np.float64)
        uv = np.array([[cu + pad * cw, cv + pad * ch], [cu + (1 - pad) * cw, cv + pad * ch],
                       [cu + (1 - pad) * cw, cv + (1 - pad) * ch], [cu + pad * cw, cv + (1 - pad) * ch]])
        faces.append((p, np.tile(n, (4, 1)), uv, np.array([[0, 1, 2], [0, 2, 3]])))
    return _merge(faces)


def laser_scene() -> SceneDef:
    """GPU Gems 3 §14.4.1 (seed 002): a flat slab lit by a thin beam in a dark room."""
    pos, nrm, uv, idx = grid(48, 48, 24.0, 24.0)
    mesh = MeshData(pos, nrm, uv, idx, name="laser-slab",
                    albedo=np.ones((4, 4, 3), np.float32))
    return SceneDef("laser", mesh, {
        "lights": [{"kind": "beam", "direction": [0.0, 0.0, 1.0], "position": [0.0, 0.0, 0.0],
                    "beam_radius": 0.02, "intensity": 400.0, "color": [1.0, 1.0, 1.0], "cast_shadow": False}],
        "camera": {"yaw": 0.0, "pitch": 0.0, "distance": 60.0, "target": [0.0, 0.0, 0.0], "fov_y": 30.0},
        "render.exposure": 1.0,
    }, "24 mm slab, white albedo, 0.02 mm beam at the centre")


def shadow_edge_scene() -> SceneDef:
    """A plane with a sharp shadow edge across it: an opaque blade hovering above its left half."""
    plane = grid(64, 64, 60.0, 60.0, uv_rect=(0.02, 0.02, 0.78, 0.98))
    blade = _box((-17.5, 0.0, 20.0), (35.0, 80.0, 2.0), uv_rect=(0.82, 0.02, 0.98, 0.40))
    pos, nrm, uv, idx = _merge([plane, blade])
    mesh = MeshData(pos, nrm, uv, idx, name="shadow-edge", albedo=np.ones((4, 4, 3), np.float32))
    return SceneDef("shadow-edge", mesh, {
        # straight down onto the plane: the blade's edge at x = 0 casts the edge at x = 0
        "lights": [{"kind": "directional", "direction": [0.0, 0.0, 1.0], "intensity": 0.8,
                    "color": [1.0, 1.0, 1.0], "cast_shadow": True}],
        "camera": {"yaw": 55.0, "pitch": 25.0, "distance": 150.0, "target": [0.0, 0.0, 0.0], "fov_y": 35.0},
    }, "60 mm plane (UV u in [0.02, 0.78]), shadow edge along x = 0 from a blade 20 mm above")


def backlit_ear_scene() -> SceneDef:
    """A thin flap lit from behind; thickness grows from 1.5 mm (top) to 6 mm (bottom) so
    transmitted light can be seen to fall off with thickness."""
    n = 40
    front = grid(n, n, 30.0, 40.0, uv_rect=(0.02, 0.02, 0.48, 0.98))
    back = grid(n, n, 30.0, 40.0, uv_rect=(0.52, 0.02, 0.98, 0.98), flip=True)
    t_front = 0.5 * _flap_thickness(front[0][:, 1])
    front[0][:, 2] = t_front
    back[0][:, 2] = -0.5 * _flap_thickness(back[0][:, 1])
    pos, nrm, uv, idx = _merge([front, back])
    from skinviewer.scene.mesh import vertex_normals
    nrm = vertex_normals(pos, idx)
    albedo = np.ones((4, 4, 3), np.float32) * np.array([0.85, 0.62, 0.55], np.float32)
    mesh = MeshData(pos, nrm, uv, idx, name="backlit-ear", albedo=albedo)
    return SceneDef("backlit-ear", mesh, {
        "lights": [{"kind": "directional", "direction": [0.0, 0.15, -1.0], "intensity": 3.0,
                    "color": [1.0, 1.0, 1.0], "cast_shadow": True}],
        "camera": {"yaw": 0.0, "pitch": 0.0, "distance": 110.0, "target": [0.0, 0.0, 0.0], "fov_y": 30.0},
    }, "30x40 mm flap, 1.5-6 mm thick (thicker downwards), lit from behind (-Z), seen from +Z")


def _flap_thickness(y: np.ndarray) -> np.ndarray:
    return 1.5 + (20.0 - y) / 40.0 * 4.5


def stretch_plane_scene() -> SceneDef:
    """A 24 mm plane whose UVs are stretched 4x along u: one mm spans 4x the texels in u as in v."""
    pos, nrm, uv, idx = grid(48, 48, 6.0, 24.0, uv_rect=(0.02, 0.02, 0.98, 0.98))
    mesh = MeshData(pos, nrm, uv, idx, name="stretch-plane", albedo=np.ones((4, 4, 3), np.float32))
    return SceneDef("stretch-plane", mesh, {
        "lights": [{"kind": "beam", "direction": [0.0, 0.0, 1.0], "position": [0.0, 0.0, 0.0],
                    "beam_radius": 0.02, "intensity": 400.0, "color": [1.0, 1.0, 1.0], "cast_shadow": False}],
        "camera": {"yaw": 0.0, "pitch": 0.0, "distance": 60.0, "target": [0.0, 0.0, 0.0], "fov_y": 30.0},
    }, "6 x 24 mm plane mapped to a square UV island (u stretched 4x relative to v)")


def regions_plane_scene() -> SceneDef:
    """A plane split into two regions (left: cheeks, right: ears) with a shadow edge running
    across both along y = 0, for per-region kernel widths.

    The key light comes from above the camera (direction (0, 0.45, 1)), so the blade that casts
    the edge hangs higher than the edge (its lower edge at y = 11.25 mm, 25 mm above the plane);
    the camera looks up at the plane from below, under the blade, so the edge is in plain view;
    the lit side (intensity 0.8 at 24° incidence) stays below white."""
    from skinviewer.ground.constants import REGIONS
    light = np.array([0.0, 0.45, 1.0])
    height = 25.0
    y_edge = height * light[1] / light[2]     # blade edge that casts the plane's edge at y = 0
    plane = grid(64, 64, 60.0, 60.0, uv_rect=(0.02, 0.02, 0.78, 0.98))
    blade = _box((0.0, y_edge + 20.0, height), (80.0, 40.0, 2.0), uv_rect=(0.82, 0.02, 0.98, 0.40))
    pos, nrm, uv, idx = _merge([plane, blade])
    region = np.zeros((256, 256), np.uint8)
    region[:, :] = REGIONS.index("cheeks")
    region[:, 103:] = REGIONS.index("ears")  # u >= 0.40 (x >= 0 on the plane)
    albedo = np.empty((64, 64, 3), np.float32)
    albedo[:] = 1.0                           # white plane (like the other analysis scenes)
    albedo[:, 51:] = (0.25, 0.25, 0.27)       # the blade's island (u >= 0.80): dark grey
    mesh = MeshData(pos, nrm, uv, idx, name="regions-plane", albedo=albedo, region_map=region)
    return SceneDef("regions-plane", mesh, {
        "lights": [{"kind": "directional", "direction": light.tolist(), "intensity": 0.8,
                    "color": [1.0, 1.0, 1.0], "cast_shadow": True}],
        "camera": {"yaw": 0.0, "pitch": -30.0, "distance": 85.0, "target": [0.0, 2.0, 0.0], "fov_y": 30.0},
    }, "60 mm plane, left half region 'cheeks', right half 'ears', shadow edge along y = 0 from a blade "
       "25 mm above it, lit from above the camera")


# the head's eyeballs are the only texels of region "other" (non-skin): a glossy cornea gives
# the eyes their catchlight (Beckmann m 0.08) while the skin keeps its own lobe
HEAD_OVERRIDES = {"specular.per_region.other": {"m": 0.08, "rho_s": 0.6}}


def head_scene(detail: int = 1) -> SceneDef:
    from skinviewer.scene.head import default_head
    mesh = default_head(detail=detail)
    return SceneDef("head", mesh, dict(HEAD_OVERRIDES), "the project's generated head (millimetres)")


_BUILDERS = {
    "laser": laser_scene,
    "shadow-edge": shadow_edge_scene,
    "backlit-ear": backlit_ear_scene,
    "stretch-plane": stretch_plane_scene,
    "regions-plane": regions_plane_scene,
}


_PREFETCHED: dict[tuple[str, int], SceneDef] = {}


def prefetch_scene(name: str, detail: int = 1) -> SceneDef:
    """``build_scene`` now (the viewer: in a worker thread while its window shows the start-up screen);
    the next ``build_scene`` of the same name and detail takes this one instead of reading it again."""
    sd = build_scene(name, detail)
    _PREFETCHED[(name, int(detail))] = sd
    return sd


def build_scene(name: str, detail: int = 1) -> SceneDef:
    pre = _PREFETCHED.pop((name, int(detail)), None)
    if pre is not None:
        return pre
    if name == "head":
        return head_scene(detail)
    if name not in _BUILDERS:
        raise KeyError(f"unknown scene '{name}' (built-in scenes: {', '.join(SCENES)})")
    return _BUILDERS[name]()


def scene_overrides(name: str) -> dict:
    """The settings a built-in scene brings (its lights and camera); cheap for analysis scenes."""
    if name == "head":
        return dict(HEAD_OVERRIDES)
    return build_scene(name).overrides
