"""What the renderer holds on the GPU, honestly counted (issue 14): every graph's outputs, the
pool's free scratch textures, depth buffers, the scene's maps (with their mip chains) and mesh
buffers. Sizes from each object's format (components x bytes), not from what a pass declared."""
from __future__ import annotations

from typing import TYPE_CHECKING

import moderngl

if TYPE_CHECKING:
    from skinviewer.engine.renderer import Renderer

_BYTES = {"f1": 1, "f2": 2, "f4": 4, "i1": 1, "u1": 1, "i2": 2, "u2": 2, "i4": 4, "u4": 4}
DEPTH_BYTES = 4  # a depth renderbuffer: 24-bit depth padded (or D24S8) per texel


def texture_bytes(tex: moderngl.Texture, mipmapped: bool = False) -> int:
    w, h = tex.size
    n: int = w * h * tex.components * _BYTES.get(tex.dtype, 4)
    return n * 4 // 3 if mipmapped else n


def renderer_memory(renderer: Renderer) -> dict[str, int]:
    """Bytes by kind: graph outputs, free pooled scratch, depth buffers, scene maps, mesh buffers."""
    out = {"graph outputs": 0, "pooled scratch (free)": 0, "depth buffers": 0, "scene maps": 0,
           "mesh buffers": 0}
    depth = {}
    for g in renderer.graphs.values():
        out["graph outputs"] += sum(texture_bytes(t) for t in g.res.textures.values())
        for size, rb in g.res.depth.items():
            depth[rb.glo] = size[0] * size[1] * DEPTH_BYTES
    out["depth buffers"] = sum(depth.values())
    for lst in renderer.pool._free.values():
        out["pooled scratch (free)"] += sum(texture_bytes(t) for t in lst)
    sc = renderer.scene.gpu if renderer.scene is not None else None
    if sc is not None:
        for tex in (sc.albedo, sc.normal_map, sc.specular_map):
            out["scene maps"] += texture_bytes(tex, mipmapped=True)
        out["scene maps"] += texture_bytes(sc.region_map)
        out["mesh buffers"] = sc.mesh_bytes()
    return out
