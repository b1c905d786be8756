"""Mesh data and loading (glTF/GLB/OBJ/PLY through trimesh), tangents, texture maps, framing."""
from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


class MeshError(ValueError):
    """A mesh that cannot be used, with a message saying why."""


@dataclass
class MeshData:
    """Triangle mesh with one UV set, in its own units (``mm_per_unit`` converts to millimetres).

    positions (N,3) f4, normals (N,3) f4 unit, uvs (N,2) f4 in [0,1], tangents (N,4) f4 (xyz, w =
    bitangent sign), indices (M,3) u4. Optional maps are float32 arrays (H,W,C) in [0,1] with row 0
    at v = 0 (OpenGL texture order): albedo sRGB-encoded RGB, normal tangent-space RGB encoded
    n*0.5+0.5, specular (H,W,1) intensity scale, region (H,W) uint8 region IDs (settings.REGIONS).
    """
    positions: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray
    indices: np.ndarray
    tangents: np.ndarray | None = None
    mm_per_unit: float = 1.0
    albedo: np.ndarray | None = None
    normal_map: np.ndarray | None = None
    specular_map: np.ndarray | None = None
    region_map: np.ndarray | None = None
    name: str = "mesh"
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        p64 = np.asarray(self.positions, dtype=np.float64)
        if not np.all(np.isfinite(p64)):
            raise MeshError(f"{self.name}: non-finite vertex positions")
        with np.errstate(over="ignore"):
            self.positions = np.ascontiguousarray(p64, dtype=np.float32)
        if not np.all(np.isfinite(self.positions)):
            raise MeshError(f"{self.name}: vertex positions up to {np.abs(p64).max():.3g} exceed the float32 "
                            "range the GPU uses (3.4e38); rescale the mesh and set scene.mm_per_unit")
        self.normals = np.ascontiguousarray(self.normals, dtype=np.float32)
        self.uvs = np.ascontiguousarray(self.uvs, dtype=np.float32)
        self.indices = np.ascontiguousarray(self.indices, dtype=np.uint32).reshape(-1, 3)
        if self.tangents is None:
            self.tangents = compute_tangents(self.positions, self.normals, self.uvs, self.indices)
        self.tangents = np.ascontiguousarray(self.tangents, dtype=np.float32)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.positions.min(axis=0), self.positions.max(axis=0)

    @property
    def center(self) -> np.ndarray:
        lo, hi = self.bounds
        return (lo + hi) * 0.5

    @property
    def radius(self) -> float:
        return float(np.linalg.norm(self.positions - self.center, axis=1).max())

    @property
    def frame(self) -> tuple[np.ndarray, float]:
        """(centre, radius) the camera frames by default: the head when the mesh has a neck or
        shoulders (``portrait_frame``), else the bounding sphere."""
        if getattr(self, "_frame", None) is None:
            self._frame = portrait_frame(self.positions)
        return self._frame
    def check_renderable(self) -> None:
        """MeshError saying why a mesh cannot be framed and shaded in float32: zero size, coordinates
        so large that squared lengths overflow in the shaders, or so small / so far from the origin
        that float32 cannot tell its vertices apart."""
        lo, hi = self.bounds
        extent = float(np.max(hi - lo))
        reach = float(np.abs(self.positions).max())
        if not extent > 0.0:
            raise MeshError(f"{self.name}: all vertices coincide (zero size): nothing to frame")
        if reach > MAX_COORDINATE:
            raise MeshError(f"{self.name}: coordinates reach {reach:.3g} mesh units; shading squares lengths in "
                            f"float32, so coordinates must stay within {MAX_COORDINATE:g}: rescale the mesh "
                            "and set scene.mm_per_unit")
        if extent < MIN_EXTENT:
            raise MeshError(f"{self.name}: the mesh is {extent:.3g} mesh units across; below {MIN_EXTENT:g} float32 "
                            "shading underflows: rescale the mesh and set scene.mm_per_unit")
        if extent < reach * 1e-5:
            raise MeshError(f"{self.name}: the mesh is {extent:.3g} units across but {reach:.3g} from the origin: "
                            "float32 cannot resolve it there; centre it near the origin")

    def replace(self, **kw) -> MeshData:
        return dataclasses.replace(self, **kw)

    def interleaved(self) -> np.ndarray:
        """(N, 12) float32: position, normal, uv, tangent — the vertex layout every pass uses."""
        assert self.tangents is not None, "set in __post_init__"
        return np.hstack([self.positions, self.normals, self.uvs, self.tangents]).astype(np.float32)


# float32 shading limits (see MeshData.check_renderable): squared lengths must neither overflow
# (3.4e38) nor sink into denormals (1.2e-38), with room for products of a few such terms
MAX_COORDINATE = 1e15
MIN_EXTENT = 1e-12
# files read as meshes / images: regular files only, at most this large
MAX_MESH_BYTES = 2 * 1024**3
MAX_IMAGE_BYTES = 1024**3
MAX_IMAGE_PIXELS = 8192 * 8192  # a map larger than the largest texture-space map helps nothing

VERTEX_FORMAT = "3f 3f 2f 4f"
VERTEX_ATTRS = ("in_position", "in_normal", "in_uv", "in_tangent")
UV_COVARIANCE_ATTR = "in_uv_covariance"  # a second buffer, bound only where a program reads it
CURVATURE_ATTR = "in_curvature"  # likewise: per-vertex curvature, mm^-1 (pre-integrated skin)
# likewise: the environment light's SH transfer vector, 25 floats padded to 7 vec4 (issue 32, lib/mesh_vs.glsl)
ENV_VIS_ATTRS = tuple(f"in_env_t{k}" for k in range(7))


def weld_ids(keys: np.ndarray, tol: float) -> np.ndarray:
    """Integer id per row of ``keys``, equal for rows within ``tol`` of each other (chains join).
    Pairs come from a k-d tree, not from rounding, so two copies of a vertex never split at a
    rounding boundary."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree
    k = np.asarray(keys, np.float64)
    n = len(k)
    pairs = cKDTree(k).query_pairs(tol, output_type="ndarray") if n else np.zeros((0, 2), np.int64)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1].astype(np.int64)


WELD_TOL = 1e-6  # copies of a vertex: within this fraction of the mesh's extent


def position_ids(positions: np.ndarray) -> np.ndarray:
    """weld_ids by position: one id per point of the surface, the same for every copy of a vertex
    (UV seams, split normals), within WELD_TOL of the mesh's largest extent."""
    P = np.asarray(positions, np.float64)
    return weld_ids(P, WELD_TOL * max(float(np.ptp(P, axis=0).max()), 1e-12) if len(P) else 1.0)


SEAM_CREASE_DEG = 40.0  # a split vertex's normal this far from its copies' mean is a crease: kept


def smooth_seam_normals(positions: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, int]:
    """Vertices split along a UV seam (copies at one position) whose normals differ: each copy takes
    their mean, unless one lies over SEAM_CREASE_DEG from it (a modelled crease). A smooth surface
    has one normal per point; exporters that average per UV island leave a step in the shading along
    every seam (the shared scan: 6 deg median, up to 34). Returns (normals, copies changed by > 1 deg)."""
    P = np.asarray(positions, np.float64)
    N = np.asarray(normals, np.float64)
    if len(P) < 2:
        return N, 0
    ids = position_ids(P)
    _, inv, count = np.unique(ids, return_inverse=True, return_counts=True)
    total = np.zeros((count.size, 3))
    np.add.at(total, inv, N)
    mean = _normalize_or(total, np.array([0.0, 0.0, 1.0]))[inv]
    cos = (N * mean).sum(1)
    crease = np.zeros(count.size, bool)
    np.logical_or.at(crease, inv, cos < np.cos(np.radians(SEAM_CREASE_DEG)))
    smooth = (count[inv] > 1) & ~crease[inv]
    out = np.where(smooth[:, None], mean, N)
    return out, int((smooth & (cos < np.cos(np.radians(1.0)))).sum())


def border_half_edges(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Half-edges (3 * triangle + corner k: the edge from corner k to k + 1) on a mesh border: their
    3D edge (vertices welded by position, so UV seams do not count) belongs to one triangle only. An
    edge collapsed by welding borders nothing."""
    P = np.asarray(positions, np.float64)
    F = np.asarray(indices, np.int64).reshape(-1, 3)
    if len(F) == 0:
        return np.zeros(0, np.int64)
    w = position_ids(P)[F]
    a, b = w[:, [0, 1, 2]].ravel(), w[:, [1, 2, 0]].ravel()
    keep = np.flatnonzero(a != b)
    edges = np.stack([np.minimum(a, b), np.maximum(a, b)], 1)[keep]
    _, inv, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    return keep[counts[inv.ravel()] == 1]


def is_closed(positions: np.ndarray, indices: np.ndarray) -> bool:
    """True when no triangle edge is a border (border_half_edges). The inside of a closed surface
    cannot be seen from outside it: a back face the camera meets there has won a depth fight with
    the near side (thin folds at grazing angles) or comes from a self-intersection."""
    return len(np.asarray(indices).reshape(-1)) > 0 and len(border_half_edges(positions, indices)) == 0


def culls_back_faces(mode: str, closed: bool) -> bool:
    """``scene.back_faces`` resolved for a mesh: cull, show, or auto (cull when the mesh is closed)."""
    return mode == "cull" or (mode == "auto" and closed)


def vertex_normals(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals; degenerate or isolated vertices get +Z (never NaN)."""
    p = positions.astype(np.float64)
    tri = p[indices]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n = np.zeros_like(p)
    for k in range(3):
        np.add.at(n, indices[:, k], fn)
    return _normalize_or(n, np.array([0.0, 0.0, 1.0])).astype(np.float32)


def _normalize_or(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(v, axis=1, keepdims=True)
    ok = length[:, 0] > 1e-20
    out = np.empty_like(v)
    out[ok] = v[ok] / length[ok]
    out[~ok] = fallback
    return out


def compute_tangents(positions, normals, uvs, indices) -> np.ndarray:
    """Per-vertex tangents from UV gradients (Lengyel's method), Gram-Schmidt against the normal.

    Returns (N,4): xyz tangent, w = handedness. Degenerate UV triangles contribute nothing; a vertex
    with no usable tangent gets an arbitrary one perpendicular to its normal.
    """
    p = positions.astype(np.float64)
    t = uvs.astype(np.float64)
    n = normals.astype(np.float64)
    i0, i1, i2 = indices[:, 0], indices[:, 1], indices[:, 2]
    e1, e2 = p[i1] - p[i0], p[i2] - p[i0]
    d1, d2 = t[i1] - t[i0], t[i2] - t[i0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    good = np.abs(det) > 1e-14
    r = np.zeros_like(det)
    r[good] = 1.0 / det[good]
    sdir = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r[:, None]
    tdir = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r[:, None]
    tan1 = np.zeros_like(p)
    tan2 = np.zeros_like(p)
    for idx in (i0, i1, i2):
        np.add.at(tan1, idx, sdir)
        np.add.at(tan2, idx, tdir)
    tt = tan1 - n * np.sum(n * tan1, axis=1, keepdims=True)
    # fallback: any vector perpendicular to n
    helper = np.where(np.abs(n[:, 0:1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    fallback = np.cross(n, helper)
    fallback = _normalize_or(fallback, np.array([1.0, 0.0, 0.0]))
    length = np.linalg.norm(tt, axis=1, keepdims=True)
    ok = length[:, 0] > 1e-12
    tt[ok] /= length[ok]
    tt[~ok] = fallback[~ok]
    w = np.where(np.sum(np.cross(n, tt) * tan2, axis=1) < 0.0, -1.0, 1.0)
    return np.hstack([tt, w[:, None]]).astype(np.float32)


# ---------------------------------------------------------------------------------------------
# loading

def _read_image(path: str | Path, mode: str) -> np.ndarray:
    """A map from an image file: regular files only, size-limited, any bit depth (see _image_array)."""
    import io

    from PIL import Image, UnidentifiedImageError

    from skinviewer.ground.files import FileReadError, read_regular_file
    try:
        data = read_regular_file(path, MAX_IMAGE_BYTES, what=f"image {path}")
    except FileReadError as exc:
        raise MeshError(str(exc)) from None
    if data[:4] == b"\x76\x2f\x31\x01":
        raise MeshError(f"cannot read image {path}: it is OpenEXR (linear HDR); maps must be PNG, JPEG, TIFF, "
                        "BMP or TGA (8 or 16 bits)")
    try:
        img = Image.open(io.BytesIO(data))
        w, h = img.size
        if w * h > MAX_IMAGE_PIXELS:
            raise MeshError(f"image {path} is {w}x{h} ({w * h / 1e6:.0f} megapixels); the limit is "
                            f"{MAX_IMAGE_PIXELS / 1e6:.0f} megapixels (8192x8192)")
        img.load()
    except Image.DecompressionBombError as exc:
        raise MeshError(f"image {path} is too large to decode safely ({exc})") from None
    except UnidentifiedImageError:
        raise MeshError(f"cannot read image {path}: not an image format Pillow reads (PNG, JPEG, TIFF, BMP, "
                        "TGA, ...)") from None
    except (OSError, ValueError, SyntaxError) as exc:
        raise MeshError(f"cannot read image {path}: {exc}") from None
    return _image_array(img, mode)


def _image_array(img, mode: str) -> np.ndarray:
    """A PIL image as a map array, row 0 at v = 0 (images store their top row first).
    ``mode`` "L": uint8 (H, W) (region IDs; 16-bit images are rounded to 8 bits, not clipped);
    "RGB"/"RGBA": float32 in [0, 1] of the image's own bit depth (16-bit PNGs stay 16-bit)."""
    from PIL import ImageOps
    try:
        img = ImageOps.exif_transpose(img)  # a JPEG's EXIF orientation, as every image viewer shows it
    except Exception:  # noqa: BLE001, S110 - a malformed EXIF block: the pixels as stored
        pass
    arr = _unit_float(img)  # (H, W, C) float32 in [0, 1]
    if mode == "L":
        arr8 = np.rint(arr[..., 0] * 255.0).astype(np.uint8)
        return np.ascontiguousarray(arr8[::-1])  # row 0 at v = 0
    want = len(mode)
    c = arr.shape[2]
    if c in (1, 2):  # grey (+ alpha)
        grey = arr[..., :1]
        arr = np.concatenate([grey, grey, grey] + ([arr[..., 1:2]] if c == 2 else []), axis=2)
        c = arr.shape[2]
    if want == 3:
        arr = arr[..., :3]
    elif want == 4 and c == 3:
        arr = np.concatenate([arr, np.ones_like(arr[..., :1])], axis=2)
    return np.ascontiguousarray(arr[::-1], dtype=np.float32)


def _unit_float(img) -> np.ndarray:
    """Pixels as float32 (H, W, C) in [0, 1], dividing by the maximum of the image's bit depth:
    8-bit modes by 255, 16-bit ("I;16*", and "I" as Pillow opens 16-bit greyscale PNGs) by 65535,
    32-bit float ("F") clipped to [0, 1]; palette and other modes through RGB(A)."""
    m = img.mode
    if m.startswith("I;16"):
        a = np.asarray(img).astype(np.float32) / 65535.0
    elif m == "I":
        a = np.asarray(img).astype(np.float64)
        top = 65535.0 if a.max(initial=0) <= 65535 else float(2**31 - 1)
        a = (a / top).astype(np.float32)
    elif m == "F":
        a = np.nan_to_num(np.asarray(img, dtype=np.float32), nan=0.0, posinf=1.0, neginf=0.0)
    elif m in ("L", "LA", "RGB", "RGBA"):
        a = np.asarray(img).astype(np.float32) / 255.0
    else:
        conv = img.convert("RGBA" if ("A" in m or "transparency" in img.info) else "RGB")
        a = np.asarray(conv).astype(np.float32) / 255.0
    a = np.clip(a, 0.0, 1.0)
    return a[..., None] if a.ndim == 2 else a


def load_texture_maps(mesh: MeshData, albedo=None, normal=None, specular=None, region=None) -> MeshData:
    kw = {}
    if albedo:
        kw["albedo"] = _read_image(albedo, "RGB")
    if normal:
        kw["normal_map"] = _read_image(normal, "RGB")
    if specular:
        kw["specular_map"] = _read_image(specular, "L").astype(np.float32)[..., None] / 255.0
    if region:
        kw["region_map"] = _read_image(region, "L").astype(np.uint8)
    return mesh.replace(**kw) if kw else mesh


def load_mesh(path: str | Path, auto_uv: bool = True) -> MeshData:
    """Load a glTF/GLB/OBJ/PLY file. A mesh without UVs gets an automatic xatlas atlas when
    ``auto_uv`` (the default, and said in ``notes``); otherwise it is refused with MeshError.

    trimesh is given bytes, never a path: the file and everything it references (an OBJ's
    ``mtllib`` and ``map_Kd``, a glTF's buffers and image URIs) are read by ``_Resolver`` through
    ``files.read_regular_file`` (regular files only, size-limited, a FIFO never blocks); a reference
    that cannot be read is named in ``notes`` (a texture) or in the MeshError (a buffer)."""
    import io

    import trimesh

    from skinviewer.ground.files import FileReadError, read_regular_file
    p = Path(path)
    try:
        data = read_regular_file(p, MAX_MESH_BYTES, what=f"mesh {p}")
    except FileReadError as exc:
        raise MeshError(str(exc) if os.path.lexists(p) else f"mesh file not found: {p}") from None
    ext = p.suffix.lower().lstrip(".")
    notes: list[str] = []
    non_images: set[str] = set()
    if ext in ("obj", "mtl"):
        data = _utf8_text(data)
        non_images = _obj_mtllibs(data)
    elif ext in ("gltf", "glb"):
        data, non_images = _gltf_prepared(data, ext, p, notes)
    resolver = _Resolver(p, non_images)
    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=ext or None,
                              resolver=resolver,  # type: ignore[arg-type]  # duck-typed: trimesh calls only get()
                              process=False)
    except Exception as exc:  # noqa: BLE001 - trimesh raises many kinds
        why = "; ".join(resolver.failed.values()) or str(exc) or type(exc).__name__
        raise MeshError(f"cannot read mesh {p}: {why}") from None
    for why in resolver.failed.values():
        notes.append(f"{why}: that texture is not used")
    try:
        return _mesh_of(loaded, p, auto_uv, notes)
    except MeshError:
        raise
    except (IndexError, ValueError, TypeError, AttributeError, KeyError, OverflowError) as exc:
        # what a malformed file can still raise past the checks (the fuzz in tests/test_mesh_fuzz.py)
        raise MeshError(f"cannot read mesh {p}: {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}") \
            from None


def _check_faces(g, p: Path) -> None:
    """MeshError unless the triangles index the vertices (a malformed file can point anywhere)."""
    f = np.asarray(g.faces)
    n = len(g.vertices)
    if f.size and (f.ndim != 2 or f.shape[1] != 3 or f.dtype.kind not in "iu" or int(f.min()) < 0
                   or int(f.max()) >= n):
        raise MeshError(f"{p}: triangle indices reach {int(f.max()) if f.size and f.dtype.kind in 'iu' else '?'} "
                        f"but the mesh has {n} vertices")


def _mesh_of(loaded, p: Path, auto_uv: bool, notes: list[str]) -> MeshData:
    """MeshData from what trimesh loaded (see load_mesh)."""
    import trimesh
    if isinstance(loaded, trimesh.Scene):
        geoms = [g for g in loaded.dump() if isinstance(g, trimesh.Trimesh)] if loaded.geometry else []
        geoms = [g for g in geoms if len(g.faces)]
        for g in geoms:
            _check_faces(g, p)
        if not geoms:
            raise MeshError(f"{p} contains no triangle mesh")
        tm, uv = _joined(geoms)
    elif isinstance(loaded, trimesh.Trimesh):
        _check_faces(loaded, p)
        tm = loaded
        uv = _uv_of(tm)
    else:
        raise MeshError(f"{p} is not a triangle mesh (got {type(loaded).__name__})")
    if len(tm.faces) == 0:
        raise MeshError(f"{p} has no triangles")
    positions = np.asarray(tm.vertices, dtype=np.float64)
    indices = np.asarray(tm.faces, dtype=np.int64)
    if not np.all(np.isfinite(positions)):
        raise MeshError(f"{p} has non-finite vertex positions")
    if uv is None:
        if not auto_uv:
            raise MeshError(f"{p} has no texture coordinates (UVs); texture-space techniques need them. "
                            "Add UVs in a modelling tool, or load with automatic UVs (xatlas).")
        indices, flipped = _outward_winding(positions, indices)
        if flipped:
            notes.append(flipped)
        # normals of the welded surface, then split with its vertices: each chart's copy of a vertex
        # keeps the one normal (computed per chart they step at every chart border: stair-step lines)
        welded_normals = vertex_normals(positions, indices)
        positions, indices, uv, vmapping = _xatlas_uvs(positions, indices, p)
        normals = welded_normals[vmapping]
        notes.append("no UVs in the file: generated a UV atlas with xatlas")
    else:
        n = getattr(tm, "vertex_normals", None)
        normals = np.asarray(n, dtype=np.float64) if n is not None and len(n) == len(positions) else None
        indices, flipped = _outward_winding(positions, indices)
        if flipped:
            notes.append(flipped)
        if normals is None or not np.all(np.isfinite(normals)):
            normals = vertex_normals(positions, indices)
        else:
            normals = _normalize_or(normals, np.array([0.0, 0.0, 1.0]))
            if flipped and float((normals * vertex_normals(positions, indices)).sum()) < 0.0:
                normals = -normals  # the file's normals pointed inwards with its winding
        normals, split = smooth_seam_normals(positions, normals)
        if split:
            notes.append(f"normals made continuous at {split} vertices split along UV seams (the file's "
                         "normals differed there: a shading line along each seam)")
    albedo, normal_map = _embedded_textures(tm if uv is not None else None, notes)
    uv = np.asarray(uv, dtype=np.float64)
    bad = ~np.isfinite(uv)
    if bad.any():
        uv[bad] = 0.0
        notes.append("non-finite UVs replaced by 0")
    if uv.min() < -1e-3 or uv.max() > 1.001:
        notes.append("UVs outside [0,1] wrap; texture-space passes use their fractional part")
        uv = uv - np.floor(uv)
    return MeshData(positions=positions, normals=normals, uvs=uv, indices=indices, name=p.stem, notes=notes,
                    albedo=albedo, normal_map=normal_map)


def signed_volume(positions: np.ndarray, indices: np.ndarray) -> float:
    """Volume enclosed by a closed triangle mesh, positive when its triangles wind counter-clockwise
    seen from outside (the glTF/OBJ convention): the sum of det(v0, v1, v2) / 6 (divergence theorem)."""
    P = np.asarray(positions, np.float64)
    F = np.asarray(indices, np.int64).reshape(-1, 3)
    c = P.mean(axis=0) if len(P) else np.zeros(3)
    a, b, d = P[F[:, 0]] - c, P[F[:, 1]] - c, P[F[:, 2]] - c
    return float(np.einsum("ij,ij->i", a, np.cross(b, d)).sum() / 6.0)


def _outward_winding(positions: np.ndarray, indices: np.ndarray) -> tuple[np.ndarray, str]:
    """A closed mesh whose triangles wind clockwise seen from outside (negative signed volume)
    renders inside out with back faces culled: its winding is reversed, and the note says so."""
    if len(indices) < 4 or not is_closed(positions, indices):
        return indices, ""
    if signed_volume(positions, indices) >= 0.0:
        return indices, ""
    return indices[:, [0, 2, 1]].copy(), ("the closed mesh's triangles wound inwards (negative volume: it "
                                           "would render inside out); their winding was reversed")


class _Resolver:
    """What trimesh reads besides the mesh file (OBJ ``mtllib``/``map_Kd``, glTF buffers and image
    URIs): through ``files.read_regular_file`` only, inside the mesh's folder (as trimesh's own
    resolver), images checked from their header (format, pixel count) before trimesh decodes them,
    all of it within MAX_MESH_BYTES together. ``failed`` maps each reference not read to why."""

    def __init__(self, mesh_path: Path, non_images: set[str]):
        self.folder = Path(os.path.abspath(mesh_path)).parent
        self.mesh = mesh_path
        self.non_images = non_images
        self.failed: dict[str, str] = {}
        self.read = 0

    def _path(self, name: str) -> Path:
        from urllib.parse import unquote
        clean = unquote(name.strip())
        parent = self.folder.resolve()
        path = (parent / clean).resolve()
        if not path.is_relative_to(parent):
            raise MeshError(f"'{name}' is outside the mesh's folder {self.folder}")
        return path

    def get(self, name: str) -> bytes:
        from skinviewer.ground.files import FileReadError, read_regular_file
        image = name not in self.non_images
        what = f"{'texture' if image else 'file'} {name!r} referenced by {self.mesh.name}"
        try:
            path = self._path(name)
            data = read_regular_file(path, min(MAX_IMAGE_BYTES if image else MAX_MESH_BYTES,
                                               MAX_MESH_BYTES - self.read), what=what)
            self.read += len(data)
            if image:
                _check_image_bytes(data, what)
            elif name.lower().endswith(".mtl"):
                data = _utf8_text(data)
        except (FileReadError, MeshError) as exc:
            msg = str(exc)
            if isinstance(exc, MeshError) and not msg.startswith("cannot"):
                msg = f"cannot read {what}: {msg}"
            self.failed[name] = msg
            raise FileNotFoundError(msg) from None
        return data

    __getitem__ = get

    def namespaced(self, namespace: str) -> _Resolver:
        return self

    def write(self, name, data):  # trimesh's loaders never write; exporting does not come through here
        raise PermissionError("the mesh loader does not write files")

    def keys(self):
        return iter(())


def _check_image_bytes(data: bytes, what: str) -> None:
    """MeshError unless ``data`` is an image Pillow reads within MAX_IMAGE_PIXELS (header only)."""
    import io

    from PIL import Image
    if data[:4] == b"\x76\x2f\x31\x01":
        raise MeshError(f"cannot read {what}: it is OpenEXR (linear HDR); maps must be PNG, JPEG, TIFF, "
                        "BMP or TGA (8 or 16 bits)")
    try:
        with Image.open(io.BytesIO(data)) as img:
            w, h = img.size
    except Exception:  # noqa: BLE001 - Pillow raises many kinds for a malformed header
        raise MeshError(f"cannot read {what}: not an image format Pillow reads (PNG, JPEG, TIFF, BMP, TGA, ...)") \
            from None
    if w * h > MAX_IMAGE_PIXELS:
        raise MeshError(f"cannot read {what}: {w}x{h} ({w * h / 1e6:.0f} megapixels) is over the "
                        f"{MAX_IMAGE_PIXELS / 1e6:.0f} megapixel limit")


def _utf8_text(data: bytes) -> bytes:
    """OBJ/MTL text as UTF-8: files in another 8-bit encoding are read as Latin-1 (their keywords and
    numbers are ASCII either way), so trimesh never guesses an encoding."""
    try:
        data.decode("utf-8")
        return data
    except UnicodeDecodeError:
        return data.decode("latin-1").encode("utf-8")


def _obj_mtllibs(data: bytes) -> set[str]:
    names = set()
    for line in data.decode("utf-8", "replace").splitlines():
        s = line.strip()
        if s[:7].lower() == "mtllib ":
            names.add(s[7:].strip())
            names.update(s.split()[1:])
    return names


def _gltf_prepared(data: bytes, ext: str, p: Path, notes: list[str]) -> tuple[bytes, set[str]]:
    """A glTF (or GLB) whose primitives with TEXCOORD_0 but no material get a plain one: trimesh keeps
    a primitive's UVs only when it has a material. Also the buffer URIs (not images). The JSON is
    rewritten only when a primitive needed it."""
    import json
    import struct
    try:
        if ext == "glb":
            if len(data) < 20 or data[:4] != b"glTF":
                raise ValueError("not a GLB file (no 'glTF' header)")
            clen, ctype = struct.unpack_from("<II", data, 12)
            if ctype != 0x4E4F534A or 20 + clen > len(data):
                raise ValueError("the GLB's first chunk is not its JSON")
            tree = json.loads(data[20:20 + clen].decode("utf-8"))
        else:
            tree = json.loads(data.decode("utf-8"))
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise MeshError(f"cannot read mesh {p}: {exc}") from None
    if not isinstance(tree, dict):
        raise MeshError(f"cannot read mesh {p}: the glTF JSON is not an object")
    buffers = {b["uri"] for b in tree.get("buffers", []) if isinstance(b, dict) and isinstance(b.get("uri"), str)}
    changed = False
    meshes = tree.get("meshes", [])
    for m in meshes if isinstance(meshes, list) else []:
        for prim in (m.get("primitives", []) if isinstance(m, dict) else []):
            if isinstance(prim, dict) and "material" not in prim \
                    and "TEXCOORD_0" in (prim.get("attributes") or {}):
                mats = tree.setdefault("materials", [])
                if not isinstance(mats, list):
                    continue
                if "_skinviewer_plain" not in tree:
                    mats.append({"name": "skinviewer_plain"})
                    tree["_skinviewer_plain"] = len(mats) - 1
                prim["material"] = tree["_skinviewer_plain"]
                changed = True
    if not changed:
        return data, buffers
    tree.pop("_skinviewer_plain", None)
    text = json.dumps(tree).encode("utf-8")
    if ext == "glb":
        text += b" " * (-len(text) % 4)
        rest = data[20 + clen:]
        body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
        return b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body, buffers
    return text, buffers


def _joined(geoms) -> tuple:
    """One mesh from a scene's (already transformed) geometries, keeping each one's own UVs (trimesh's
    concatenate would pack differing materials into an atlas and move the UVs); the first geometry's
    material stands for all (see _embedded_textures). UVs are None unless every geometry has them."""
    import trimesh
    if len(geoms) == 1:
        return geoms[0], _uv_of(geoms[0])
    uvs = [_uv_of(g) for g in geoms]
    offsets = np.cumsum([0] + [len(g.vertices) for g in geoms])
    vertices = np.concatenate([np.asarray(g.vertices, np.float64) for g in geoms])
    faces = np.concatenate([np.asarray(g.faces, np.int64) + o for g, o in zip(geoms, offsets)])
    normals = np.concatenate([np.asarray(g.vertex_normals, np.float64) for g in geoms])
    tm = trimesh.Trimesh(vertices=vertices, faces=faces, vertex_normals=normals, process=False)
    if all(u is not None for u in uvs):
        uv = np.concatenate([np.asarray(u, np.float64) for u in uvs])
        first = next((g.visual.material for g in geoms if getattr(getattr(g, "visual", None), "material", None)
                      is not None), None)
        tm.visual = trimesh.visual.TextureVisuals(uv=uv, material=first)
        return tm, uv
    return tm, None


def _embedded_textures(tm, notes: list[str]):
    """Base-colour and normal textures the file itself carries (glTF PBR material, OBJ map_Kd)."""
    material = getattr(getattr(tm, "visual", None), "material", None)
    if material is None:
        return None, None
    base = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
    normal = getattr(material, "normalTexture", None)
    if base is not None and _is_placeholder(base):
        # trimesh gives an OBJ without a material (or with a missing .mtl) a 2x2 grey image: not a texture
        base = None
        notes.append("the file has no material texture: the default skin tone is used as albedo")
    albedo = _image_array(base, "RGB") if base is not None else None
    nmap = _image_array(normal, "RGB") if normal is not None else None
    for what, arr in (("base colour", albedo), ("normal", nmap)):
        if arr is not None:
            notes.append(f"using the file's {what} texture ({arr.shape[1]}x{arr.shape[0]})")
    return albedo, nmap


def _is_placeholder(img) -> bool:
    """trimesh's stand-in material image (trimesh.visual.material.empty_material): tiny, uniform grey 100."""
    try:
        if img.size[0] > 2 or img.size[1] > 2:
            return False
        a = np.asarray(img.convert("RGB"))
    except Exception:
        return False
    return bool(np.all(a == 100))


def _uv_of(tm) -> np.ndarray | None:
    uv = getattr(getattr(tm, "visual", None), "uv", None)
    if uv is None or len(uv) != len(tm.vertices):
        return None
    return np.asarray(uv)


def _xatlas_uvs(positions, indices, p):
    try:
        import xatlas
    except ImportError:
        raise MeshError(f"{p} has no UVs and the xatlas package (automatic UVs) is not installed: "
                        "pip install xatlas") from None
    vmapping, new_idx, uvs = xatlas.parametrize(positions.astype(np.float32), indices.astype(np.uint32))
    vmapping = np.asarray(vmapping, dtype=np.int64)
    return positions[vmapping], new_idx.astype(np.int64), uvs, vmapping


def framing_distance(radius: float, fov_y_deg: float, margin: float = 1.15) -> float:
    """Camera distance at which a sphere of ``radius`` fills the vertical field of view."""
    half = np.radians(fov_y_deg) * 0.5
    return float(radius * margin / max(np.sin(half), 1e-3))


def portrait_frame(positions: np.ndarray, slices: int = 48) -> tuple[np.ndarray, float]:
    """Centre and radius of the part of a Y-up mesh a portrait shows, without face detection.

    A bust or a figure is wide at the head, narrow at the neck and wide again at the shoulders;
    the horizontal (x) width of horizontal slices shows it. The neck is the narrowest slice below
    the widest slice of the upper half; when it is clearly narrower than the head (< 0.8) and not
    the bottom of the mesh, the frame is everything above it (head and a little neck). A mesh much
    taller than wide without a neck is framed on its top (a square of its width). Otherwise the
    bounding sphere (centre of the bounds, farthest vertex)."""
    p = np.asarray(positions, dtype=np.float64)
    lo, hi = p.min(axis=0), p.max(axis=0)
    height = hi[1] - lo[1]
    keep = p
    if height > 0 and len(p) >= 8 * slices:
        edges = np.linspace(lo[1], hi[1], slices + 1)
        idx = np.clip(((p[:, 1] - lo[1]) / height * slices).astype(int), 0, slices - 1)
        order = np.argsort(idx, kind="stable")
        bounds = np.searchsorted(idx[order], np.arange(slices + 1))
        width = np.zeros(slices)
        for i in range(slices):
            xs = p[order[bounds[i]:bounds[i + 1]], 0]
            if len(xs) >= 4:  # robust extent: ignore a few stray vertices
                width[i] = np.percentile(xs, 99) - np.percentile(xs, 1)
        top = np.arange(slices // 2, slices)
        i_head = top[np.argmax(width[top])]
        below = np.arange(0, i_head)
        below = below[width[below] > 0]
        girth = max(np.ptp(p[:, 0]), np.ptp(p[:, 2]))
        if len(below) and width[i_head] > 0:
            i_neck = below[np.argmin(width[below])]
            if width[i_neck] < 0.8 * width[i_head] and i_neck > slices // 20:
                keep = p[p[:, 1] >= edges[i_neck]]
            elif height > 1.6 * girth:
                keep = p[p[:, 1] >= hi[1] - girth]
        elif height > 1.6 * girth:
            keep = p[p[:, 1] >= hi[1] - girth]
    c = 0.5 * (keep.min(axis=0) + keep.max(axis=0))
    return c, float(np.linalg.norm(keep - c, axis=1).max())
