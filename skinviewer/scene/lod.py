"""Levels of detail of a mesh, for frames where the head covers few pixels (issue 14: simulate only
what shows). Level k keeps about 1/4^k of the triangles, by quadric edge collapse
(fast-simplification, Garland & Heckbert 1997) with the open borders kept: a UV seam is a border of
split vertices, so every island keeps its outline in UV space. Collapses merge vertices into vertices
that already exist, and each surviving vertex keeps its own position, normal, UV and tangent, so
texture-space passes unwrap a level exactly where the full mesh would put those vertices."""
from __future__ import annotations

import numpy as np

from skinviewer.scene.mesh import MeshData

LOD_FACTOR = 4        # triangles shrink by this factor per level
MIN_LOD_TRIANGLES = 1000  # no level below this many triangles


def level_targets(n_triangles: int) -> list[int]:
    """The triangle count each level aims at; level 0 is the mesh itself."""
    out = [int(n_triangles)]
    while out[-1] // LOD_FACTOR >= MIN_LOD_TRIANGLES:
        out.append(out[-1] // LOD_FACTOR)
    return out


def surviving_vertex(n_vertices: int, collapses: np.ndarray) -> np.ndarray:
    """For each vertex, the vertex it was collapsed into in the end (itself if it survived).
    ``collapses[i] = (a, b)``: at step i, b was merged into a."""
    parent = np.arange(n_vertices)
    if len(collapses):
        parent[collapses[:, 1]] = collapses[:, 0]
    while True:  # follow chains b -> a -> ... to the survivor
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            return parent
        parent = nxt


def decimate(mesh: MeshData, target_triangles: int) -> MeshData:
    """A coarser copy of ``mesh`` with about ``target_triangles`` triangles (no maps)."""
    import fast_simplification  # compiled; imported only when a far frame asks for a level

    n = len(mesh.indices)
    if target_triangles >= n:
        return mesh
    pos64, tri32 = mesh.positions.astype(np.float64), mesh.indices.astype(np.int32)
    _, _, collapses = fast_simplification.simplify(pos64, tri32, target_count=int(target_triangles),
                                                   return_collapses=True, preserve_border=True)
    # the library's own replay gives the faces and, per input vertex, its output vertex
    _, faces, out_index = fast_simplification.replay_simplification(pos64, tri32, collapses)
    survivor = surviving_vertex(len(mesh.positions), np.asarray(collapses, dtype=np.int64).reshape(-1, 2))
    kept = np.flatnonzero(survivor == np.arange(len(survivor)))
    rep = np.zeros(int(out_index.max()) + 1, dtype=np.int64)
    rep[out_index[kept]] = kept  # output vertex -> the input vertex that survived as it
    tri = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    kept = rep
    assert mesh.tangents is not None, "MeshData sets its tangents"
    return MeshData(positions=mesh.positions[kept], normals=mesh.normals[kept], uvs=mesh.uvs[kept],
                    indices=tri.astype(np.uint32), tangents=mesh.tangents[kept], mm_per_unit=mesh.mm_per_unit,
                    name=f"{mesh.name} (LOD, {len(tri)} triangles)")
