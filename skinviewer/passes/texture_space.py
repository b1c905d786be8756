"""Texture-space helpers shared by the texture-space techniques: the gutter map of the UV atlas
(nearest island texel for every texel outside the islands) and the dilation that uses it."""
from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass

import moderngl
import numpy as np

from skinviewer.ground.constants import FLOAT_MAX, HALF_MAX
from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, whole
from skinviewer.passes.rules import light_on
from skinviewer.scene.texels import border_gutters, seam_indirection


def gutter_resource(size: int) -> str:
    return f"gutter_{size}"


class GutterMapPass(Pass):
    """Per texel: the integer texel coordinate of the nearest texel covered by a UV island (RG) and
    coverage (B); with scene.seam_aware also the seam map (seam_resource: RG the fractional texel
    coordinate of the surface point across the UV seam, B 1 where there is one; seam_map). Depends
    on the mesh and the texture size only, so it runs once per scene/size. With render.texel_surface
    the coverage and the texel positions come from the texel surface map of the same size (its
    TexelSurfacePass is in every graph that has this pass) instead of two more rasters of the mesh.
    ``size_of(r)``: the texture size it serves (reads e.g. ``r.settings.gosselin.light_map_size``)."""

    def __init__(self, name: str, size_of):
        self.name = name
        self.size_of = size_of

    def _n(self, r) -> int:
        return int(self.size_of(r))

    def reflect(self, r: Reflection) -> None:
        size = self._n(r)
        seam = seam_resource(size) if r.settings.scene.seam_aware else None
        # the coverage from the texel surface map's positions (render.texel_surface), or rasterised
        surface = texel_surface_resources(size, "p")[0] if texel_shading(r) else None
        r.plan(size=size, surface=surface, gutter=gutter_resource(size), gutter_spec=gutter_spec(size), seam=seam,
               cover=TexSpec((size, size), 1, "f1", filter="nearest"))
        if surface:
            r.input(surface)
            r.program("texel_coverage")
        else:
            r.program("uv_coverage")
            if seam:
                r.program("uv_position")
        r.output(r.planned.gutter, r.planned.gutter_spec)
        if seam:
            r.output(seam, TexSpec((size, size), 4, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        plan = ec.plan
        size, surface, spec = plan.size, plan.surface, plan.gutter_spec
        if surface:
            prog = ec.program("texel_coverage")
            ec.bind(prog, "surface_p", surface)
            cover = ec.scratch(plan.cover)
            ec.draw_fullscreen(prog, cover)
        else:
            cover = rasterize_unwrapped(ec, ec.program("uv_coverage"), size, components=1, dtype="f1")
        covered = np.frombuffer(cover.read(alignment=1), dtype=np.uint8).reshape(size, size) > 0
        # the CPU tables depend on the mesh and the coverage only: kept by the scene (GpuScene.texel_table),
        # so a forced re-run or a second technique at the same size only uploads them
        key = (size, hashlib.blake2b(covered.tobytes(), digest_size=16).digest())
        dtype = np.float16 if spec.dtype == "f2" else np.float32
        ec.output(plan.gutter).write(ec.scene.texel_table(("gutter",) + key, lambda: stored_table(
            ["gutter", spec.components], covered, ((size, size, spec.components), dtype),
            lambda: gutter_table(covered)[..., :spec.components].astype(dtype)).tobytes()))

        if plan.seam:
            def seam() -> bytes:
                pos = ec.input(surface) if surface else rasterize_unwrapped(ec, ec.program("uv_position"), size)
                pos = np.frombuffer(pos.read(), dtype=np.float32).reshape(size, size, 4)[..., :3]
                sc = ec.scene
                m = sc.mesh
                return stored_table(
                    ["seam", SEAM_REACH_TEXELS, float(sc.mm_per_unit), float(sc.mean_uv_per_mm)],
                    (covered, pos, m.positions, m.uvs, m.indices), ((size, size, 4), np.float32),
                    lambda: seam_map(covered, sc, pos)).tobytes()
            ec.output(plan.seam).write(ec.scene.texel_table(("seam",) + key, seam))


TABLES_VERSION = 1  # bump when gutter_table or seam_map change what they compute
TABLES_KEPT = 24  # files kept in the cache folder's texel-tables/ (the least recently used go)


def stored_table(what: list, inputs, like: tuple, compute) -> np.ndarray:
    """A CPU table of the texture-space passes (the gutter table, the seam map: seconds of numpy for a
    1024² atlas, most of a first frame) from the cache folder when it was made before from the very
    same inputs (their bytes are the key: the mesh, the coverage and texel positions as this GL
    rasterised them; ``like``: its shape and dtype), else ``compute()``, then stored (atomically; a store that fails, or a file that
    does not read back, only costs the computation). The viewer's first image of a known mesh then
    skips them."""
    shape, dtype = tuple(like[0]), np.dtype(like[1])
    h = hashlib.blake2b(repr([TABLES_VERSION, shape, dtype.str] + list(what)).encode(), digest_size=20)
    for a in (inputs if isinstance(inputs, tuple) else (inputs,)):
        a = np.ascontiguousarray(a)
        h.update(repr((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    try:
        from skinviewer.ground.paths import cache_dir
        folder = cache_dir() / "texel-tables"
    except OSError:
        return compute()
    path = folder / f"{what[0]}-{h.hexdigest()}.npy"
    try:
        table = np.load(path, allow_pickle=False)
        if table.shape == shape and table.dtype == dtype:
            os.utime(path)  # recently used
            return table
    except Exception:
        pass  # not made yet, or unreadable: made again
    table = np.ascontiguousarray(compute())
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        with open(tmp, "wb") as f:
            np.save(f, table, allow_pickle=False)
        os.replace(tmp, path)
        old = sorted(folder.glob("*.npy"), key=lambda p: p.stat().st_mtime)
        for p in old[:-TABLES_KEPT]:
            p.unlink(missing_ok=True)
    except OSError:
        try:
            tmp.unlink(missing_ok=True)
        except (OSError, UnboundLocalError):
            pass
    return table


def gutter_spec(size: int) -> TexSpec:
    """gutter_table's RG integer texel coordinates, B island zone, A distance to another zone: half
    floats hold every integer up to 2048 exactly (issue 14: exact formats)."""
    return TexSpec((size, size), 4, "f2" if size <= 2048 else "f4", filter="nearest")


def read_gutter(tex: moderngl.Texture) -> np.ndarray:
    """The gutter map back on the CPU: (H, W, 2) float32, RG = source texel."""
    w, h = tex.size
    dt = np.float16 if tex.dtype == "f2" else np.float32
    return np.frombuffer(tex.read(), dtype=dt).reshape(h, w, tex.components).astype(np.float32)


TILE = 16  # texels per tile edge of work_tiles
COMPUTE_TILE_COLS = 4096  # compute_tiles' origins a texture row


def drop_other_scenes(objs: dict, kind: str, scene_id: int) -> None:
    """Release the tile lists cached in ``gl_objects`` under ``kind`` for another mesh (each entry a
    work_tiles-like tuple whose first element is a texture, or None)."""
    for k in [k for k in objs if k[0] == kind and k[1] != scene_id]:
        old = objs.pop(k)
        if old is not None:
            old[0].release()


def per_tile(mask: np.ndarray) -> np.ndarray:
    """(tiles, tiles) bool: the TILE x TILE tiles of an (n, n) texel ``mask`` that hold a True texel."""
    n = mask.shape[0]
    nt = -(-n // TILE)
    pad = np.zeros((nt * TILE, nt * TILE), bool)
    pad[:n, :n] = mask
    return np.asarray(pad.reshape(nt, TILE, nt, TILE).any(axis=(1, 3)))


def rect_tiles(gl, tiles: np.ndarray, edge: int = TILE) -> tuple | None:
    """The True cells of ``tiles`` as a work_tiles-like tuple for a TILED = 2 program (RGBA32F 1-row
    texture of tile_rects' rectangles in texels, count, edge); None when no cell is True."""
    if not tiles.any():
        return None
    boxes = tile_rects(tiles) * edge
    tex = gl.texture((len(boxes), 1), 4, boxes.astype(np.float32).tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return (tex, len(boxes), edge)


def compute_tiles(ec, tiles: tuple) -> tuple:
    """A work_tiles-like list (``tiles``: TILED = 2 rectangles, TILED = 1 origins, or one whole-target tile)
    as the TILE x TILE tile origins a compute twin dispatches one workgroup each (ExecuteContext.dispatch,
    lib/compute_target.glsl CS_TILES): (RG32F texture of the origins sorted by y, read row by row,
    COMPUTE_TILE_COLS a row; count; TILE; their y's), so a band dispatches only its rows' tiles; the same texels.
    Once per list (kept in gl_objects with it)."""
    objs = ec.state.setdefault("gl_objects", {})
    key = ("compute_tiles", id(ec.scene), id(tiles[0]), int(tiles[1]), int(tiles[2]), COMPUTE_TILE_COLS)
    hit = objs.get(key)
    if hit is not None:
        return hit
    drop_other_scenes(objs, "compute_tiles", id(ec.scene))
    tex, count, edge = tiles
    boxes = np.frombuffer(tex.read(), np.float32).reshape(int(count), tex.components).astype(np.int64)
    if tex.components == 2:  # origins of edge x edge tiles
        boxes = np.concatenate([boxes, np.full((len(boxes), 2), int(edge), np.int64)], axis=1)
    origins = [(x, y) for bx, by, bw, bh in boxes
               for y in range(by, by + bh, TILE) for x in range(bx, bx + bw, TILE)]
    arr = np.asarray(sorted(set(origins), key=lambda o: (o[1], o[0])), np.float32).reshape(-1, 2)
    count = len(arr)
    cols = min(count, COMPUTE_TILE_COLS)  # row by row: a 4096^2 map has 65,536 tiles, more than a texture's width
    rows = -(-count // cols)
    padded = np.zeros((rows * cols, 2), np.float32)
    padded[:count] = arr
    out = ec.gl.texture((cols, rows), 2, padded.tobytes(), dtype="f4")
    out.filter = (moderngl.NEAREST, moderngl.NEAREST)
    objs[key] = (out, count, TILE, arr[:, 1].astype(np.int64))  # + the origins' y, ascending (a band's range)
    return objs[key]


def work_tiles(ec, size: int, ring: int, rects: bool = False) -> tuple | None:
    """The tiles (TILE x TILE texels) holding a texel covered by a UV island or within ``ring``
    texels of one: (RG32F 1-row texture of tile origins, count, TILE) for ``ec.draw_fullscreen(...,
    tiles=)`` with a program compiled with TILED=1. Once per mesh, size and ring; one tile of the
    whole target when they are (nearly) every tile. ``rects``: the same texels as rectangles
    (tile_rects: RGBA32F x, y, w, h) for a program compiled with TILED=2 (issue 27: llvmpipe pays per
    triangle, and a blur's seam fill over 2,900 tiles cost a third more than over their ~400 rectangles)."""
    objs = ec.state.setdefault("gl_objects", {})
    key = ("work_tiles", id(ec.scene), size, int(ring), bool(rects))
    if key in objs:
        return objs[key]
    drop_other_scenes(objs, "work_tiles", id(ec.scene))
    g = read_gutter(ec.input(gutter_resource(size)))
    y, x = np.mgrid[0:size, 0:size]
    nt = -(-size // TILE)
    any_t = per_tile(np.hypot(g[..., 0] - x, g[..., 1] - y) <= ring)
    ty, tx = np.nonzero(any_t)
    edge = TILE
    if len(tx) == 0 or len(tx) > 0.9 * nt * nt or len(tx) > 16384:
        tx, ty, edge = np.zeros(1, int), np.zeros(1, int), size  # one tile: the whole target
        any_t = np.ones((1, 1), bool)
    if rects:
        objs[key] = rect_tiles(ec.gl, any_t, edge)
        return objs[key]
    origins = np.stack([tx * TILE, ty * TILE], axis=1).astype(np.float32)
    tex = ec.gl.texture((len(tx), 1), 2, origins.tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    objs[key] = (tex, len(tx), edge)
    return objs[key]


def tile_rects(tiles: np.ndarray) -> np.ndarray:
    """(K, 4) int (x, y, w, h), in tiles, of rectangles that cover exactly the True cells of ``tiles``
    (rows, columns) without overlap: each row's runs of True cells, merged with the run of the rows
    below when it spans the same columns."""
    open_: dict[tuple[int, int], list[int]] = {}  # (x0, x1) -> [x, y, w, h] still growing downwards
    out: list[list[int]] = []
    for yy, row in enumerate(np.asarray(tiles, bool)):
        d = np.diff(np.concatenate([[0], row.astype(np.int8), [0]]))
        runs = set(zip(np.nonzero(d == 1)[0].tolist(), np.nonzero(d == -1)[0].tolist()))
        for span in [k for k in open_ if k not in runs]:
            out.append(open_.pop(span))
        for x0, x1 in sorted(runs):
            if (x0, x1) in open_:
                open_[(x0, x1)][3] += 1
            else:
                open_[(x0, x1)] = [x0, yy, x1 - x0, 1]
    out.extend(open_.values())
    return np.array(sorted(out, key=lambda b: (b[1], b[0])), int).reshape(-1, 4)


def rasterize_unwrapped(ec, prog, size: int, components: int = 4, dtype: str = "f4") -> moderngl.Texture:
    """Draw the mesh with an unwrap program (shaders/vs/unwrap.vert, seed 000 eq. 8) into a
    cleared scratch texture of size x size (nearest filtering; gutters still empty)."""
    tex = ec.scratch(TexSpec((size, size), components, dtype, filter="nearest"))
    ec.draw_mesh(prog, tex, depth_test=False)
    return tex


def declare_unwrapped(r: Reflection, program: str, size: int, resource: str, spec: TexSpec, more: int = 0,
                      **defines) -> None:
    """Declare a pass that rasterises ``program`` (with ``defines``) in texture space and writes
    ``resource`` with its gutters filled (see unwrap_dilated). ``more`` = 1: it writes one more output
    (declared by the caller), dilated in the same draw as ``resource`` (dilate.frag DILATE_MORE)."""
    r.input(gutter_resource(size))
    r.program(program, **defines)
    r.program("dilate")
    if more == 1:
        r.program("dilate", DILATE_MORE=1)
    r.plan(dilate_pair=more == 1)
    r.output(resource, spec)


TEXEL_SURFACE_MAPS = "pn"  # position + tangent handedness, octahedral normal + tangent (texel_surface.frag)
TEXEL_SURFACE_SAMPLERS = {"p": "surface_p", "n": "surface_n", "v": "surface_v"}  # v: the environment's light


def texel_surface_resources(size: int, maps: str = TEXEL_SURFACE_MAPS) -> tuple[str, ...]:
    """The texel surface map at ``size`` (those of ``maps``; "p" alone: the position)."""
    return tuple(f"texel_surface_{size}_{k}" for k in maps)


class TexelSurfacePass(Pass):
    """The mesh's interpolated attributes at every covered texel centre (shaders/texel_surface.frag),
    so per-frame texture-space shading is one full-screen draw (shade_dilated) instead of a
    raster of the whole mesh, whose small triangles each shade whole pixel blocks (issue 14). Depends
    on the mesh and the size only: runs once per scene/size. ``maps``: the ones its readers need
    (the light maps' gutter mask reads only the position)."""

    def __init__(self, name: str, size_of, maps: str = TEXEL_SURFACE_MAPS):
        self.name, self.size_of, self.maps = name, size_of, maps

    def reflect(self, r: Reflection) -> None:
        if not r.peeked.render.texel_surface:  # shape only: the map's content does not depend on it
            return
        n = self.size_of(r)
        env = _env_vis_defines(r)
        from skinviewer.passes.environment import declare_env_fields, env_index
        i = env_index(r) if env else None
        if i is not None:  # the v map holds the vertex's shadowed irradiance (lib/mesh_vs.glsl): it follows the light
            declare_env_fields(r.settings.lights[i])
        r.program("texel_surface", **env)
        maps = texel_surface_resources(n, self.maps + ("v" if env else ""))
        r.plan(environment=i, maps=maps)
        for res in maps:
            r.output(res, TexSpec((n, n), 4, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        # a fragment output without an attachment is discarded: the program is the same for any maps
        prog = ec.program("texel_surface")
        if ec.plan.environment is not None:
            from skinviewer.passes.environment import set_environment
            set_environment(ec, prog, specular=False)  # the transfer vectors' radiance
        ec.draw_mesh(prog, *ec.plan.maps, depth_test=False)


def _env_vis_defines(r) -> dict[str, int]:
    """The environment light's defines when its baked visibility is used (ENV_RAYS > 0), else {}."""
    from skinviewer.passes.environment import depend_on_bake, env_defines, env_index
    d = env_defines(r)
    if d.get("ENV_RAYS", 0) > 0:
        depend_on_bake(r, whole(r.peeked.lights[env_index(r)]))
    return d if d.get("ENV_RAYS", 0) > 0 else {}


def texel_shading(r) -> bool:
    """render.texel_surface: texture-space shading reads the texel surface map (one fragment per
    texel) instead of rasterising the mesh unwrapped; r: a Reflection or ExecuteContext."""
    return bool(r.settings.render.texel_surface)


def shading_program(r, base: str) -> str:
    """The program of a texture-space shading pass: ``base`` (mesh unwrapped, vs/unwrap.vert) or
    ``base``_texels (full-screen over the texel surface map), per texel_shading."""
    return f"{base}_texels" if texel_shading(r) else base


@dataclass(frozen=True)
class Shading:
    """How a texture-space shading pass shades this frame: declare_shaded decides it (planned as
    ``shading``), execute reads ``ec.plan.shading`` (its program) and shade_dilated the rest."""
    program: str  # shading_program(r, base)
    size: int  # the map's side in texels
    texels: bool  # over the texel surface map (texel_shading), else the mesh unwrapped
    maps: str = ""  # the texel surface maps the program reads (TEXEL_SURFACE_MAPS, + "v": the environment's)


def declare_shaded(r: Reflection, base: str, size: int, resource: str, spec: TexSpec,
                   maps: str = TEXEL_SURFACE_MAPS, steps: bool = False, more: int = 0, **defines: object) -> None:
    """Declare a texture-space shading pass writing ``resource`` with its gutters filled, whichever
    way it shades (shading_program): declare_unwrapped, plus for the texel path the maps ``maps``
    it reads, TILED and TEXEL_STEPS (the position's change per texel, which only beam footprints
    need, from the neighbouring texels when a beam light is on, or ``steps``: samples over the texel).
    Plans ``shading`` (a Shading) for execute and shade_dilated."""
    if not texel_shading(r):
        r.plan(shading=Shading(base, size, False))
        declare_unwrapped(r, base, size, resource, spec, more=more, **defines)
        return
    if defines.get("ENV_LIGHT") and int(defines.get("ENV_RAYS", 0)) > 0:  # type: ignore[call-overload]  # the environment's AO per texel
        maps += "v"
        defines = {**defines, "ENV_TEXELS": 1}
    for res in texel_surface_resources(size, maps):
        r.input(res)
    steps = steps or any(light_on(light) and light.kind == "beam" for light in whole(r.settings.lights))
    r.plan(shading=Shading(shading_program(r, base), size, True, maps))
    declare_unwrapped(r, shading_program(r, base), size, resource, spec, more=more, TILED=1, TEXEL_STEPS=int(steps),
                      **defines)


def shade_dilated(ec, prog, resource: str, *more: str) -> None:
    """Run a pass declared with declare_shaded, as it planned (``ec.plan.shading``): unwrap_dilated, or
    one full-screen draw of ``prog`` over the texel surface map (samplers surface_p / surface_n / surface_v
    for its maps) on the tiles holding island texels, then the same dilation of the gutters."""
    shading = ec.plan.shading
    size, maps = shading.size, shading.maps
    if not shading.texels:
        unwrap_dilated(ec, prog, size, resource, *more)
        return
    for k, res in zip(maps, texel_surface_resources(size, maps)):
        ec.bind(prog, TEXEL_SURFACE_SAMPLERS[k], res)
    raws = _raws(ec, size, more)
    with ec.band():  # a tileable pass (issue 27): this band's rows; the dilation once all are shaded
        ec.draw_fullscreen(prog, *raws, tiles=work_tiles(ec, size, 0))
    if ec.last_tile:
        dilate_all(ec, raws, gutter_resource(size), (resource,) + more)


def _raws(ec, size: int, more: tuple[str, ...]) -> list:
    """The undilated targets of a texture-space shading draw, kept across a tileable pass's bands."""
    specs = [TexSpec((size, size), 4, "f4", filter="nearest")]
    specs += [TexSpec((size, size), ec.output(r).components, ec.output(r).dtype, filter="nearest") for r in more]
    return [ec.held(f"raw{i}", spec)[0] for i, spec in enumerate(specs)]


def unwrap_dilated(ec, prog, size: int, resource: str, *more: str) -> None:
    """Rasterise ``prog`` in texture space, then copy into ``resource`` with the gutters filled.
    ``more``: further outputs the program writes in the same draw (layout locations 1, 2, ...), each
    rasterised into a scratch of its own format and dilated the same way."""
    raws = _raws(ec, size, more)
    with ec.band():  # a tileable pass (issue 27): this band's rows; the dilation once all are drawn
        ec.draw_mesh(prog, *raws, depth_test=False, space="uv")
    if ec.last_tile:
        dilate_all(ec, raws, gutter_resource(size), (resource,) + more)


SEAM_REACH_TEXELS = 24.0  # gutter texels this close to a seam continue across it (blur taps reach ~3 sigma)


def seam_resource(size: int) -> str:
    return f"seam_{size}"


def seam_map(covered: np.ndarray, scene, texel_pos: np.ndarray) -> np.ndarray:
    """(H, W, 4) float32 for gutter texels near a UV seam (issue 10 item 1): RG the fractional
    texel coordinate of the surface point the texel stands for on the adjacent island, B = 1 there;
    B = 2 beyond a mesh border (scene/texels.border_gutters), 0 elsewhere; A = 1 on island texels
    whose nearest island edge is a mesh border, and past a border the share of the edge's light kept.
    Blur taps that leave their island read the source there, so they continue on the surface instead
    of repeating the island's edge texel (scene/texels.seam_indirection), and read no light past the
    surface's end; from a texel with A = 1 a tap in another island's zone is past that end too (it
    counts as no light, not as a dropped tap). Across a seam A = 1 marks a point snapped to the other
    island's nearest texel (the direct gather then continues this side's surface instead)."""
    size = covered.shape[0]
    mm = float(scene.mm_per_unit)
    texel_mm = 1.0 / (size * max(scene.mean_uv_per_mm, 1e-12))
    mapped, coords = seam_indirection(scene.mesh.positions, scene.mesh.uvs, scene.mesh.indices, covered,
                                      SEAM_REACH_TEXELS, mm, texel_pos.astype(np.float64) * mm, texel_mm)
    beyond, dist = border_gutters(scene.mesh.positions, scene.mesh.uvs, scene.mesh.indices, covered,
                                  SEAM_REACH_TEXELS)
    out = np.zeros((size, size, 4), np.float32)
    past = beyond & ~mapped & ~covered
    out[past, 2] = 2.0
    # A past a border: the share of the edge's value a gutter texel keeps, 1 - 2d (d its distance to
    # the border, texels): bilinear taps between it and the island's last texel then integrate to the
    # true edge, not to the gutter texel's centre
    out[past, 3] = np.clip(1.0 - 2.0 * dist[past], 0.0, 1.0)
    out[beyond & covered, 3] = 1.0
    out[mapped, :2] = coords[mapped]
    out[mapped, 2] = 1.0
    # A = 1 across a seam where the point fell outside the other island's texel centres and was snapped
    # to its nearest covered texel (whole coordinates): that texel's point is not the one it stands for
    out[mapped & np.all(coords == np.round(coords), axis=-1), 3] = 1.0
    return out


ZONE_IDS = 2047  # island zone ids stored as 1 + label % 2047: exact in half floats


def gutter_table(covered: np.ndarray) -> np.ndarray:
    """(H, W, 4) float32: RG = (x, y) of the nearest covered texel (itself when covered); B = the zone
    id of that texel's UV island (1 + label % ZONE_IDS of the islands' 8-connected components; 0 when
    nothing is covered), negative on the zone's border (a texel with a neighbour, 8-connected, in
    another zone): every texel belongs to the island nearest to it; A = the distance (texels)
    to the nearest texel of another zone. A blur tap that lands in another island's zone would read
    an unrelated part of the surface (issue 10: light across UV gutters); the blurs drop such taps,
    and A lets a texel whose taps all stay closer than that skip the test."""
    h, w = covered.shape
    out = np.zeros((h, w, 4), np.float32)
    if covered.any():
        from scipy import ndimage  # here, not at import: scipy costs start-up (issue 14 item 7)
        _, (iy, ix) = ndimage.distance_transform_edt(~covered, return_indices=True)
        label, _ = ndimage.label(covered, structure=np.ones((3, 3), bool))
        zone = label[iy, ix]
        # a texel next to (8-neighbourhood) one of another zone is on a zone border
        zp = np.pad(zone, 1, mode="edge")
        border = np.zeros((h, w), bool)
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                border |= zp[dy:dy + h, dx:dx + w] != zone
        safe = ndimage.distance_transform_edt(~border) if border.any() else np.full((h, w), 65504.0)
        # B < 0 on a zone border: a bilinear tap whose nearest texel has B = +zone blends only texels
        # of that zone, so one fetch per tap tells
        out[..., 2] = np.where(border, -1, 1) * (1 + (zone - 1) % ZONE_IDS)
        out[..., 3] = np.minimum(safe, 65504.0)
    else:
        iy, ix = np.mgrid[0:h, 0:w]
    out[..., 0] = ix
    out[..., 1] = iy
    return out


# issue 27: two shaded outputs (d'Eon's irradiance and visibility) dilated in one draw when the pass declared
# dilate DILATE_MORE (declare_shaded more=1); False: one draw each (the code before, for an A/B)
DILATE_PAIRS = os.environ.get("SKINVIEWER_DILATE_PAIRS", "1") != "0"


def dilate_all(ec, sources: list, gutter: str, targets: tuple) -> None:
    """Dilate each source into its target (``dilate``); a pair in one draw (dilate.frag DILATE_MORE) when
    the pass declared that variant: the same copies, one gutter fetch and one draw fewer."""
    if len(targets) == 2 and DILATE_PAIRS and ec.plan.dilate_pair:
        prog = ec.program("dilate", DILATE_MORE=1)
        ec.textures(prog, source=sources[0], source1=sources[1], gutter=gutter)
        outs = [ec.output(t) if isinstance(t, str) else t for t in targets]
        ec.set(prog, "u_limit", HALF_MAX if outs[0].dtype == "f2" else FLOAT_MAX)
        ec.set(prog, "u_limit1", HALF_MAX if outs[1].dtype == "f2" else FLOAT_MAX)
        ec.draw_fullscreen(prog, *targets)
        return
    for src, target in zip(sources, targets):
        dilate(ec, src, gutter, target)


def dilate(ec, source: moderngl.Texture | str, gutter: str, target: moderngl.Texture | str) -> None:
    """Copy ``source`` into ``target`` (an output or scratch texture) with the gutters filled from
    the nearest island texel. The calling pass must declare the program ``dilate``."""
    prog = ec.program("dilate")
    ec.textures(prog, source=source, gutter=gutter)
    tex = ec.output(target) if isinstance(target, str) else target
    ec.set(prog, "u_limit", HALF_MAX if tex.dtype == "f2" else FLOAT_MAX)
    ec.draw_fullscreen(prog, target)
