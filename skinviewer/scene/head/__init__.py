"""The project's own default head: a procedural adult head and neck with a UV atlas and skin maps.

Geometry in millimetres, Y up, facing +Z, origin near the middle of the head. Modules:
``landmarks`` (the anatomy as a table), ``shapes`` (SDF primitives), ``geometry`` (the implicit
head, eyes, ears), ``atlas`` (UV layout and its inverse), ``tessellate`` (triangles), ``paint``
(albedo, normal, specular and region maps). Generation is deterministic and cached as .npz.
"""
from __future__ import annotations

import io
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from skinviewer.scene.head.geometry import EYE_C, EYE_R, head_sdf
from skinviewer.scene.mesh import MeshData

__all__ = ["EYE_C", "EYE_R", "GENERATOR_VERSION", "default_head", "head_sdf"]

# bump whenever the shape, the atlas or the maps change: old cache files are then not reused
GENERATOR_VERSION = 6

# detail level -> (target edge length in mm, texture size)
LEVELS = {0: (10.5, 512), 1: (4.0, 1024), 2: (2.0, 2048)}

_ARRAY_KEYS = ("positions", "normals", "uvs", "indices", "albedo", "normal_map", "specular_map", "region_map")


def default_head(detail: int = 1, seed: int = 7, cache_dir: str | Path | None = None) -> MeshData:
    """The built-in head (mm, Y up, facing +Z), generated once per (detail, seed) and cached.

    detail 0: ~10k triangles and 512² maps (tests); 1: ~60k triangles and 1024² maps;
    2: ~200k triangles and 2048² maps. The seed only changes the skin's noise (albedo mottling,
    pores), never the shape.
    """
    if detail not in LEVELS:
        raise ValueError(f"head detail must be one of {sorted(LEVELS)}, got {detail}")
    path = _cache_path(detail, seed, cache_dir)
    arrays = _load_cache(path)
    notes = []
    if arrays is None:
        if os.path.lexists(path):  # there, but truncated, inconsistent or not a regular file
            notes.append(f"the cached head {path.name} did not validate: regenerated")
        arrays = _generate(detail, seed)
        _save_cache(path, arrays)
    return MeshData(notes=notes,
        positions=arrays["positions"], normals=arrays["normals"], uvs=arrays["uvs"],
        indices=arrays["indices"], mm_per_unit=1.0,
        albedo=arrays["albedo"].astype(np.float32),
        normal_map=arrays["normal_map"].astype(np.float32),
        specular_map=arrays["specular_map"].astype(np.float32),
        region_map=arrays["region_map"], name=f"default-head-d{detail}")


def _generate(detail: int, seed: int) -> dict[str, np.ndarray]:
    # generation only (scipy and the painting code): a cached head loads without them (issue 14 start-up)
    from skinviewer.scene.head.atlas import Atlas
    from skinviewer.scene.head.paint import paint
    from skinviewer.scene.head.tessellate import tessellate
    spacing, res = LEVELS[detail]
    atlas = Atlas()
    positions, normals, uvs, indices, table = tessellate(atlas, detail, spacing)
    maps = paint(atlas, table, res, seed)
    return {"positions": positions.astype(np.float32), "normals": normals,
            "uvs": uvs.astype(np.float32), "indices": indices.astype(np.uint32), **maps}


# ---------------------------------------------------------------------------------------------
# cache

def _cache_path(detail: int, seed: int, cache_dir: str | Path | None) -> Path:
    root = cache_dir or os.environ.get("SKINVIEWER_CACHE") or Path.home() / ".cache" / "skinviewer"
    return Path(root) / f"head-v{GENERATOR_VERSION}-d{detail}-s{seed}.npz"


def _load_cache(path: Path) -> dict[str, np.ndarray] | None:
    """The cached arrays, or None when missing, unreadable or inconsistent (then regenerate)."""
    if not path.is_file():
        return None
    try:
        from skinviewer.ground.files import read_regular_file
        data = read_regular_file(path, 2**31, what=f"cache entry {path}")  # never blocks, never unbounded
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {k: z[k] for k in _ARRAY_KEYS}
    except Exception:  # truncated zip, bad header, missing key...: all mean "regenerate"
        return None
    n = len(arrays["positions"])
    res = arrays["region_map"].shape
    ok = (arrays["positions"].shape == (n, 3) and arrays["normals"].shape == (n, 3)
          and arrays["uvs"].shape == (n, 2) and arrays["indices"].ndim == 2
          and arrays["indices"].shape[1] == 3 and int(arrays["indices"].max(initial=0)) < n
          and len(res) == 2 and arrays["albedo"].shape == (*res, 3)
          and arrays["normal_map"].shape == (*res, 3) and arrays["specular_map"].shape == (*res, 1)
          and all(np.all(np.isfinite(arrays[k])) for k in ("positions", "normals", "uvs")))
    return arrays if ok else None


def _save_cache(path: Path, arrays: dict[str, Any]) -> None:
    """Atomic write (temp file + os.replace); an unwritable cache only costs regeneration."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.stem, suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
        os.replace(tmp, path)
    except OSError:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
