"""deon.view_cull (issue 27; notes/deon_light_move.md section 17): d'Eon's texture-space passes make only
the tiles (VIEW_TILE texels a side) of their maps that the current view reads, transitively.

Texture space shades every texel of the atlas, though a view reads only some (seed 001 around line 765: no
depth culling / early-z in texture space). The needed sets, from the final pass backwards (stage_needs):
  * F: the tiles of the triangles that may give a fragment (not wholly past one clip plane, and front-facing
    where the view culls back faces: culls_back_faces), each triangle's UV box +2 texels (bilinear reads):
    the diffuse sum and the visibility the final pass reads;
  * the diffuse sum reads its full-size blurs at the same texel, the half-size ones and the transmitted
    light bilinearly (F at half size, a tile wider);
  * the transmitted light reads the blurs and the irradiance only at the TSM's stored uv (lib/tsm_transmit
    .glsl, t.gb): L, every TSM texel's uv, read back from the TSM once per light pose (exact, not bounded by
    the 2^-24 cut's thickness);
  * a blur reads its input around each texel's island texel: per draw (seam fill, H, fill, V) its taps' reach
    at the stretch map's largest stretch, the gutter map's island texel and the seam map's partner texel
    (tile links read from those maps); the summed step its inner texels and block rings;
  * the irradiance (and its gutter dilation) the union of what its readers read.
Each pass declares the frame's F (a TileCover tagged with the chain, cull_chain) and draws only its own
tiles not yet held (kernel/coverage: a camera move makes the tiles it has not made; a light move all anew)."""
from __future__ import annotations

import math

import moderngl
import numpy as np

from skinviewer.kernel.coverage import TileCover
from skinviewer.passes.rules import LOD_HYSTERESIS, LOD_TRIANGLES_PER_PX, screen_diameter_px
from skinviewer.passes.texture_space import TILE, drop_other_scenes, read_gutter, rect_tiles
from skinviewer.scene.mesh import culls_back_faces

# the tile of the needed sets and of the culled draws' rectangle lists: half of texture_space.TILE, so a one-texel
# read past a set (a bilinear tap, a seam partner) adds 8 texels, not 16 (the half-size maps are 32 tiles across)
VIEW_TILE = 8
UV_MARGIN = 2.0  # texels around a triangle's UV box: a bilinear read at its edge (1.5) and float rounding
CLIP_MARGIN = 0.02  # of w: a triangle is off-screen only when all its corners lie this far past one plane
FACING_EPS = 1e-5  # relative: a triangle this close to edge-on counts as facing (GL's float32 winding)


def tiles_of(n: int) -> int:
    return -(-n // VIEW_TILE)


def _tri_tiles(scene, n: int, state) -> tuple[np.ndarray, np.ndarray]:
    """(triangle index, tile index) pairs: the tiles of each triangle's UV box (+UV_MARGIN texels) at an n x n
    map. Once per scene and size (kept in the graph's state)."""
    key = ("view_cull_tri_tiles", id(scene), n)
    hit = state.get(key)
    if hit is not None:
        return hit
    for k in [k for k in state if isinstance(k, tuple) and k[:1] == ("view_cull_tri_tiles",) and k[1] != id(scene)]:
        del state[k]
    m = scene.mesh
    nt = tiles_of(n)
    uv = np.asarray(m.uvs, np.float64)[np.asarray(m.indices)]  # (T, 3, 2): u -> x, v -> y (row)
    lo = np.clip(np.floor((uv.min(axis=1) * n - UV_MARGIN) / VIEW_TILE), 0, nt - 1).astype(np.int64)
    hi = np.clip(np.floor((uv.max(axis=1) * n + UV_MARGIN) / VIEW_TILE), 0, nt - 1).astype(np.int64)
    sx, sy = hi[:, 0] - lo[:, 0] + 1, hi[:, 1] - lo[:, 1] + 1
    count = sx * sy
    tri = np.repeat(np.arange(len(uv)), count)
    start = np.repeat(np.cumsum(count) - count, count)
    k = np.arange(int(count.sum())) - start
    w = np.repeat(sx, count)
    tx, ty = np.repeat(lo[:, 0], count) + k % w, np.repeat(lo[:, 1], count) + k // w
    state[key] = (tri, ty * nt + tx)
    return state[key]


def facing(positions: np.ndarray, indices: np.ndarray, clip_matrix: np.ndarray, cull_back: bool) -> np.ndarray:
    """Per triangle: whether it may give a fragment drawn with the column-vector GL matrix ``clip_matrix``:
    not wholly past one clip plane (CLIP_MARGIN), and with ``cull_back`` counter-clockwise on screen (GL's
    front face) or nearly edge-on (FACING_EPS); a corner behind the eye keeps it."""
    p = np.asarray(positions, np.float64)
    clip = np.hstack([p, np.ones((len(p), 1))]) @ np.asarray(clip_matrix, np.float64).T
    x, y, z, w = clip[:, 0], clip[:, 1], clip[:, 2], clip[:, 3]
    m = CLIP_MARGIN * np.abs(w)
    code = np.zeros(len(p), np.uint8)  # per vertex: the clip planes it lies past (an outcode)
    for bit, a in enumerate((x - w - m, -x - w - m, y - w - m, -y - w - m, z - w - m, -z - w - m)):
        code |= (a > 0.0).astype(np.uint8) << bit
    idx = np.asarray(indices)
    keep = (code[idx[:, 0]] & code[idx[:, 1]] & code[idx[:, 2]]) == 0  # not all three past one plane
    if not cull_back:
        return np.asarray(keep)
    ws = np.where(w > 0.0, w, 1.0)
    nx, ny = x / ws, y / ws
    behind = (w[idx] <= 0.0).any(axis=1)
    ax, ay = nx[idx[:, 0]], ny[idx[:, 0]]
    e1x, e1y = nx[idx[:, 1]] - ax, ny[idx[:, 1]] - ay
    e2x, e2y = nx[idx[:, 2]] - ax, ny[idx[:, 2]] - ay
    area = e1x * e2y - e1y * e2x
    scale = np.sqrt((e1x * e1x + e1y * e1y) * (e2x * e2x + e2y * e2y))
    return np.asarray(keep & (behind | (area >= -FACING_EPS * scale)))


def tile_mask(scene, n: int, tris: np.ndarray, state) -> np.ndarray:
    """(tiles, tiles) bool: the tiles of the triangles ``tris`` (bool per triangle) at an n x n map."""
    tri, tile = _tri_tiles(scene, n, state)
    nt = tiles_of(n)
    mask = np.zeros(nt * nt, bool)
    mask[tile[tris[tri]]] = True
    return mask.reshape(nt, nt)


def grow(mask: np.ndarray, k: int = 1) -> np.ndarray:
    """``mask`` and the tiles within ``k`` tiles of it (a square window)."""
    out = mask.copy()
    for _ in range(max(int(k), 0)):
        g = out.copy()
        g[1:, :] |= out[:-1, :]
        g[:-1, :] |= out[1:, :]
        g[:, 1:] |= g[:, :-1].copy()
        g[:, :-1] |= g[:, 1:].copy()
        out = g
    return out


def half_of(mask: np.ndarray, m: int) -> np.ndarray:
    """The tiles of an m x m map (half the side of ``mask``'s) holding the texels of ``mask``'s tiles,
    one tile wider (a bilinear read at half size reaches a texel past them)."""
    nt = tiles_of(m)
    out = np.zeros((nt, nt), bool)
    ys, xs = np.nonzero(mask)
    out[np.minimum(ys // 2, nt - 1), np.minimum(xs // 2, nt - 1)] = True
    return grow(out, 1)


def lod_possible(r, scene) -> bool:
    """Whether render.mesh_lod may draw a coarser mesh this frame (rules.mesh_lod's wanted level, less
    its hysteresis): its triangles are not the ones F was made of, so no tile is culled."""
    if r.settings.render.mesh_lod != "auto" or len(scene.lod_triangles) < 2:
        return False
    d_px = screen_diameter_px(r.view)
    area = math.pi / 4.0 * d_px * d_px
    if not area > 0.0 or not math.isfinite(area):
        return False
    per_px = scene.lod_triangles[0] / 2.0 / area
    return math.log(max(per_px / LOD_TRIANGLES_PER_PX, 1e-9), 4.0) >= 1.0 - LOD_HYSTERESIS - 0.05


class ViewTiles:
    """This frame's needed set: F (the tiles of the view's triangles at the map size n) and the chain
    (deon.cull_chain: what each pass reads, from reflect), as one TileCover ``token`` (tag: the chain) that every
    culled pass declares (Reflection.cover). Each pass's own tiles follow from it (stage_needs)."""

    def __init__(self, f: np.ndarray, chain: tuple, n: int, m: int):
        self.n, self.m, self.chain = n, m, chain
        self.token = TileCover(f, tag=chain)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ViewTiles) and self.token == other.token

    def __hash__(self) -> int:
        return hash(self.token)


COMPLETE = "deon.view_cull.complete"  # shape state: this frame needs every tile (Renderer.complete_view)


def make_view_tiles(r, chain: tuple, n: int, m: int) -> ViewTiles | None:
    """This frame's ViewTiles for d'Eon's chain ``chain`` (deon.cull_chain; its first entry ("names", diffuse
    sum, transmitted light, visibility, TSM, stretch map) names the resources) on n x n maps (m: the half
    size); None when a coarser mesh level may be drawn (lod_possible). Called from a memoised rule."""
    scene = r.scene
    if lod_possible(r, scene):
        return None
    state = r.state
    cull = culls_back_faces(r.settings.scene.back_faces, scene.closed)  # declared either way: the same keys
    if state.get(COMPLETE):  # idle: the tiles no view has needed yet, so that a later orbit finds them made
        return ViewTiles(np.ones((tiles_of(n), tiles_of(n)), bool), chain, n, m)
    mesh = scene.mesh
    f = tile_mask(scene, n, facing(mesh.positions, mesh.indices, r.view.camera.view_proj, cull), state)
    return ViewTiles(f, chain, n, m)


def names(chain: tuple) -> dict[str, str]:
    """The resource names a chain's first entry gives (make_view_tiles)."""
    return dict(zip(("diffuse", "transmitted", "visibility", "tsm", "stretch", "position", "gutter_half"),
                    chain[0][1:]))


def tsm_texels(ec, tsm: str) -> tuple[np.ndarray, np.ndarray]:
    """The TSM read back once per version (gl_objects): (its side, and per texel with a surface (A >= 0) its
    flat index and uv)."""
    objs = ec.state.setdefault("gl_objects", {})
    version = ec.input_version(tsm)
    key = ("view_cull_tsm", id(ec.scene), version)
    hit = objs.get(key)
    if hit is None:
        drop_other_scenes(objs, "view_cull_tsm", id(ec.scene))
        for k in [k for k in objs if k[0] == "view_cull_tsm"]:
            objs.pop(k)
        tex = ec.input(tsm)
        t = np.frombuffer(tex.read(), np.float32).reshape(-1, tex.components)
        keep = np.nonzero((t[:, 3] >= 0.0) & np.isfinite(t[:, 1]) & np.isfinite(t[:, 2]))[0]
        hit = objs[key] = (_Token(), keep, np.ascontiguousarray(np.clip(t[keep][:, 1:3], -1.0, 2.0)))
    return hit[1], hit[2]


def exit_boxes(ec, m: int, position: str, gutter: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(tile index, lowest corner, highest corner): per tile of the m x m transmitted-light map holding island
    texels, the 3D box of those texels' positions (its texel surface map; the gutter map's own texels), once
    per scene and size (gl_objects)."""
    objs = ec.state.setdefault("gl_objects", {})
    key = ("view_cull_exits", id(ec.scene), m)
    hit = objs.get(key)
    if hit is None:
        drop_other_scenes(objs, "view_cull_exits", id(ec.scene))
        g = read_gutter(ec.input(gutter))
        y, x = np.mgrid[0:m, 0:m]
        own = ((g[..., 0] + 0.5).astype(np.int64) == x) & ((g[..., 1] + 0.5).astype(np.int64) == y)
        tex = ec.input(position)
        p = np.frombuffer(tex.read(), np.float32).reshape(m, m, tex.components)[..., :3][own].astype(np.float64)
        nt = tiles_of(m)
        cid = ((y // VIEW_TILE) * nt + x // VIEW_TILE)[own]
        order = np.argsort(cid, kind="stable")
        cid, p = cid[order], p[order]
        starts = np.nonzero(np.r_[True, cid[1:] != cid[:-1]])[0] if len(cid) else np.zeros(0, np.int64)
        with np.errstate(invalid="ignore"):  # a NaN position: its box is NaN, never projected (as the shader)
            lo = np.minimum.reduceat(p, starts, axis=0) if len(cid) else np.zeros((0, 3))
            hi = np.maximum.reduceat(p, starts, axis=0) if len(cid) else np.zeros((0, 3))
        hit = objs[key] = (_Token(), cid[starts] if len(cid) else cid, lo, hi)
    return hit[1], hit[2], hit[3]


def tsm_reads(ec, stage: tuple, exits: np.ndarray, m: int, sizes: set[int], rn: dict[str, str]) -> dict[int, np.ndarray]:
    """L: per map size in ``sizes``, the tiles the transmitted light reads for its exit texels in the tiles
    ``exits`` (m x m map): lib/tsm_transmit.glsl projects an exit texel C into the TSM and reads the TSM texels
    within its reach (the 3x3 taps, the gather's spiral: the max map's widest window, planned), and at each
    one's stored uv t.gb the blurs and the irradiance (bilinear: +UV_MARGIN texels). A TSM texel is read when
    it lies in the window around some exit tile's projection: the box of its 3D box's projected corners (a
    projective map keeps a box's image inside its corners' hull while all lie before the light; a tile
    straddling the light's plane reads the whole TSM)."""
    _, _, matrix, tsm_n, reach = stage
    nts = {size: tiles_of(size) for size in sizes}
    if matrix is None:  # no position map to project the exits from: every TSM texel
        return _uv_tiles(ec, np.ones(tsm_n * tsm_n, bool), nts, rn["tsm"])
    cells, lo3, hi3 = exit_boxes(ec, m, rn["position"], rn["gutter_half"])
    sel = exits.ravel()[cells] & np.all(np.isfinite(lo3) & np.isfinite(hi3), axis=1)
    out = {size: np.zeros((nt, nt), bool) for size, nt in nts.items()}
    if not sel.any():
        return out
    lo3, hi3 = lo3[sel], hi3[sel]
    corners = np.stack([np.where(np.array([(k >> a) & 1 for a in range(3)], bool), hi3, lo3) for k in range(8)], 1)
    clip = np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], axis=2) @ np.asarray(matrix, np.float64).reshape(4, 4).T
    w = clip[..., 3]
    front = np.all(w > 0.0, axis=1)  # every corner before the light: the tile's image within its corners' box
    behind = np.all(w <= 0.0, axis=1)  # every texel behind it: the shader returns 0 before reading
    if np.any(~front & ~behind):  # straddling the light's plane: anywhere in the TSM
        return _uv_tiles(ec, np.ones(tsm_n * tsm_n, bool), nts, rn["tsm"])
    cc = (clip[front][..., :2] / w[front][..., None] * 0.5 + 0.5) * tsm_n  # TSM texel coordinates
    if not len(cc):
        return out
    lo, hi = cc.min(axis=1), cc.max(axis=1)
    ext = float(reach) + 2.0  # the window past the projection, a texel of rounding either side
    x0 = np.clip(np.floor(lo[:, 0] - ext), 0, tsm_n).astype(np.int64)
    y0 = np.clip(np.floor(lo[:, 1] - ext), 0, tsm_n).astype(np.int64)
    x1 = np.clip(np.ceil(hi[:, 0] + ext) + 1, 0, tsm_n).astype(np.int64)
    y1 = np.clip(np.ceil(hi[:, 1] + ext) + 1, 0, tsm_n).astype(np.int64)
    keep = (x1 > x0) & (y1 > y0)
    acc = np.zeros((tsm_n + 1, tsm_n + 1), np.int32)  # the windows' union: a summed difference array
    for xs, ys, v in ((x0, y0, 1), (x1, y0, -1), (x0, y1, -1), (x1, y1, 1)):
        np.add.at(acc, (ys[keep], xs[keep]), v)
    return _uv_tiles(ec, (acc.cumsum(axis=0).cumsum(axis=1)[:tsm_n, :tsm_n] > 0).ravel(), nts, rn["tsm"])


def _uv_tiles(ec, read: np.ndarray, nts: dict[int, int], tsm: str) -> dict[int, np.ndarray]:
    """Per map size: the tiles of the uv stored in the TSM texels ``read`` (flat), +UV_MARGIN texels (a texel
    grid marked once, widened, then per tile: cheaper than marking each uv's tiles)."""
    index, uv = tsm_texels(ec, tsm)
    uv = uv[read[index]]
    out: dict[int, np.ndarray] = {}
    mg = int(math.ceil(UV_MARGIN))
    for size, nt in nts.items():
        texel = np.clip(np.floor(uv * np.float32(size)), 0, size - 1).astype(np.int32)  # off the map: its edge
        grid = np.zeros((nt * VIEW_TILE, nt * VIEW_TILE), bool)
        grid[texel[:, 1], texel[:, 0]] = True
        for _ in range(mg):  # +-mg texels (a square)
            g = grid.copy()
            g[1:, :] |= grid[:-1, :]
            g[:-1, :] |= grid[1:, :]
            g[:, 1:] |= g[:, :-1].copy()
            g[:, :-1] |= g[:, 1:].copy()
            grid = g
        out[size] = np.asarray(grid.reshape(nt, VIEW_TILE, nt, VIEW_TILE).any(axis=(1, 3)))
    return out


# -- each pass's tiles, backwards from the final pass (at execute: the gutter and seam maps, the stretch) ---

def declare_inputs(r, vt: ViewTiles) -> None:
    """The maps stage_needs reads: the gutter and seam maps at both sizes, the stretch map."""
    from skinviewer.passes.texture_space import gutter_resource, seam_resource
    res = names(vt.chain)
    for size in sorted({vt.n, vt.m}):
        r.input(gutter_resource(size))
        if r.settings.scene.seam_aware:
            r.input(seam_resource(size))
    if any(stage[0] == "trans" for stage in vt.chain):  # L: the TSM's uv around the exits (tsm_reads)
        r.input(res["tsm"])
        r.input(res["position"])
    if r.settings.deon.stretch:
        r.input(res["stretch"])
        r.settings.deon.stretch_shear  # noqa: B018  (declared: max_stretch reads it)


def links(ec, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(island tiles, gutter pairs, seam pairs) at ``size`` (gutter_links; seam pairs: a texel across a UV
    seam reads its partner's bilinear 2 x 2, seam_map's RG, in the second tile)."""
    island, gut = gutter_links(ec, size)
    objs = ec.state.setdefault("gl_objects", {})
    key = ("view_cull_seams", id(ec.scene), size)
    hit = objs.get(key)
    if hit is None:
        drop_other_scenes(objs, "view_cull_seams", id(ec.scene))
        from skinviewer.passes.texture_space import seam_resource
        pairs = np.zeros((0, 2), np.int64)
        if ec.has_input(seam_resource(size)):
            tex = ec.input(seam_resource(size))
            sm = np.frombuffer(tex.read(), np.float32).reshape(size, size, tex.components)
            ys, xs = np.nonzero(sm[..., 2] > 0.5)
            nt = tiles_of(size)
            here = (ys // VIEW_TILE) * nt + xs // VIEW_TILE
            cx, cy = sm[ys, xs, 0], sm[ys, xs, 1]
            out = []
            for dx in (-1.0, 0.0, 1.0):  # the bilinear 2 x 2 around the partner point, a texel of rounding
                for dy in (-1.0, 0.0, 1.0):
                    px = np.clip(np.floor(np.nan_to_num(cx) + dx), 0, size - 1).astype(np.int64)
                    py = np.clip(np.floor(np.nan_to_num(cy) + dy), 0, size - 1).astype(np.int64)
                    out.append(np.stack([here, (py // VIEW_TILE) * nt + px // VIEW_TILE], axis=1))
            pairs = np.unique(np.concatenate(out), axis=0) if out else pairs
        hit = objs[key] = (_Token(), pairs)
    return island, gut, hit[1]


def to_full(mask: np.ndarray, n: int) -> np.ndarray:
    """The n-map tiles holding the texels of ``mask``'s half-size tiles, one tile wider."""
    nt = tiles_of(n)
    out = np.zeros((nt, nt), bool)
    ys, xs = np.nonzero(mask)
    for dy in (0, 1):
        for dx in (0, 1):
            out[np.minimum(2 * ys + dy, nt - 1), np.minimum(2 * xs + dx, nt - 1)] = True
    return grow(out, 1)


def reach_tiles(texels: float) -> int:
    """Tiles a read ``texels`` away from a texel can land past its own."""
    return int(math.ceil(max(texels, 0.0) / VIEW_TILE))


def stretch_tiles(ec, size: int, stretch: str) -> np.ndarray:
    """Per tile of a size x size blur map: the largest tap step (UV per mm, lib/deon_blur.glsl shear_step, either
    pass) of its texels, read from the stretch map at the texel a blur texel reads it (a half-size map: every
    other one); inf where a texel's is not finite (its taps may land anywhere). The uniform scale without the
    stretch map. Once per stretch version and size (gl_objects)."""
    nt = tiles_of(size)
    if not ec.has_input(stretch):
        return np.full((nt, nt), float(ec.scene.mean_uv_per_mm))
    objs = ec.state.setdefault("gl_objects", {})
    shear = bool(ec.settings.deon.stretch_shear)
    key = ("view_cull_stretch", id(ec.scene), ec.input_version(stretch), size, shear)
    hit = objs.get(key)
    if hit is not None:
        return np.asarray(hit[1])
    drop_other_scenes(objs, "view_cull_stretch", id(ec.scene))
    tex = ec.input(stretch)
    n = tex.size[0]
    a = np.frombuffer(tex.read(), np.float32).reshape(n, n, tex.components).astype(np.float64)
    su, sv = a[..., 0], a[..., 1]
    if shear and tex.components >= 3:  # the second pass's step along the skewed axis
        c = np.clip(a[..., 2], -0.95, 0.95)
        sv = np.sqrt(c * c * su * su + sv * sv) / np.sqrt(1.0 - c * c)
    with np.errstate(invalid="ignore"):
        step = np.maximum(np.abs(su), np.abs(sv))
    step = np.where(np.isfinite(step), step, np.inf)
    idx = (np.arange(size) * n) // size  # the stretch texel a blur texel reads (src * n / size)
    step = step[np.ix_(idx, idx)]
    pad = np.zeros((nt * VIEW_TILE, nt * VIEW_TILE))
    pad[:size, :size] = step
    out = pad.reshape(nt, VIEW_TILE, nt, VIEW_TILE).max(axis=(1, 3))
    objs[key] = (_Token(), out)
    return out


def grow_by(mask: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """``mask`` and, for each of its tiles, the tiles within its own ``radius`` (tiles; larger than the grid:
    every tile)."""
    out = mask.copy()
    nt = max(mask.shape)
    for r in np.unique(radius[mask]):
        part = mask & (radius == r)
        out |= np.ones_like(mask) if r >= nt else grow(part, int(r))
    return out


def separable_draws(ec, stage: tuple, out: np.ndarray, stretch: str) -> tuple[list[np.ndarray], np.ndarray]:
    """A separable blur's draws backwards from ``out`` (its tiles to make): per logical draw (4 a sub-step:
    seam fill, H, seam fill, V; deon.GaussianBlurPass.execute) the tiles it makes, and the tiles of its
    input read. A blur draw computes a gutter texel at its island texel and reads its taps around it (3 steps
    of the texel's own stretch x sigma, stretch_tiles; whole-texel taps NARROW_TAPS + 0.5; + 1.5 bilinear and
    a texel of rounding); a seam fill reads the texel, its island texel (DILATE) and its partner across a seam
    (bilinear), one texel wide."""
    _, _, m, _source, n_in, sigmas, narrow, seam, _cull = stage
    island, gut, seams = links(ec, m)
    step = stretch_tiles(ec, m, stretch)
    masks: list[np.ndarray] = [np.zeros_like(out)] * (4 * len(sigmas))
    x = out
    nt = tiles_of(m)
    for k in range(len(sigmas) - 1, -1, -1):
        with np.errstate(invalid="ignore", over="ignore"):
            taps = np.full_like(step, float(narrow) + 0.5) if narrow else 3.0 * step * float(sigmas[k]) * m
            radius = np.where(np.isfinite(taps), np.ceil((taps + 2.5) / VIEW_TILE), nt).astype(np.int64)
        for d in (3, 1):  # V, then H (each preceded by its seam fill)
            masks[4 * k + d] = x
            x = grow_by(through_links(x, gut), radius)
            if seam:  # the fill: the texel, its island texel, its partner's bilinear 2 x 2 (the links hold it)
                masks[4 * k + d - 1] = x
                x = through_links(through_links(x, gut), seams) | through_links(x, seams)
    if n_in != m:
        x = to_full(x, n_in)
    return masks, x


def gather_reads(ec, stage: tuple, out: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A summed step (deon_gather_quad/pick, deon_gather_sum): (the island tiles its sum computes for ``out``,
    the tiles of its input read): a texel is its island texel's sum, which reads its 6 x 6 inner texels and
    ``reach`` rings of 2 x 2 blocks of the seam-filled input (+ a block of rounding), the fill a texel,
    its island texel and its seam partner (bilinear)."""
    _, _, n, _source, reach, _cull = stage
    island, gut, seams = links(ec, n)
    q = through_links(out, gut)
    x = grow(q, reach_tiles(2.0 * reach + 8.0))
    return q, through_links(through_links(x, gut), seams) | through_links(x, seams)


def stage_needs(ec, vt_token: TileCover, n: int, m: int) -> dict[str, np.ndarray]:
    """The tiles each texture-space resource must hold for ``vt_token`` (a ViewTiles token, its tag the chain):
    the final pass's F, the diffuse sum's reads, the transmitted light's L, each blur's reads, backwards.
    A stage the chain marks as not cullable makes every tile. Once per token (gl_objects)."""
    chain: tuple = vt_token.tag  # type: ignore[assignment]  # a ViewTiles token: its tag is the chain
    rn = names(chain)
    objs = ec.state.setdefault("gl_objects", {})
    # L follows the TSM: the needs of a token hold for one version of it (a light move makes another)
    key = ("view_cull_needs", id(ec.scene), vt_token, ec.input_version(rn["tsm"]) if ec.has_input(rn["tsm"]) else None)
    hit = objs.get(key)
    if hit is not None:
        return hit[1]
    drop_other_scenes(objs, "view_cull_needs", id(ec.scene))
    for k in [k for k in objs if k[0] == "view_cull_needs"][:-3]:  # the last few tokens (need and have)
        objs.pop(k)
    DIFFUSE, TRANSMITTED, VISIBILITY = rn["diffuse"], rn["transmitted"], rn["visibility"]  # noqa: N806
    f = np.asarray(vt_token.mask)
    size_of: dict[str, int] = {DIFFUSE: n, VISIBILITY: n, TRANSMITTED: m}
    need: dict[str, np.ndarray] = {}

    def add(res: str, size: int, mask: np.ndarray) -> None:
        size_of[res] = size
        need[res] = need[res] | mask if res in need else mask.copy()
    add(DIFFUSE, n, f)
    add(VISIBILITY, n, f)
    add(TRANSMITTED, m, half_of(f, m))
    for stage in chain[1:]:
        if stage[0] == "comb":
            for res, size in stage[1]:
                add(res, size, f if size == n else half_of(f, size))
        elif stage[0] == "trans":  # the TSM texels around the exits' projections, at their uv
            exits = through_links(need[TRANSMITTED], links(ec, m)[1])
            lit = tsm_reads(ec, stage, exits, m, {size for _, size in stage[1]}, rn)
            for res, size in stage[1]:
                add(res, size, lit[size])
    for stage in reversed(chain[1:]):
        if stage[0] not in ("blur", "gather"):
            continue
        out = blur_name(stage[1])
        size = stage[2]
        if out not in need:
            continue
        if not stage[-1]:  # not cullable: every tile
            need[out] = np.ones_like(need[out])
        src, src_size = stage[3], (stage[4] if stage[0] == "blur" else size)
        reads = (separable_draws(ec, stage, need[out], rn["stretch"])[1] if stage[0] == "blur"
                 else gather_reads(ec, stage, need[out])[1])
        add(src, src_size, reads)
    objs[key] = (_Token(), need)
    return need


def blur_name(i: int) -> str:
    from skinviewer.physics.diffusion import blur_resource
    return blur_resource(i)


def work_of(ec, res: str) -> np.ndarray | None:
    """The tiles of ``res`` this run makes (ExecuteContext.cover: needed and not held), or None: every tile
    (no cover, or ``res`` not in the chain's needs)."""
    cover = ec.cover
    if cover is None or cover[0] is None or not ec.plan.get("cull"):
        return None
    n, m = ec.plan.cull
    need = stage_needs(ec, cover[0], n, m).get(res)
    if need is None:
        return None
    have = cover[1]
    if have is not None and have.tag == cover[0].tag and have.mask.shape == cover[0].mask.shape:
        held = stage_needs(ec, have, n, m).get(res)
        if held is not None:
            return np.asarray(need & ~held)
    return need


# -- drawing a tile set ---------------------------------------------------------------------------

def note_tiles(ec, work: np.ndarray | None, text: str = "", **figures) -> None:
    """The pass's note (``text``, ``figures``) with, for a culled pass (``work``: the tiles it makes this run),
    the share of its map's tiles it made."""
    if work is not None:
        text = "; ".join(x for x in (text, f"view culling: {int(work.sum())} of {work.size} tiles made") if x)
        figures["view_tiles"] = float(work.mean()) if work.size else 0.0
    ec.note(text, **figures)


def coarse(mask: np.ndarray) -> np.ndarray:
    """``mask`` widened to whole draw tiles (texture_space.TILE, two of these a side): fewer, larger rectangles
    (llvmpipe pays per triangle: 8 x 8 quads made the irradiance's shading ~10 % dearer than 16 x 16 ones)."""
    k = TILE // VIEW_TILE
    nt = mask.shape[0]
    big = -(-nt // k)
    pad = np.zeros((big * k, big * k), bool)
    pad[:nt, :nt] = mask
    wide = pad.reshape(big, k, big, k).any(axis=(1, 3))
    return np.asarray(np.repeat(np.repeat(wide, k, axis=0), k, axis=1)[:nt, :nt])


def exact(ec) -> bool:
    """Whether a draw into a pass's output must keep to its tiles: in a run for the tiles it does not hold
    (ExecuteContext.cover), whose others hold valid texels; elsewhere (scratch targets, a whole run) a draw
    may cover whole TILE tiles (coarse): the texels past its tiles are read by nothing."""
    return ec.cover is not None and ec.cover[1] is not None


def mask_rects(ec, mask: np.ndarray, slot: object = 0, output: bool = True) -> tuple | None:
    """``mask``'s tiles as a TILED = 2 rectangle list (rect_tiles), whole TILE tiles where it may (``output``:
    a draw into the pass's output, exact), kept for its last mask per pass and ``slot`` (gl_objects); None when
    it is empty."""
    if not mask.any():
        return None
    if not (output and exact(ec)):
        mask = coarse(mask)
    objs = ec.state.setdefault("gl_objects", {})
    cover = TileCover(mask)
    key = ("view_cull_rects", id(ec.scene), ec.pass_.name, slot, mask.shape)
    hit = objs.get(key + ("mask",))
    if hit is not None and hit[1] == cover:
        return objs[key]
    drop_other_scenes(objs, "view_cull_rects", id(ec.scene))
    old = objs.pop(key, None)
    if old is not None:
        old[0].release()
    objs[key] = rect_tiles(ec.gl, mask, VIEW_TILE)
    objs[key + ("mask",)] = (_Token(), cover)
    return objs[key]


def where_mask(ec, where: tuple | None, size: int) -> np.ndarray:
    """The tiles a draw's tile list (work_tiles-like: TILED = 2 rectangles, TILED = 1 origins, one whole-target
    tile; None: the whole target) covers at a size x size target (read back once per list: gl_objects keeps
    the list's texture, so its id stays its own)."""
    nt = tiles_of(size)
    if where is None or where[2] >= size:
        return np.ones((nt, nt), bool)
    objs = ec.state.setdefault("gl_objects", {})
    key = ("view_cull_where", id(ec.scene), id(where[0]), int(where[1]), size)
    hit = objs.get(key)
    if hit is not None and hit[0].tex is where[0]:
        return np.asarray(hit[1])
    drop_other_scenes(objs, "view_cull_where", id(ec.scene))
    tex, count, edge = where[0], int(where[1]), int(where[2])
    boxes = np.frombuffer(tex.read(), np.float32).reshape(count, tex.components).astype(np.int64)
    out = np.zeros((nt, nt), bool)
    for b in boxes:
        x, y = b[0] // VIEW_TILE, b[1] // VIEW_TILE
        w, h = (b[2], b[3]) if tex.components == 4 else (edge, edge)
        out[y:y + -(-h // VIEW_TILE), x:x + -(-w // VIEW_TILE)] = True
    objs[key] = (_Keep(tex), out)
    return out


class _Keep:
    """A gl_objects entry holding another entry's texture without owning it (Graph.release releases that one)."""

    def __init__(self, tex):
        self.tex = tex

    def release(self) -> None:
        pass


def restrict(ec, slot: object, where: tuple | None, mask: np.ndarray, size: int, output: bool = True) -> tuple | None:
    """A draw's tile list ``where`` cut to the tiles of ``mask`` (TILED = 2 rectangles; None: none left; whole
    TILE tiles unless the draw writes the output in a run for new tiles: mask_rects)."""
    wm = where_mask(ec, where, size)
    cut = wm & (mask if output and exact(ec) else coarse(mask))
    if np.array_equal(cut, wm):  # nothing culled: the draw's own list (work_tiles may draw it as one quad)
        return where
    return mask_rects(ec, cut, slot, output)


class _Token:
    """A gl_objects entry that holds no texture (Graph.release releases entry[0] of each)."""

    def release(self) -> None:
        pass


def island_origins(ec, size: int, mask: np.ndarray, island: np.ndarray) -> tuple | None:
    """The island tiles (``island``) of ``mask`` as a TILED = 1 origin list (work_tiles' form) of whole TILE
    tiles (its draw writes a scratch target); None: none."""
    k = TILE // VIEW_TILE
    sel = coarse(mask & island)[::k, ::k]
    ty, tx = np.nonzero(sel)
    if len(tx) == 0:
        return None
    objs = ec.state.setdefault("gl_objects", {})
    key = ("view_cull_origins", id(ec.scene), ec.pass_.name, size)
    cover = TileCover(sel)
    hit = objs.get(key + ("mask",))
    if hit is not None and hit[1] == cover:
        return objs[key]
    drop_other_scenes(objs, "view_cull_origins", id(ec.scene))
    old = objs.pop(key, None)
    if old is not None:
        old[0].release()
    origins = np.stack([tx * TILE, ty * TILE], axis=1).astype(np.float32)
    tex = ec.gl.texture((len(tx), 1), 2, origins.tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    objs[key] = (tex, len(tx), TILE)
    objs[key + ("mask",)] = (_Token(), cover)
    return objs[key]


def gutter_links(ec, size: int) -> tuple[np.ndarray, np.ndarray]:
    """(island tiles, links): per tile of the size x size gutter map whether it holds an island texel, and
    (tile, tile) index pairs: a texel of the first is dilated from its nearest island texel in the second
    (texture_space.dilate). Once per scene and size (gl_objects)."""
    objs = ec.state.setdefault("gl_objects", {})
    key = ("view_cull_links", id(ec.scene), size)
    hit = objs.get(key)
    if hit is not None:
        return hit[1], hit[2]
    drop_other_scenes(objs, "view_cull_links", id(ec.scene))
    from skinviewer.passes.texture_space import gutter_resource
    g = read_gutter(ec.input(gutter_resource(size)))
    nt = tiles_of(size)
    y, x = np.mgrid[0:size, 0:size]
    sx = np.clip((g[..., 0] + 0.5).astype(np.int64), 0, size - 1)
    sy = np.clip((g[..., 1] + 0.5).astype(np.int64), 0, size - 1)
    island = np.zeros((nt, nt), bool)
    covered = (sx == x) & (sy == y)
    island[y[covered] // VIEW_TILE, x[covered] // VIEW_TILE] = True
    pairs = np.unique(np.stack([(y // VIEW_TILE) * nt + x // VIEW_TILE, (sy // VIEW_TILE) * nt + sx // VIEW_TILE], axis=-1).reshape(-1, 2),
                      axis=0)
    objs[key] = (_Token(), island, pairs)
    return island, pairs


def through_links(mask: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``mask`` and the tiles its tiles read through ``pairs`` (gutter_links)."""
    flat = mask.ravel()
    out = flat.copy()
    out[pairs[flat[pairs[:, 0]], 1]] = True
    return out.reshape(mask.shape)
