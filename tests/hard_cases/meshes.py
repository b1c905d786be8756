"""Hard-case meshes written as OBJ files: degenerate and sliver triangles, one-texel UV islands,
planes at 1e-3 mm and 1e4 mm, a thin flap."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from skinviewer.scene.scenes import grid


def _write(path: Path, pos, uv, idx) -> Path:
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in pos]
    lines += [f"vt {float(u)!r} {float(v)!r}" for u, v in uv]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in idx]
    path.write_text("\n".join(lines) + "\n")
    return path


def _plane(n=8, size=40.0):
    pos, _, uv, idx = grid(n, n, size, size)
    return pos, uv, idx


def make(kind: str, folder: Path) -> Path:
    path = folder / f"{kind}.obj"
    if path.exists():
        return path
    if kind == "degenerate":
        pos, uv, idx = _plane()
        # zero-area triangles: repeated vertices and collinear ones, and a zero-area UV triangle
        extra_p = np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0], [1, 1, 0], [2, 2, 0], [3, 3, 0]], float)
        extra_uv = np.array([[0.5, 0.5]] * 3 + [[0.1, 0.1], [0.2, 0.2], [0.3, 0.3]])
        k = len(pos)
        pos, uv = np.vstack([pos, extra_p]), np.vstack([uv, extra_uv])
        idx = np.vstack([idx, [[k, k + 1, k + 2], [k + 3, k + 4, k + 5], [0, 0, 1]]])
    elif kind == "sliver":
        # a fan of needle triangles 1e-6 wide, 40 long, over a plane
        pos, uv, idx = _plane()
        k = len(pos)
        sl_p, sl_uv, sl_i = [], [], []
        for j in range(20):
            y = -15.0 + j * 1.5
            sl_p += [[-20, y, 0.01], [20, y, 0.01], [20, y + 1e-6, 0.01]]
            sl_uv += [[0.02, 0.5], [0.98, 0.5], [0.98, 0.5 + 1e-7]]
            sl_i.append([k + 3 * j, k + 3 * j + 1, k + 3 * j + 2])
        pos, uv, idx = np.vstack([pos, sl_p]), np.vstack([uv, sl_uv]), np.vstack([idx, sl_i])
    elif kind == "one-texel-islands":
        # 64 quads, each mapped into a UV square one texel wide at a 256 map
        ps, uvs, ids = [], [], []
        t = 1.0 / 256
        for i in range(8):
            for j in range(8):
                x, y = i * 5.0 - 20, j * 5.0 - 20
                k = len(ps)
                ps += [[x, y, 0], [x + 4, y, 0], [x + 4, y + 4, 0], [x, y + 4, 0]]
                u, v = (i * 30 + 5) * t, (j * 30 + 5) * t
                uvs += [[u, v], [u + t, v], [u + t, v + t], [u, v + t]]
                ids += [[k, k + 1, k + 2], [k, k + 2, k + 3]]
        pos, uv, idx = np.array(ps, float), np.array(uvs), np.array(ids)
    elif kind.startswith("plane-"):
        scale = float(kind.split("-", 1)[1])  # the plane's width in mm (mm_per_unit 1)
        pos, uv, idx = _plane(size=1.0)
        pos = pos * scale
    elif kind == "flap":
        # a 0.05 mm thick closed slab, 30 x 20 mm: front and back faces with their own UV islands
        f_p, _, f_uv, f_i = grid(6, 4, 30.0, 20.0, uv_rect=(0.02, 0.02, 0.48, 0.98), z=0.025)
        b_p, _, b_uv, b_i = grid(6, 4, 30.0, 20.0, uv_rect=(0.52, 0.02, 0.98, 0.98), z=-0.025, flip=True)
        pos, uv, idx = np.vstack([f_p, b_p]), np.vstack([f_uv, b_uv]), np.vstack([f_i, b_i + len(f_p)])
    else:
        raise ValueError(kind)
    return _write(path, pos, uv, idx)
