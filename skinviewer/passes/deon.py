"""d'Eon & Luebke 2007 (seed 000 §4.2 eq. 20-35; seed 002 §14.4): texture-space diffusion with a
sum-of-Gaussians profile, blurred separably and hierarchically, stretch-corrected, with energy
conservation (rho_dt) and the modified translucent shadow map.

Graph (resources in quotes):
    shadow_map_i        (shared)           per light pose
    deon_gutter         "gutter_N"         mesh, irradiance size
    deon_stretch        "deon_stretch"     mesh, mm_per_unit, size           (eq. 27)
    rho_dt_lut          "rho_dt_lut"       specular.f0, specular.rho_s        (eq. 30-31)
    deon_tsm            "deon_tsm"         key light pose, mesh, tsm size     (§4.2.7)
    deon_irradiance     "deon_irradiance"  lights, mix, albedo, TSM           (eq. 28, 32)
    deon_gather_surface "deon_gather_surface" mesh, size, seams            (points and areas per texel)
    deon_gather_weights_i "deon_gather_w{i}_{t}" surface, v_1..v_i, stretch  (a summed step's weights, kept
                                           across light moves: issue 27)
    deon_blur_i         "blur_i"           v_1..v_i, stretch toggle, input    (eq. 24-26; narrow
                                           steps: a direct sum over the surface, eq. 21)
    deon_transmitted    "deon_transmitted" TSM, blurs, weights                (eq. 33)
    deon_combine        "deon_diffuse"     weights, blurs, transmitted        (eq. 34's sum)
    deon_final          "lit"              camera, mix, specular, ...         (eq. 34-35)
    output              "image"

The key light of the TSM is the first enabled shadow-casting light (one TSM; other lights get no
transmitted term). Units: the stretch map holds UV per millimetre, so tap spacing in UV =
stretch * sigma_mm; TSM distances and thicknesses are in mm (mesh units * scene.mm_per_unit).
"""
from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from skinviewer.ground.constants import FLOAT_MAX, HALF_MAX, LIGHT_KINDS, MAX_GAUSSIANS, MAX_LIGHTS
from skinviewer.kernel.gl import compute_choice, gl_info, image_format, software_renderer
from skinviewer.kernel.pass_api import Pass, Reflection, TexSpec, declare, whole
from skinviewer.kernel.shaders import ShaderCompileError
from skinviewer.passes import texture_space
from skinviewer.passes.common import (
    LIT,
    bind_specular,
    bind_surface,
    declare_lighting,
    declare_lit,
    declare_pose,
    declare_specular,
    declare_view_mesh,
    draw_view_mesh,
    set_camera,
    set_lighting,
)
from skinviewer.passes.environment import declare_environment, env_defines, env_index, set_environment
from skinviewer.passes.luts import BECKMANN_LUT
from skinviewer.passes.rho_dt import RHO_DT_RESOURCE
from skinviewer.passes.rules import (
    analytic_on,
    coverage_size,
    frame_memo,
    kernel_under_pixel,
    light_map_size,
    light_on,
    tsm_needed,
)
from skinviewer.passes.texture_space import (
    TEXEL_SURFACE_MAPS,
    TEXEL_SURFACE_SAMPLERS,
    TILE,
    compute_tiles,
    declare_shaded,
    declare_unwrapped,
    dilate,
    drop_other_scenes,
    gutter_resource,
    per_tile,
    rasterize_unwrapped,
    read_gutter,
    rect_tiles,
    seam_resource,
    shade_dilated,
    texel_shading,
    texel_surface_resources,
    unwrap_dilated,
    work_tiles,
)
from skinviewer.passes.view_cull import (
    ViewTiles,
    gutter_links,
    island_origins,
    links,
    make_view_tiles,
    mask_rects,
    note_tiles,
    restrict,
    separable_draws,
    through_links,
    work_of,
)
from skinviewer.passes.view_cull import declare_inputs as declare_cull_inputs
from skinviewer.physics.diffusion import (
    IRRADIANCE,
    KERNEL7,
    BlurStep,
    blur_plan_texels,
    blur_resource,
    half_size_increment,
    stretch_blur_resource,
    sub_steps,
    texture_of,
)
from skinviewer.physics.specular import per_region_specular
from skinviewer.physics.surface_gather import KEPT_RINGS, SHORTCUT_RATIO, gather_blocks_for, weight_textures
from skinviewer.scene.camera import gl_bytes
from skinviewer.scene.texels import border_frame

STRETCH = "deon_stretch"
TSM = "deon_tsm"
DIFFUSE = "deon_diffuse"  # sum_i w_i blur_i + transmitted (DiffuseSumPass)
TRANSMITTED = "deon_transmitted"  # eq. 33 in texture space (TransmittedPass)
VISIBILITY = "deon_visibility"  # fac_shadow (eq. 10) per light slot and texel (deon.specular_shadows)
MAX_THICKNESS_MM = 100.0  # exp(-100^2 / 2 v) = 0 for every skin Gaussian
GATHER_SURFACE = "deon_gather_surface"  # per texel: point on the surface (mm), area (mm^2)
GATHER_BLOCKS_POINT = "deon_gather_blocks_point"  # per 2 x 2 block: mean point, area
GATHER_BLOCKS_ZONE = "deon_gather_blocks_zone"  # per 2 x 2 block: zone, spread
# issue 27: the summed step split in a weight pass (mesh, size, variance, stretch: kept across light moves)
# and a light pass that sums with them (deon_gather_weights.frag, deon_gather_sum.frag); False: the
# one-pass deon_surface_gather.frag, what benchmarks/bench_deon_draws.py --ab-unsplit-sum compares against
# (SKINVIEWER_SPLIT_SUM=0 in the environment: a whole run, e.g. the bench's ruler, without the split)
SPLIT_SUM = os.environ.get("SKINVIEWER_SPLIT_SUM", "1") != "0"
MRT = 8  # targets per draw of the weight pass (GL_MAX_DRAW_BUFFERS >= 8)
# the block rings whose light the sum takes at the light's own mean point (deon_gather_sum.frag LIT_RING);
# None: every ring; past it at the area's mean point (one fetch, no exp a block; notes/deon_light_move.md)
LIT_RING: int | None = int(os.environ["SKINVIEWER_LIT_RING"]) if os.environ.get("SKINVIEWER_LIT_RING") else None
# issue 27: the split sum four texels a fragment (deon_gather_quad.frag + deon_gather_pick.frag, the same
# values bit for bit): "auto" on a software rasterizer, which pays per fetch and lane (135 fetches a texel
# -> 49); a GPU's texture cache shares those fetches already. "1" / "0" (SKINVIEWER_QUAD_SUM): always / never.
QUAD_SUM = os.environ.get("SKINVIEWER_QUAD_SUM", "auto")
# issue 27 (session 9, notes/deon_light_move.md section 12): the summed step's seam fill as a plain copy on
# the tiles with no seam texel (seam_split), and deon_combine's fetch of a texture that two blur slots share
# once (blur_sources); each the same values bit for bit. SKINVIEWER_SUM_CUTS=0: both off, for an A/B
# (benchmarks/bench_deon_draws.py --ab-no-sum-cuts).
GATHER_FILL_SPLIT = os.environ.get("SKINVIEWER_SUM_CUTS", "1") != "0"
COMBINE_ONCE = os.environ.get("SKINVIEWER_SUM_CUTS", "1") != "0"


def map_size(r) -> int:
    """The irradiance-map size: deon.irradiance_size, or from the screen coverage (rules.py); asked
    by most passes, answered once a frame (rules.frame_memo)."""
    return frame_memo(r, "deon.map_size", _map_size)


def _map_size(r) -> int:
    d = r.settings.deon
    return coverage_size(r, d.irradiance_size, d.irradiance_size_mode, "deon_irradiance")


# -- which light casts the TSM --------------------------------------------------------------------

def tsm_light_index(r: Reflection) -> int | None:
    """_tsm_light_index, answered once a frame (rules.frame_memo: several passes ask)."""
    return frame_memo(r, "deon.tsm_light_index", _tsm_light_index)


def _tsm_light_index(r: Reflection) -> int | None:
    """Declare (and return) the light the TSM is rendered from: deon.tsm_light when it names an
    enabled shadow-casting light, else the first such light; None when deon.tsm is off or no light
    casts shadows. Reflect only: the passes plan it (``tsm_light``) for execute."""
    if not r.settings.deon.tsm:
        return None
    n = min(len(r.settings.lights), MAX_LIGHTS)
    usable = [j for j in range(n) if r.settings.lights[j].enabled and r.settings.lights[j].cast_shadow
              and analytic_on(whole(r.peeked.lights[j]))]
    want = r.settings.deon.tsm_light
    j = want if want is not None and want in usable else (usable[0] if usable else None)
    subpixel = kernel_under_pixel(r) if j is not None else None
    if subpixel:  # transmission is part of the diffusion
        r.drop(TSM, subpixel)
        return None
    if j is not None and r.settings.deon.tsm_auto and r.scene is not None:
        # issue 14: only when the light is behind a thin part in view (peeked: shape only)
        need, why = tsm_needed(r._settings, r.scene, whole(r.peeked.lights[j]), whole(r.peeked.deon.gaussians), r.view,
                               interactive=r.interactive)
        if not need:
            r.drop(TSM, why)
            return None
    return j


def set_tsm_uniforms(ec, prog, j: int | None, matrix: str = "u_tsm_matrix"):
    """The TSM light's uniforms (lib/deon.glsl; ``matrix``: the name of its light-space matrix in
    ``prog``). Returns its LightSpace. Only called by passes that read the TSM, so a light is named."""
    assert j is not None, "a TSM pass runs only when tsm_light_index names a light"
    scene = ec.scene
    pose = ec.settings.lights[j]
    ls = scene.light_space(pose)
    d = np.asarray(pose.direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    ec.uniforms(prog, **{matrix: gl_bytes(ls.gl_matrix)}, u_tsm_kind=LIGHT_KINDS[pose.kind],
                u_tsm_dir=tuple(float(x) for x in d), u_tsm_pos=tuple(float(x) for x in ls.position),
                u_mm_per_unit=float(scene.mm_per_unit))
    return ls


# -- passes --------------------------------------------------------------------------------------

SHEAR_COS_NONE = 1e-4  # a mesh whose UV axes are this close to orthogonal everywhere is not sheared


def stretch_defines(r) -> dict:
    return {"VERTEX_METRIC": 1} if r.settings.scene.stretch_metric == "vertex" else {}


class StretchPass(Pass):
    """eq. (27): UV per mm along u and v (RG) and the shear of the UV axes on the surface (B, the
    cosine between them: deon.stretch_shear), from derivatives while rasterising in texture space;
    gutters dilated. Depends on the mesh, mm_per_unit (scene) and the size only."""
    name = "deon_stretch"

    def __init__(self, name: str = "deon_stretch", resource: str = STRETCH, size_of=None):
        self.name, self.resource = name, resource
        self.size_of = size_of or map_size  # the map size it serves, given r (Gosselin: its light map)

    def reflect(self, r: Reflection) -> None:
        n = self.size_of(r)
        r.plan(size=n)
        declare_unwrapped(r, "deon_stretch", n, self.resource, TexSpec((n, n), 3, "f4"),  # RG stretch, B shear
                          **stretch_defines(r))

    def execute(self, ec) -> None:
        prog = ec.program("deon_stretch")  # the variant reflect declared (stretch_defines)
        ec.set(prog, "u_mm_per_unit", float(ec.scene.mm_per_unit))
        unwrap_dilated(ec, prog, ec.plan.size, self.resource)


class GatherSurfacePass(Pass):
    """What the direct gather of narrow blur steps sums over (shaders/deon_gather_surface.frag): per
    texel its point on the surface in mm and the area it stands for (its triangle's, eq. 27), with
    seam-filled gutters continuing across seams and area past mesh borders that holds no light.
    Depends on the mesh, mm_per_unit and the seam map only: once per scene and size."""
    name = "deon_gather_surface"

    def reflect(self, r: Reflection) -> None:
        if not gather_used(r):
            return
        n = map_size(r)
        seam = seam_resource(n) if r.settings.scene.seam_aware else None
        r.plan(size=n, gutter=gutter_resource(n), seam=seam, position=TexSpec((n, n), 4, "f4"),
               metric=TexSpec((n, n), 4, "f4", filter="nearest"))
        r.input(r.planned.gutter)
        if seam:
            r.input(seam)
        r.program("uv_position")
        r.program("deon_stretch")  # per triangle (eq. 27): a texel's area is its own triangle's
        r.program("dilate")
        r.program("deon_gather_surface", **({"SEAM": 1} if seam else {}))
        r.program("deon_gather_blocks", BLOCK_SURFACE=1)
        r.output(GATHER_SURFACE, TexSpec((n, n), 4, "f4", filter="nearest"))
        h = (n + 1) // 2
        r.output(GATHER_BLOCKS_POINT, TexSpec((h, h), 4, "f4", filter="nearest"))
        r.output(GATHER_BLOCKS_ZONE, TexSpec((h, h), 2, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        plan = ec.plan
        n, gutter, seam = plan.size, plan.gutter, plan.seam
        pos = ec.scratch(plan.position)  # dilated, so bilinear reads across seams stay on the surface
        dilate(ec, rasterize_unwrapped(ec, ec.program("uv_position"), n), gutter, pos)
        # the areas from each texel's own triangle, not the vertex metric the separable taps use (smooth
        # across triangles, so it spreads a jump in texel size over several texels: wrong weights there)
        metric = ec.program("deon_stretch")
        ec.set(metric, "u_mm_per_unit", float(ec.scene.mm_per_unit))
        stretch = ec.scratch(plan.metric)
        dilate(ec, rasterize_unwrapped(ec, metric, n), gutter, stretch)
        prog = ec.program("deon_gather_surface")  # SEAM when reflect planned a seam map
        ec.set(prog, "u_mm", float(ec.scene.mm_per_unit))
        ec.textures(prog, positions=pos, gutter=gutter, stretch_map=stretch)
        if seam:
            ec.bind(prog, "seam_map", seam)
        ec.draw_fullscreen(prog, GATHER_SURFACE)
        blocks = ec.program("deon_gather_blocks", BLOCK_SURFACE=1)
        ec.textures(blocks, surface=ec.output(GATHER_SURFACE), gutter=gutter)
        ec.draw_fullscreen(blocks, GATHER_BLOCKS_POINT, GATHER_BLOCKS_ZONE)


def weights_resource(i: int, t: int) -> str:
    """RGBA texture t of blur step i's summed-step weights (GatherWeightsPass)."""
    return f"deon_gather_w{i}_{t}"


def kept_textures(reach: int) -> int:
    """The weight textures a summed step of ``reach`` keeps: its rings up to KEPT_RINGS (19 at 3); the
    sum computes the weights of the rings past it itself (deon_gather_sum.frag LIVE)."""
    return weight_textures(min(reach, KEPT_RINGS))


def split_sum(r, step: BlurStep, n: int) -> bool:
    """Whether gathered blur step ``step`` is summed with kept weights (SPLIT_SUM): when its weight
    textures, the sum's five other textures, the tile list, the live rings' three (blocks' points and
    zones, stretch) and the flat rings' mean light fit the context's texture units (at most 29: the 29
    of 32 after the graph's dummies; else the one-pass sum)."""
    units = fragment_units(r.scene.ctx) - 3
    reach = gather_reach(r, step, n)
    need = kept_textures(reach) + 6 + (3 if reach > KEPT_RINGS else 0) + (1 if LIT_RING is not None else 0)
    return SPLIT_SUM and need <= units


def quad_sum(r, step: BlurStep, n: int) -> bool:
    """Whether split-summed step ``step`` sums four texels a fragment (QUAD_SUM): an even map. auto: on a
    software rasterizer (kernel/gl;
    off the GL thread before the renderer is known: as one, like compute_choice)."""
    if QUAD_SUM == "0" or n % 2:
        return False
    info = gl_info(r.scene.ctx)
    return QUAD_SUM == "1" or not info or software_renderer(r.scene.ctx)


def fragment_units(ctx) -> int:
    """GL_MAX_TEXTURE_IMAGE_UNITS, never queried off the GL thread (kernel/gl.gl_info; not read yet there:
    32, what every GL 3.3+ desktop driver has)."""
    return int(gl_info(ctx).get("GL_MAX_TEXTURE_IMAGE_UNITS", 32) or 32)


def bind_sheet_stretch(ec, prog) -> None:
    """The sheet test's stretch at x (eq. 27 with shear) for the gather's programs: the stretch map when
    the pass reads it, else the atlas' mean UV per mm; and the shortcut ratio (SHORTCUT_RATIO)."""
    stretch = ec.has_input(STRETCH)
    sc = ec.scene.mean_uv_per_mm
    ec.uniforms(prog, u_use_stretch=stretch, u_uniform_stretch=(sc, sc), u_shortcut=SHORTCUT_RATIO)
    if stretch:
        ec.bind(prog, "stretch_map", STRETCH)


class GatherWeightsPass(Pass):
    """The light-independent half of summed blur step i (issue 27; shaders/deon_gather_weights.frag,
    physics/surface_gather.gather_weights): per texel the normalised-to-the-centre weights of the
    36 inner texels and the outer blocks, packed 4 to an RGBA16F texel. Reads the gather surface, its
    blocks, the gutter map, the stretch map and the variances up to v_i: a light move keeps it."""

    def __init__(self, i: int):
        self.i = i
        self.name = f"deon_gather_weights_{i}"

    tileable = True  # in row bands: each band draws its rows of every group

    def reflect(self, r: Reflection) -> None:
        if len(r.peeked.deon.gaussians) <= self.i or not gather_used(r):
            return
        step = GaussianBlurPass(self.i)._step(r)
        if not gathered(r, step):
            return
        n = map_size(r)
        if not split_sum(r, step, n):
            return
        reach = min(gather_reach(r, step, n), KEPT_RINGS)  # the rings whose weights are kept
        count = weight_textures(reach)
        tiles = island_tiles(r, "irradiance", {"OPEN_BORDER": 1} if open_border(r) else {})  # the sum's tiles
        r.plan(size=n, step=step, gutter=gutter_resource(n), tiles=tiles)
        for res in (gutter_resource(n), GATHER_SURFACE, GATHER_BLOCKS_POINT, GATHER_BLOCKS_ZONE):
            r.input(res)
        if r.settings.deon.stretch:
            r.input(STRETCH)
        tiled = {"TILED": tiled_define()} if tiles else {}
        groups = []  # per draw: its outputs and its program's defines (up to MRT targets a draw)
        for g in range(-(-count // MRT)):
            outs = tuple(weights_resource(self.i, t) for t in range(MRT * g, min(count, MRT * (g + 1))))
            defines = {"GATHER_BLOCKS": reach, "GROUP": g, "OUTPUTS": len(outs), **tiled}
            r.program("deon_gather_weights", **defines)
            groups.append((outs, defines))
        r.plan(groups=tuple(groups))
        for t in range(count):
            r.output(weights_resource(self.i, t), TexSpec((n, n), 4, "f2", filter="nearest"))

    def execute(self, ec) -> None:
        plan = ec.plan
        n, step = plan.size, plan.step
        tiles = work_tiles(ec, n, DILATE_RING, rects=TILE_RECTS) if plan.tiles else None
        for outs, defines in plan.groups:  # as reflect planned them
            prog = ec.program("deon_gather_weights", **defines)
            ec.textures(prog, surface=GATHER_SURFACE, gutter=plan.gutter, blocks_p=GATHER_BLOCKS_POINT,
                        blocks_z=GATHER_BLOCKS_ZONE)
            ec.set(prog, "u_var", float(step.increment))
            bind_sheet_stretch(ec, prog)
            if tiles is not None and ec.first_tile:  # texels beyond the tiles: 0, not a pooled texture's
                for res in outs:
                    ec.clear_unwritten(res, (id(ec.scene), n, DILATE_RING))
            with ec.band():
                ec.draw_fullscreen(prog, *outs, tiles=tiles)


def border_resource(size: int) -> str:
    return f"deon_border_{size}"


BORDER_REACH_MM = 10.0  # the border frame reaches this far: 3.5 sigma of the widest skin Gaussian (2.7 mm)


def open_border(r) -> bool:
    """deon.open_border = reflect with scene.seam_aware (which knows where the mesh borders are), on a
    mesh that has an open border (peeked: a closed mesh, such as the default head, pays nothing)."""
    if r.scene is None or not r.peeked.scene.seam_aware or r.peeked.deon.open_border != "reflect":
        return False
    if not r.scene.has_open_border:
        return False
    return bool(r.settings.scene.seam_aware) and r.settings.deon.open_border == "reflect"


class BorderFramePass(Pass):
    """Per texel near a mesh border of its own island: the signed distance to the border's line and its
    inward normal (scene/texels.border_frame), for the blurs' open-border reflection (issue 30 item 5).
    Depends on the mesh and the size only (the coverage from the gutter map): once per scene and size."""
    name = "deon_border_frame"

    def reflect(self, r: Reflection) -> None:
        if not open_border(r):
            return
        n = map_size(r)
        r.plan(size=n, gutter=gutter_resource(n), border=border_resource(n))
        r.input(r.planned.gutter)
        r.output(r.planned.border, TexSpec((n, n), 4, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        from skinviewer.passes.texture_space import read_gutter
        n = ec.plan.size
        g = read_gutter(ec.input(ec.plan.gutter))
        iy, ix = np.mgrid[0:n, 0:n]
        covered = (g[..., 0] == ix) & (g[..., 1] == iy)
        m = ec.scene.mesh
        reach = min(float(n), BORDER_REACH_MM * ec.scene.max_uv_per_mm * n)
        ec.output(ec.plan.border).write(ec.scene.texel_table(
            ("border", n, hash(covered.tobytes())), lambda: border_frame(m.positions, m.uvs, m.indices, covered, reach).tobytes()))


def _gathers(step: BlurStep, limit: float, texel_mm: float) -> bool:
    return not step.reused and limit > 0.0 and np.sqrt(step.increment) <= limit * texel_mm


def gather_reach(r, step: BlurStep, n: int) -> int:
    """The summed step's reach in 2 x 2 blocks, from its sigma in mean texels (gather_blocks_for)."""
    return gather_blocks_for(np.sqrt(step.increment) / mean_texel_mm(r.scene, n))


def gathered(r, step: BlurStep) -> bool:
    """Whether blur step ``step`` is a direct sum over the surface (deon_surface_gather.frag): its
    sigma is at most deon.surface_gather_below_texels mean texels (issue 10 item 1)."""
    return _gathers(step, r.settings.deon.surface_gather_below_texels, mean_texel_mm(r.scene, map_size(r)))


def gather_used(r) -> bool:
    """Some blur step gathers (gathered(); peeked: whether the gather surface exists is shape, its
    content depends on the mesh, the size, the stretch and the seams only)."""
    limit = r.peeked.deon.surface_gather_below_texels  # shape only: the map's content depends on neither
    if limit <= 0.0 or r.scene is None:
        return False
    texel = mean_texel_mm(r.scene, map_size(r))
    variances = [r.peeked.deon.gaussians[k].variance for k in range(len(r.peeked.deon.gaussians))]
    plan = blur_plan_texels(variances, r.peeked.deon.reuse_irradiance_below_texels, texel, r.peeked.deon.fold_below_texels)
    return any(_gathers(st, limit, texel) for st in plan)


class TsmPass(Pass):
    """Modified TSM (§4.2.7) from the key light: R distance (mm), GB uv of the lit point, A cos."""
    name = "deon_tsm"

    def reflect(self, r: Reflection) -> None:
        j = tsm_light_index(r)
        if j is None:
            if TSM in r.dropped:  # the rule's reason (rules.tsm_needed)
                r.skip(r.dropped[TSM])
            return
        declare_pose(r.settings.lights[j])
        r.plan(tsm_light=j)
        n = light_map_size(r, r.settings.deon.tsm_size, r.settings.deon.irradiance_size_mode, "deon_tsm")
        r.program("deon_tsm")
        r.output(TSM, TexSpec((n, n), 4, "f4", filter="nearest", depth=True))

    def execute(self, ec) -> None:
        prog = ec.program("deon_tsm")
        set_tsm_uniforms(ec, prog, ec.plan.tsm_light, matrix="u_light_matrix")
        ec.draw_mesh(prog, TSM, clear=(0.0, 0.0, 0.0, -1.0))  # A < 0: no surface


TSM_MAX = "deon_tsm_max"  # the TSM's farthest first surface within four reaches, per block (TsmMaxPass)
TSM_MAX_BLOCK = 8  # TSM texels per block side (a 1024^2 TSM: a 128^2 map)
# deon_transmitted skips the texels the max proves get exactly 0 (lib/tsm_transmit.glsl TSM_SKIP);
# SKINVIEWER_TSM_SKIP=0 in the environment: a whole run without it (an A/B)
TSM_SKIP = os.environ.get("SKINVIEWER_TSM_SKIP", "1") != "0"
TSM_SKIP_MARK = False  # benchmarks and tests: a skipped texel comes out -1 (the share skipped), not 0
# the 3x3 taps' terms only for the Gaussians not gathered, and not for those the max map proves 0
# (lib/tsm_transmit.glsl TSM_TAPS_NARROW, TSM_TAPS_SKIP; exact); SKINVIEWER_TSM_TAPS=0: without (an A/B)
TSM_TAPS_CUT = os.environ.get("SKINVIEWER_TSM_TAPS", "1") != "0"
# the skip's threshold (lib/tsm_transmit.glsl TSM_ZERO): by default a term exp(-m^2 / (k2 v)) below 2^-24
# (e^-16.64) of its lit point's light counts as 0, so a texel (a Gaussian, its taps) whose every term is
# below it is skipped: |change| < 2^-24 x sum |w_i| x max E / 0.05 (E / cos A, clamped), the lit and
# displayed images bit-identical on the head and the scan, front- and back-lit, at the defaults
# (notes/deon_light_move.md section 14). SKINVIEWER_TSM_CUT=0 (or TSM_CUT = False): only what underflows
# to 0 in float32 is skipped (TSM_ZERO 110, bit for bit the loops' result)
TSM_CUT = os.environ.get("SKINVIEWER_TSM_CUT", "1") != "0"
TSM_CUT_ZERO = 16.64  # ln 2^24 = 16.636: e^-16.64 < 2^-24


def tsm_reach_texels(v_max: float, texel_mm: float, gather: int, k2: float) -> float:
    """How far (TSM texels) lib/tsm_transmit.glsl reads from C's texel: its gather's last spiral sample for
    the widest used Gaussian (variance ``v_max`` mm^2) when it is gathered (v > 4 texels^2), at
    sqrt(k2 v / 2) sqrt(-2 ln(0.5 / N)) mm; the 3x3 taps (1 texel) else."""
    if gather <= 0 or not texel_mm > 0.0 or not v_max > 3.9 * texel_mm * texel_mm:  # 3.9: the shader's 4, rounded
        return 1.0
    return max(1.0, math.sqrt(0.5 * k2 * v_max) * math.sqrt(2.0 * math.log(2.0 * gather)) / texel_mm)


def tsm_max_plan(r) -> tuple[int, int, tuple[int, int, int, int]]:
    """(TSM size, block, dilation in blocks of each of the max map's four channels) of deon_tsm_max,
    answered once a frame. Channel 0 reaches past every read of the widest Gaussian's gather; the others
    past the reads of narrower ones (the 3x3 taps' 1 texel for a Gaussian not gathered), so each Gaussian
    gets the tightest bound that covers its own reads: +3 texels of rounding (the shader checks it needs
    reach + 2 <= dilation * block). Peeked: the plan keys what the reaches depend on."""
    return frame_memo(r, "deon.tsm_max_plan", _tsm_max_plan)


def tsm_max_radii(reaches, n: int, block: int) -> tuple[int, int, int, int]:
    """The four channels' dilations (blocks) for Gaussians reading ``reaches`` TSM texels around C:
    the widest first (the texel's whole-skip bound before session 9), then the narrowest, then the
    others, widest first; repeated to fill four channels. Blocks cover reach + 3 texels."""
    blocks = -(-n // block)
    rad = sorted({min(math.ceil((x + 3.0) / block), blocks) if math.isfinite(x) else blocks for x in reaches} or {1})
    out = ([rad[-1]] + ([rad[0]] if len(rad) > 1 else []) + rad[-2:0:-1] + [rad[-1]] * 4)[:4]
    return int(out[0]), int(out[1]), int(out[2]), int(out[3])


def _tsm_max_plan(r) -> tuple[int, int, tuple[int, int, int, int]]:
    n = light_map_size(r, r.settings.deon.tsm_size, r.settings.deon.irradiance_size_mode, "deon_tsm")
    j = tsm_light_index(r)
    reaches = [1.0]
    if j is not None and r.scene is not None:
        g = whole(r.peeked.deon.gaussians)
        ls = r.scene.light_space(whole(r.peeked.lights[j]))
        k2 = 1.0 if r.peeked.deon.tsm_form == "printed" else 2.0
        texel_mm = ls.texel_world(n) * r.scene.mm_per_unit
        reaches += [tsm_reach_texels(float(x.variance), texel_mm, int(r.peeked.deon.tsm_gather), k2)
                    for x in g if any(w > 0 for w in x.weights)]
    return n, TSM_MAX_BLOCK, tsm_max_radii(reaches, n, TSM_MAX_BLOCK)


def tsm_max_covered(plan) -> tuple[float, float, float, float]:
    """TSM texels each channel of the max map covers past C's texel on each side (u_tsm_max_reach): the
    whole map when the dilation spans it."""
    n, block, radii = plan
    c = [1e30 if radius >= -(-n // block) else float(radius * block) for radius in radii]
    return c[0], c[1], c[2], c[3]


class TsmMaxPass(Pass):
    """The TSM's farthest first surface (largest t.r) around each block of TSM texels, dilated by the
    transmitted light's reach (shaders/deon_tsm_max.frag): deon_transmitted returns 0 before its loops
    for a texel that it proves every read leaves at exactly 0 (issue 27). Re-runs with the TSM (a
    light move) and when the reach changes; a camera move keeps it."""
    name = "deon_tsm_max"

    def reflect(self, r: Reflection) -> None:
        if not TSM_SKIP or tsm_light_index(r) is None:
            return
        plan = tsm_max_plan(r)
        n, block, _radii = plan
        r.plan(tsm_max=plan)
        r.input(TSM)
        r.program("deon_tsm_max", TSM_MAX_BLOCK=1)
        r.program("deon_tsm_max", TSM_MAX_BLOCK=0)
        nb = -(-n // block)
        spec = TexSpec((nb, nb), 4, "f4", filter="nearest")  # a channel per reach
        r.plan(spec=spec)  # the output's and its two scratch textures' (the blocks, one axis dilated)
        r.output(TSM_MAX, spec)

    def execute(self, ec) -> None:
        n, block, radii = ec.plan.tsm_max
        blocks, wide = ec.scratch(ec.plan.spec), ec.scratch(ec.plan.spec)
        prog = ec.program("deon_tsm_max", TSM_MAX_BLOCK=1)
        ec.bind(prog, "src", TSM)
        ec.set(prog, "u_block", int(block))
        ec.draw_fullscreen(prog, blocks)
        prog = ec.program("deon_tsm_max", TSM_MAX_BLOCK=0)
        ec.set(prog, "u_radii", tuple(int(x) for x in radii))
        for src, axis, dst in ((blocks, (1, 0), wide), (wide, (0, 1), TSM_MAX)):  # a box window, one axis each
            ec.bind(prog, "src", src)
            ec.set(prog, "u_axis", axis)
            ec.draw_fullscreen(prog, dst)


# issue 27: the irradiance split in a light-independent pass (IrradianceSurfacePass: the shading normal,
# C^mix, the specular parameters, the environment's term; kept across light moves) and the light pass
# (IrradiancePass, DEON_CACHED); bit-identical to the one-pass shader. SKINVIEWER_SPLIT_IRRADIANCE=0 in the
# environment: the one-pass shader, for before | after runs (notes/deon_light_move.md section 9)
SPLIT_IRRADIANCE = os.environ.get("SKINVIEWER_SPLIT_IRRADIANCE", "1") != "0"


def irradiance_surface_resource(k: int) -> str:
    """RGBA32F map k of the irradiance's light-independent values (IrradianceSurfacePass)."""
    return f"deon_irradiance_surface_{k}"


def split_irradiance(r) -> bool:
    """Whether the irradiance is shaded from the light-independent pass's maps: SPLIT_IRRADIANCE, over the
    texel surface map (render.texel_surface; the mesh unwrapped shades in one pass) and with one sample a
    texel (deon.texel_samples = 4 reads the normal map at four other uv per light: one pass)."""
    return bool(SPLIT_IRRADIANCE and texel_shading(r) and r.peeked.deon.texel_samples < 4)


def irradiance_surface_maps(r) -> int:
    """How many RGBA32F maps the light-independent pass writes: N and m, C^mix and rho_s, and with an
    environment light its term."""
    return 3 if env_index(r) is not None else 2


class IrradianceSurfacePass(Pass):
    """The light-independent half of the irradiance (issue 27; shaders/deon_irradiance_surface.frag, the
    first lines and the environment term of lib/deon_irradiance.glsl): per covered texel the shading
    normal N and m, C^mix and rho_s, and the environment's occluded irradiance at N with rho_dt's
    hemispherical mean (eq. 32), stored as exact float32. It reads the mesh, the map size, the albedo,
    normal, region and specular maps, deon.mix, the specular settings and the environment light: a
    light move keeps it. Tileable like the light pass (row bands)."""
    name = "deon_irradiance_surface"
    tileable = True

    def reflect(self, r: Reflection) -> None:
        if not split_irradiance(r):
            return
        n = map_size(r)
        env = declare_environment(r, specular=False)
        declare(r.settings.deon.mix)
        if r.settings.deon.energy_conservation:
            sp = r.settings.specular  # per-texel m and rho_s (specular_params; f0 is the rho_dt table's)
            declare(sp.m, sp.rho_s, sp.per_region)
            if env:  # rho_dt's hemispherical mean for the environment (eq. 32)
                r.input(RHO_DT_RESOURCE)
        maps = TEXEL_SURFACE_MAPS
        if env and int(env.get("ENV_RAYS", 0)) > 0:  # the environment's AO and shadowed irradiance per texel
            maps += "v"
            env = {**env, "ENV_TEXELS": 1}
        for res in (gutter_resource(n),) + texel_surface_resources(n, maps):
            r.input(res)
        r.program("deon_irradiance_surface", TILED=1, DEON_SURFACE=1, **env)
        outs = tuple(irradiance_surface_resource(k) for k in range(irradiance_surface_maps(r)))
        samplers = tuple((TEXEL_SURFACE_SAMPLERS[k], res) for k, res in zip(maps, texel_surface_resources(n, maps)))
        r.plan(size=n, samplers=samplers, outs=outs)
        for res in outs:
            r.output(res, TexSpec((n, n), 4, "f4", filter="nearest"))

    def execute(self, ec) -> None:
        plan = ec.plan
        n = plan.size
        prog = ec.program("deon_irradiance_surface")
        bind_surface(ec, prog)
        set_environment(ec, prog, specular=False)
        energy = bool(ec.settings.deon.energy_conservation)
        ec.uniforms(prog, u_energy=energy, u_mix=float(ec.settings.deon.mix), u_texel_uv=(1.0 / n, 1.0 / n))
        if energy:  # lib/specular_params.glsl's m and rho_s (bind_specular less the f0 this pass does not read)
            sp = ec.settings.specular
            m, rho = per_region_specular(sp)
            ec.uniforms(prog, u_spec_m=m, u_spec_rho_s=rho, u_spec_rho_s_table=float(sp.rho_s))
            ec.textures(prog, region_map=ec.scene.region_map, specular_map=ec.scene.specular_map)
            if ec.has_input(RHO_DT_RESOURCE):
                ec.bind(prog, "rho_dt_tex", RHO_DT_RESOURCE)
        for sampler, res in plan.samplers:  # the texel surface maps it reads
            ec.bind(prog, sampler, res)
        if ec.first_tile:  # texels beyond the island tiles: 0, not a pooled texture's
            for res in plan.outs:
                ec.clear_unwritten(res, (id(ec.scene), n, 0))
        with ec.band():
            ec.draw_fullscreen(prog, *plan.outs, tiles=work_tiles(ec, n, 0))


class IrradiancePass(Pass):
    """eq. (28)/(32) in texture space, thickness in alpha; float32; gutters dilated. Tileable: under
    the viewer's frame budget it is shaded in row bands, across frames (issue 27). Split (split_irradiance):
    the light pass, reading the light-independent values of IrradianceSurfacePass."""
    name = "deon_irradiance"
    tileable = True

    def reflect(self, r: Reflection) -> None:
        n = map_size(r)
        split = split_irradiance(r)
        energy = r.settings.deon.energy_conservation
        if split:  # N, C^mix, m, rho_s and the environment's term from the light-independent pass
            lighting = {**declare_lighting(r), "DEON_CACHED": 1,
                        "DEON_CACHED_ENV": int(irradiance_surface_maps(r) > 2)}
            cached = tuple(irradiance_surface_resource(k) for k in range(irradiance_surface_maps(r)))
            r.plan(cached=cached)
            for res in cached:
                r.input(res)
            if energy:
                declare(r.settings.specular.rho_s)  # the rho_s of the rho_dt table (surface_rho_dt)
                r.input(RHO_DT_RESOURCE)
        else:
            lighting = {**declare_lighting(r), **declare_environment(r, specular=False)}
            declare(r.settings.deon.mix)
            if energy:
                declare_specular(r, lut=False)  # per-texel m and rho_s for rho_dt(x, L)
                r.input(RHO_DT_RESOURCE)
        r.plan(split=split)
        over_texel = r.settings.deon.texel_samples > 1  # the texel's extent (TEXEL_STEPS) for its samples
        j = tsm_light_index(r)
        if j is not None:
            r.input(TSM)
        vis = texture_shadows(r)
        r.plan(tsm_light=j, visibility=vis)  # the TSM's light; each light's fac_shadow kept per texel
        # deon.texel_samples compiled in: a branch on a uniform costs both sides on llvmpipe (issue 27)
        declare_shaded(r, "deon_irradiance", n, IRRADIANCE, TexSpec((n, n), 4, "f4"), **lighting,
                       steps=over_texel, more=int(vis), DEON_VISIBILITY=int(vis),  # E and visibility dilated in one draw
                       DEON_TEXEL_SAMPLES=int(r.settings.deon.texel_samples))
        if vis:
            r.output(VISIBILITY, TexSpec((n, n), 4, "f2"))
        # deon.view_cull: the tiles the blurs, the transmitted light and the final pass read (over the texel map)
        vt = view_tiles(r) if r.planned.shading.texels else None
        r.plan(cull=(vt.n, vt.m) if vt is not None else None)
        if vt is not None:
            r.program("dilate", TILED=2)
            r.program("dilate", DILATE_MORE=1, TILED=2)
            declare_cull_inputs(r, vt)
            r.cover(vt.token)

    def execute(self, ec) -> None:
        n = ec.plan.shading.size
        prog = ec.program(ec.plan.shading.program)
        set_lighting(ec, prog)
        energy = bool(ec.settings.deon.energy_conservation)
        ec.uniforms(prog, u_energy=energy, u_texel_samples=int(ec.settings.deon.texel_samples),
                    u_texel_uv=(1.0 / n, 1.0 / n))
        if ec.plan.split:
            for k, res in enumerate(ec.plan.cached):
                ec.bind(prog, f"irr_surface{k}", res)
            if energy:
                ec.bind(prog, "rho_dt_tex", RHO_DT_RESOURCE)
                ec.uniforms(prog, u_spec_rho_s_table=float(ec.settings.specular.rho_s))
        else:
            bind_surface(ec, prog)
            set_environment(ec, prog, specular=False)
            ec.uniforms(prog, u_mix=float(ec.settings.deon.mix))
            if energy:
                ec.bind(prog, "rho_dt_tex", RHO_DT_RESOURCE)
                bind_specular(ec, prog)
        use_tsm = ec.plan.tsm_light is not None
        ec.uniforms(prog, u_tsm=use_tsm, u_max_thickness=MAX_THICKNESS_MM)
        if use_tsm:
            ec.bind(prog, "tsm_map", TSM)
            set_tsm_uniforms(ec, prog, ec.plan.tsm_light)
        # with texture shadows the same draw also writes each light's fac_shadow (location 1)
        more = (VISIBILITY,) if ec.plan.visibility else ()
        work = work_of(ec, IRRADIANCE)  # deon.view_cull: the tiles to make (None: every tile)
        if work is not None:
            seen = work_of(ec, VISIBILITY) if more else None
            work = work | seen if seen is not None else work
            note_tiles(ec, work)
            shade_tiles(ec, prog, IRRADIANCE, work, *more)
        else:
            shade_dilated(ec, prog, IRRADIANCE, *more)


def mean_texel_mm(scene, n: int) -> float:
    """The atlas's mean texel size in mm at an n x n map (from UV area / surface area)."""
    return 1.0 / (n * scene.mean_uv_per_mm)


def plan_of(variances, r) -> list:
    """The blur chain for these variances (r: a Reflection or ExecuteContext of a scene pass); every
    blur is the irradiance itself when the kernel is under a pixel on screen (rules.py)."""
    if kernel_under_pixel(r):
        return [BlurStep(i, IRRADIANCE, 0.0, 0.0, True) for i in range(len(variances))]
    return blur_plan_texels(variances, r.settings.deon.reuse_irradiance_below_texels,
                            mean_texel_mm(r.scene, map_size(r)), r.settings.deon.fold_below_texels)


def _plan(r):
    return frame_memo(r, "deon._plan", lambda rr: plan_of([g.variance for g in whole(rr.settings.deon.gaussians)], rr))




# the blurs' island tiles as merged rectangles (texture_space.tile_rects, TILED=2); False: one quad per 16^2
# tile as before (TILED=1), what benchmarks/bench_blur_floor.py's "before" sets to compare in one run
TILE_RECTS = True

DILATE_RING = 3  # texels past the islands a bilinear reader of a blur reaches (seam fill <= 1.42, deon_final)


def tiled_define() -> int:
    """The TILED define of vs/fullscreen.vert for the blurs' tile lists (TILE_RECTS)."""
    return 2 if TILE_RECTS else 1


def island_tiles(r, chain: str, border: dict) -> bool:
    """deon.skip_gutters with the seam fill of a light blur (issue 27): the blur draws only the tiles
    within DILATE_RING texels of an island, and its seam fill reads every texel at the island texel
    the gutter map names (seam_fill.frag DILATE), which is where the blur computes a gutter texel
    anyway: the texels readers reach are bit-identical, ~30 % fewer texels shaded at 1024^2."""
    return bool(r.settings.deon.skip_gutters and r.settings.scene.seam_aware and chain == "irradiance"
                and not border)


def stretch_of(source: str) -> str:
    """The stretch map that goes with a blur input: the raw one for the irradiance, else the stretch
    convolved like that input (deon.stretch_per_gaussian)."""
    return STRETCH if source == IRRADIANCE else stretch_blur_resource(int(source.rsplit("_", 1)[1]))


HALF_MIN = 64  # no half-size blurs under a 128^2 map


def half_size(r, i: int) -> bool:
    """deon.half_res_above_texels (issue 27): whether blur_i is made on a map of half the side
    (transmitted_size: the half-size gutter and seam maps already exist): a separable light blur whose
    sigma increment is at least that many mean texels, or whose input is half size already. The
    summed step, a mesh with an open border (the reflection's border frame is full size; with
    deon.open_border = absorb the half-size fill would carry light past the rim that absorb drops)
    and the per-Gaussian stretch chain stay full size. r: a Reflection or ExecuteContext."""
    limit = r.settings.deon.half_res_above_texels
    if limit <= 0.0 or r.scene is None or r.scene.has_open_border or r.settings.deon.stretch_per_gaussian:
        return False
    n = map_size(r)
    if n // 2 < HALF_MIN or transmitted_size(r) != n // 2:
        return False
    plan = _plan(r)
    if i >= len(plan):
        return False
    step = plan[i]
    if step.reused or gathered(r, step):
        return False
    if np.sqrt(step.increment) >= limit * mean_texel_mm(r.scene, n):
        return True
    return step.source != IRRADIANCE and half_size(r, int(step.source.rsplit("_", 1)[1]))


def texture_size(r, resource: str) -> int:
    """The side of a light blur chain's texture: the irradiance map's, or half of it for a half-size blur."""
    if resource == IRRADIANCE:
        return map_size(r)
    return transmitted_size(r) if half_size(r, int(resource.rsplit("_", 1)[1])) else map_size(r)


class GaussianBlurPass(Pass):
    """blur_i = blur_(i-1) (x) G(v_i - v_(i-1)) (eq. 24), H then V (7 taps, eq. 25-26). Declares the
    variances up to v_i (not the weights), the stretch toggles, its input and the stretch map.

    ``chain="stretch"`` runs the same convolution on the stretch map instead (seed 000 end of
    §4.2.4, deon.stretch_per_gaussian): stretch_blur_i, which blur_(i+1) then uses for its taps, so
    a wide Gaussian sees the average distortion of its footprint rather than the centre texel's."""

    def __init__(self, i: int, chain: str = "irradiance"):
        self.i = i
        self.chain = chain
        self.name = f"deon_blur_{i}" if chain == "irradiance" else f"deon_stretch_blur_{i}"

    tileable = True  # in row bands: the summed step's one draw, or each separable draw in turn

    def _output(self) -> str:
        return blur_resource(self.i) if self.chain == "irradiance" else stretch_blur_resource(self.i)

    def _stretch_input(self, r, step) -> str | None:
        if not r.settings.deon.stretch:
            return None
        return stretch_of(step.source) if r.settings.deon.stretch_per_gaussian else STRETCH

    def reflect(self, r: Reflection) -> None:
        if len(r.peeked.deon.gaussians) <= self.i:
            return
        if self.chain == "stretch" and not (r.peeked.deon.stretch and r.peeked.deon.stretch_per_gaussian):
            return
        step = self._step(r)
        if step.reused:  # blur_i is its source: the final pass reads that, this pass is pruned
            subpixel = kernel_under_pixel(r)
            if subpixel:
                r.skip(subpixel)
                return
            d = r.settings.deon
            r.skip(f"kernel under {d.fold_below_texels if self.i else d.reuse_irradiance_below_texels}"
                   f" texel: {'folded into the next blur' if self.i else 'the irradiance itself'}")
            return
        n = map_size(r)
        gather = self.chain == "irradiance" and gathered(r, step)
        border = self._open_border(r)
        half = self.chain == "irradiance" and half_size(r, self.i)
        m = transmitted_size(r) if half else n  # this blur's map (deon.half_res_above_texels)
        # the input's map: the irradiance's, or a blur's (half size when that blur is)
        n_in = texture_size(r, step.source) if self.chain == "irradiance" else n
        seam = seam_resource(m) if r.settings.scene.seam_aware else None
        # what execute reads (ec.plan): the step, the map, its resources and which draws it makes
        r.plan(step=step, size=m, size_in=n_in, half=half, full=n, gather=gather, output=self._output(), spec=self._spec(m),
               gutter=gutter_resource(m), seam=seam, border=border_resource(n) if border else None,
               island_tiles=island_tiles(r, self.chain, border))
        if gather:
            self._reflect_gather(r, step, n)
            return
        stretch = self._stretch_input(r, step)
        if stretch:
            declare(r.settings.deon.stretch_shear)
        skip_gutters = r.settings.deon.skip_gutters
        if seam:
            r.input(seam)
        source = step.source if self.chain == "irradiance" else stretch_of(step.source)
        r.input(source)
        r.input(gutter_resource(m))
        if stretch:
            r.input(stretch)
        tiled = {"TILED": tiled_define()} if skip_gutters else {}
        zones = {"ISLAND_ZONES": 1} if seam else {}  # taps never land on another UV island
        dilate_fill = {"DILATE": 1, **tiled} if r.planned.island_tiles else {}
        if border:
            r.input(border_resource(n))
            r.input(IRRADIANCE)  # E at the border (lib/open_border.glsl)
        narrow = {} if half else self._narrow(r, step, stretch, n)
        # with island tiles, the tiles where no tap can reach another zone take a variant without the
        # zone checks (zone_split; issue 27): the same values, without the masked zone fetches
        split = bool(zones) and bool(skip_gutters) and not border
        blur_defines = {**tiled, **zones, **border, **narrow}
        # render.compute_blur (issue 27): every draw below as its compute twin (deon_blur_cs, seam_fill_cs)
        compute = compute_blur(r)
        r.plan(stretch=stretch, source=source, skip_gutters=bool(skip_gutters), narrow=bool(narrow),
               ring_sigma=ring_sigma(r, self.i), blur_defines=blur_defines, zone_split=split, compute=compute)
        self._declare_cull(r)
        spec = self._spec(m)
        blur_program(r, compute, spec, "deon_blur", **blur_defines)
        if split:
            blur_program(r, compute, spec, "deon_blur", **blur_defines, NO_ZONE_CHECKS=1)
        if seam:
            fill_defines = {**(dilate_fill or tiled), **border}
            # the fill's tiles with no texel across a seam or past a border take a plain copy (seam_split)
            plain = bool(fill_defines.get("TILED") == 2) and not border
            r.plan(fill_defines=fill_defines, seam_split=plain)
            for extra in ({}, {"NO_SEAM": 1}) if plain else ({},):
                blur_program(r, compute, spec, "seam_fill", **fill_defines, **extra)
                if n_in != m:  # a half-size blur's full-size input, seam-filled at half size (seam_fill DOWN)
                    blur_program(r, compute, spec, "seam_fill", DOWN=1, **fill_defines, **extra)
        r.output(self._output(), spec)

    def _declare_cull(self, r) -> None:
        """deon.view_cull: the tiles this blur's readers need (view_cull.stage_needs), when its stage is cullable."""
        vt = view_tiles(r) if self.chain == "irradiance" else None
        stage = cull_stage(vt, self.i) if vt is not None else None
        r.plan(cull=(vt.n, vt.m) if stage is not None and vt is not None else None, cull_stage=stage)
        if stage is not None and vt is not None:
            declare_cull_inputs(r, vt)
            r.cover(vt.token)

    def _reflect_gather(self, r, step, n: int) -> None:
        """A narrow step as a direct sum over the surface: the gather surface, the step's input
        (seam-filled first with scene.seam_aware) and the island zones."""
        seam = r.settings.scene.seam_aware
        r.input(step.source)
        r.input(gutter_resource(n))
        r.input(GATHER_SURFACE)
        # the one-pass sum computes the weights itself; the split one those of the rings past KEPT_RINGS
        if not split_sum(r, step, n) or gather_reach(r, step, n) > KEPT_RINGS:
            r.input(GATHER_BLOCKS_POINT)
            r.input(GATHER_BLOCKS_ZONE)
            if r.settings.deon.stretch:
                r.input(STRETCH)
        tiles = r.planned.island_tiles
        h = (n + 1) // 2
        r.plan(blocks=TexSpec((h, h), 4, "f4", filter="nearest"))  # the 2 x 2 block sums, kept across bands
        if seam:
            r.input(seam_resource(n))
            border = self._open_border(r)
            if border:  # the rim texels' share on the surface (seam_fill's RIM_SHARE)
                r.input(border_resource(n))
                r.input(IRRADIANCE)
            dilate = {"DILATE": 1} if tiles and step.source != IRRADIANCE else {}  # never with a border
            fill = {**dilate, **border, **({"RIM_SHARE": 1} if border else {})}
            # issue 27: the fill over the whole map as rectangles, those with no texel across a seam as a
            # plain copy (seam_split, as the separable blurs' fills; NO_SEAM is void with a border)
            fill_split = GATHER_FILL_SPLIT and TILE_RECTS and not border
            r.plan(fill=fill, fill_split=fill_split)
            if fill_split:
                for extra in ({}, {"NO_SEAM": 1}):
                    r.program("seam_fill", **fill, TILED=2, **extra)
            else:
                r.program("seam_fill", **fill)
        reach = gather_reach(r, step, n)
        tiled = {"TILED": tiled_define()} if tiles else {}
        if split_sum(r, step, n):  # the weights kept by GatherWeightsPass; the light summed with them here
            count = kept_textures(reach)
            r.plan(weights=[weights_resource(self.i, t) for t in range(count)], live=reach > KEPT_RINGS)
            for res in r.planned.weights:
                r.input(res)
            flat = {"LIT_RING": LIT_RING} if LIT_RING is not None and LIT_RING < reach else {}
            r.plan(flat=bool(flat))
            r.program("deon_gather_blocks", MEAN_THICKNESS=1, **({"MEAN_LIGHT": 1} if flat else {}))
            quad = quad_sum(r, step, n)
            r.plan(quad=quad)
            if quad:  # four texels a fragment at half size, then each texel picked (issue 27)
                r.program("deon_gather_quad", GATHER_BLOCKS=reach, WEIGHT_TEXTURES=count, KEPT_RINGS=KEPT_RINGS,
                          **tiled, **flat)
                r.program("deon_gather_pick", **tiled)
            else:
                r.program("deon_gather_sum", GATHER_BLOCKS=reach, WEIGHT_TEXTURES=count, KEPT_RINGS=KEPT_RINGS,
                          **tiled, **flat)
        else:
            r.plan(weights=None, quad=False)
            r.program("deon_gather_blocks")
            r.program("deon_surface_gather", GATHER_BLOCKS=reach, **tiled)
        self._declare_cull(r)
        r.output(self._output(), self._spec(n))

    def _execute_gather(self, ec) -> None:
        plan = ec.plan
        step, n, gutter = plan.step, plan.size, plan.gutter
        source = step.source
        tiled = plan.island_tiles
        work = work_of(ec, plan.output)  # deon.view_cull: the tiles to make (None: every tile)
        if work is not None and not work.any():
            note_tiles(ec, work)
            return
        # the seam fill and the block sums are made once (first band) and kept across the bands
        if plan.seam:  # gutters across seams hold the surface there
            filled, fresh = ec.held("filled", plan.spec)
            if fresh:
                dilating = tiled and source != IRRADIANCE  # the irradiance is whole: dilated already
                # the variant(s) reflect declared (DILATE, OPEN_BORDER, RIM_SHARE; TILED = 2 with its NO_SEAM twin)
                fill_sets = seam_split(ec, n, whole_target(ec, n)) if plan.fill_split else None
                if fill_sets is None:
                    parts = [(ec.program("seam_fill", **plan.fill, **({"TILED": 2} if plan.fill_split else {})),
                              whole_target(ec, n) if plan.fill_split else None)]
                else:
                    parts = [(ec.program("seam_fill", **plan.fill, TILED=2, **extra), where)
                             for extra, where in (({}, fill_sets[0]), ({"NO_SEAM": 1}, fill_sets[1])) if where is not None]
                for fill, where in parts:
                    ec.textures(fill, source=source, seam_map=plan.seam)
                    if dilating:
                        ec.bind(fill, "gutter", gutter)
                    ec.set(fill, "u_past_border_dark", True)
                    if plan.border:  # a texel the border crosses counts its share on the surface; no reflection
                        ec.textures(fill, border_map=plan.border, irradiance_map=IRRADIANCE)
                        ec.set(fill, "u_reflect", 0)
                    ec.draw_fullscreen(fill, filled, tiles=where)
            source = filled
        split = plan.weights is not None
        flat = split and plan.flat  # the rings past LIT_RING read the blocks' mean light
        held = [ec.held(k, plan.blocks) for k in ("light", "lit", "mean")[:3 if flat else 2]]
        light, lit = held[0][0], held[1][0]
        if held[0][1]:
            prog = ec.program("deon_gather_blocks", **({"MEAN_THICKNESS": 1} if split else {}),
                              **({"MEAN_LIGHT": 1} if flat else {}))
            ec.textures(prog, source=source, surface=GATHER_SURFACE)
            ec.draw_fullscreen(prog, *(t for t, _ in held))
        texels = np.sqrt(step.increment) / mean_texel_mm(ec.scene, n)
        note_tiles(ec, work, f"summed over the surface: sigma {texels:.2f} mean texels", sigma_texels=float(texels))
        if split and plan.quad:  # four texels a fragment (deon_gather_quad.frag), then picked per texel
            self._execute_quad(ec, source, light, lit, held[2][0] if flat else None)
            return
        if split:  # the light-dependent half: E, the blocks' light and the kept weights
            prog = ec.program("deon_gather_sum")  # GATHER_BLOCKS, WEIGHT_TEXTURES and TILED as reflect declared
            ec.textures(prog, source=source, surface=GATHER_SURFACE, gutter=gutter, blocks_e=light, blocks_l=lit)
            if flat:
                ec.bind(prog, "blocks_m", held[2][0])
            if plan.live:  # the rings past KEPT_RINGS: their weights computed in the sum
                ec.textures(prog, blocks_p=GATHER_BLOCKS_POINT, blocks_z=GATHER_BLOCKS_ZONE)
                bind_sheet_stretch(ec, prog)
            for t, res in enumerate(plan.weights):
                ec.bind(prog, f"w{t}", res)
            ec.set(prog, "u_var", float(step.increment))
        else:
            prog = ec.program("deon_surface_gather")  # GATHER_BLOCKS (gather_reach) and TILED as reflect declared
            ec.textures(prog, source=source, surface=GATHER_SURFACE, gutter=gutter, blocks_e=light,
                        blocks_p=GATHER_BLOCKS_POINT, blocks_z=GATHER_BLOCKS_ZONE, blocks_l=lit)
            ec.set(prog, "u_var", float(step.increment))
            bind_sheet_stretch(ec, prog)
        if tiled and ec.first_tile:  # texels beyond the tiles: 0, not a pooled texture's
            ec.clear_unwritten(plan.output, (id(ec.scene), n, DILATE_RING))
        tiles = work_tiles(ec, n, DILATE_RING, rects=TILE_RECTS) if tiled else None
        if work is not None:  # each texel is its island texel's sum: those of the tiles to make
            tiles = restrict(ec, "sum", tiles, through_links(work, links(ec, n)[1]), n)
            if tiles is None:
                return
        with ec.band():
            ec.draw_fullscreen(prog, plan.output, tiles=tiles)

    def _execute_quad(self, ec, source, light, lit, mean) -> None:
        """The split sum as deon_gather_quad.frag (the island texels, four a fragment, into four half-size
        float32 sums kept across the bands) and deon_gather_pick.frag (each texel its island texel's sum):
        two draws in sequence over the bands (ExecuteContext.units), the same tiles."""
        plan = ec.plan
        n, h = plan.size, plan.size // 2
        quads = [ec.held(f"quad{t}", TexSpec((h, h), 4, "f4", filter="nearest"))[0] for t in range(4)]
        prog = ec.program("deon_gather_quad")  # GATHER_BLOCKS, WEIGHT_TEXTURES, TILED as reflect declared
        ec.textures(prog, source=source, surface=GATHER_SURFACE, blocks_e=light, blocks_l=lit)
        if mean is not None:
            ec.bind(prog, "blocks_m", mean)
        for t, res in enumerate(plan.weights):
            ec.bind(prog, f"w{t}", res)
        ec.set(prog, "u_var", float(plan.step.increment))
        if plan.live:  # the rings past KEPT_RINGS: their weights computed in the sum
            ec.textures(prog, gutter=plan.gutter, blocks_p=GATHER_BLOCKS_POINT, blocks_z=GATHER_BLOCKS_ZONE)
            bind_sheet_stretch(ec, prog)
        pick = ec.program("deon_gather_pick")
        ec.bind(pick, "gutter", plan.gutter)
        for t, q in enumerate(quads):
            ec.bind(pick, f"q{t}", q)
        tiles = work_tiles(ec, n, DILATE_RING, rects=TILE_RECTS) if plan.island_tiles else None
        if tiles is not None and ec.first_tile:  # texels beyond the tiles: 0, not a pooled texture's
            ec.clear_unwritten(plan.output, (id(ec.scene), n, DILATE_RING))
        quad_tiles = pick_tiles = tiles
        work = work_of(ec, plan.output)  # deon.view_cull: the tiles to make, and their island texels' sums
        if work is not None:
            pick_tiles = restrict(ec, "pick", tiles, work, n)
            quad_tiles = restrict(ec, "quad", tiles, through_links(work, links(ec, n)[1]), n, output=False)
        for d, sub, subs in ec.units(2):
            with ec.band(sub, subs):
                if work is not None and (quad_tiles if d == 0 else pick_tiles) is None:
                    continue  # deon.view_cull: no tile of this draw is to be made
                if d == 0:  # the tiles' rectangles are in the map's texels: the half-size target's twice
                    ec.draw_fullscreen(prog, *quads, tiles=quad_tiles, tile_space=(n, n))
                else:
                    ec.draw_fullscreen(pick, plan.output, tiles=pick_tiles)

    def _spec(self, n: int) -> TexSpec:
        return TexSpec((n, n), 4 if self.chain == "irradiance" else 2, "f4")  # the stretch chain: RG

    def _open_border(self, r) -> dict:
        """{"OPEN_BORDER": 1} when this light blur reflects the light past open borders (open_border)."""
        return {"OPEN_BORDER": 1} if self.chain == "irradiance" and open_border(r) else {}

    def _step(self, r):
        i = self.i

        def step(rr):  # blur i declares the variances up to its own: its key is the chain's prefix
            return plan_of([rr.settings.deon.gaussians[k].variance for k in range(i + 1)], rr)[i]
        return frame_memo(r, ("deon._step", i), step)

    @staticmethod
    def _narrow(r, step, stretch: str | None, n: int) -> dict:
        """Issue 10 item 5: a sigma of 1 (mean) to NARROW_TEXELS (largest stretch, deon_stretch's
        maximum from the mesh) texels takes whole-texel taps, NARROW_TAPS covering 3 sigma; under a
        texel the bilinear 7 taps' own smoothing is closer to the texel integral. {} or the define."""
        sigma = np.sqrt(step.increment)
        widest = sigma * (r.scene.max_uv_per_mm if stretch else r.scene.mean_uv_per_mm) * n
        sheared = stretch and r.settings.deon.stretch_shear and r.scene.max_shear_cos > SHEAR_COS_NONE
        if sigma < mean_texel_mm(r.scene, n) or widest > NARROW_TEXELS or sheared:
            return {}
        return {"NARROW_TAPS": narrow_taps(widest)}

    def execute(self, ec) -> None:
        plan = ec.plan
        if plan.gather:
            self._execute_gather(ec)
            return
        step, n, stretch, narrow, border = plan.step, plan.size, plan.stretch, plan.narrow, plan.border
        work = work_of(ec, plan.output)  # deon.view_cull: the tiles to make (None: every tile)
        if work is not None and not work.any():
            note_tiles(ec, work)
            return
        compute = plan.compute  # render.compute_blur: the compute twins of the same programs (blur_program)

        def program(name: str, **defines: Any) -> Any:
            name, d = blur_variant(compute, plan.spec, name, defines)
            return ec.program(name, **d)
        try:
            prog = program("deon_blur", **plan.blur_defines)  # TILED, ISLAND_ZONES, OPEN_BORDER, NARROW_TAPS
            free = program("deon_blur", **plan.blur_defines, NO_ZONE_CHECKS=1) if plan.zone_split else None
            if compute and plan.seam:
                program("seam_fill", **plan.fill_defines)
        except ShaderCompileError as exc:
            if not compute:
                raise
            # a driver whose compiler refuses the compute twins: the fragment draws reflect also declared
            compute = False
            compute_failed = f"compute blur did not compile ({exc.errors[0] if exc.errors else exc.name}): fragment draws; "
            prog = program("deon_blur", **plan.blur_defines)
            free = program("deon_blur", **plan.blur_defines, NO_ZONE_CHECKS=1) if plan.zone_split else None
        else:
            compute_failed = ""
        progs = (prog, free) if free else (prog,)
        s = 1.0 if stretch else ec.scene.mean_uv_per_mm
        for p_ in progs:
            ec.uniforms(p_, u_use_stretch=bool(stretch), u_uniform_stretch=(s, s),
                        u_weights=np.asarray(KERNEL7, np.float32),
                        u_shear=bool(stretch) and bool(ec.settings.deon.stretch_shear))
        sigmas = blur_sigmas(ec.scene, step, n, plan.half, plan.size_in, plan.full, narrow)
        for p_ in progs:
            ec.bind(p_, "gutter", plan.gutter)
            if stretch:
                ec.bind(p_, "stretch_map", stretch)
        spec = plan.spec
        # scratch kept across the pass's bands (ExecuteContext.held): a blur runs in row bands
        # under the viewer's frame budget, each draw complete before the next one's first band
        tmp = ec.held("tmp", spec)[0]
        tmp2 = ec.held("tmp2", spec)[0] if len(sigmas) > 1 else None
        seam = plan.seam
        # a half-size blur's first pass reads its full-size input: that is seam-filled at its own size
        n_in = plan.size_in
        filled = ec.held("filled", spec)[0] if seam else None
        dilate_fill = bool(seam) and plan.island_tiles
        fill = program("seam_fill", **plan.fill_defines) if seam else None  # the variant reflect declared
        # a half-size blur's full-size input: filled at half size, each texel the 2 x 2 it covers (DOWN)
        down = program("seam_fill", DOWN=1, **plan.fill_defines) if seam and n_in != n else None
        if border:
            for p_ in (prog, fill):  # never half size: no DOWN fill
                ec.bind(p_, "border_map", border)
                ec.bind(p_, "irradiance_map", IRRADIANCE)
        # the plain-copy variants for the fill's tiles without seam or border texels (seam_split)
        plain_fill = program("seam_fill", **plan.fill_defines, NO_SEAM=1) if seam and plan.seam_split else None
        plain_down = (program("seam_fill", DOWN=1, **plan.fill_defines, NO_SEAM=1)
                      if down is not None and plan.seam_split else None)
        if seam:
            light = self.chain == "irradiance"
            for p_ in (fill, down, plain_fill, plain_down):
                if p_ is not None:
                    ec.set(p_, "u_past_border_dark", light)
            for p_ in progs:
                ec.bind(p_, "seam_map", seam)
                ec.set(p_, "u_absorb", light)
        src = plan.source
        # the blur draws the texels a reader can reach: with a dilating seam fill the islands and
        # DILATE_RING (its taps read the fill), else the ring its own and the next blur's taps reach
        reach = blur_ring(ec, n, stretch, plan.ring_sigma)
        tiles = work_tiles(ec, n, DILATE_RING if dilate_fill else reach, rects=TILE_RECTS) if plan.skip_gutters else None
        # a dilating fill: over the tiles this blur's taps reach (measured: splitting it into a plain
        # fill on the island tiles and a dilating one beyond them costs one draw more and saved nothing)
        fill_tiles = work_tiles(ec, n, reach, rects=TILE_RECTS) if dilate_fill else tiles
        # the blur's tiles as (program, tiles) draws: those where a tap may reach another zone with the
        # checks, the rest without (zone_split); one draw when no tile is free of them
        parts = [(prog, tiles)]
        if free is not None and tiles is not None and TILE_RECTS:  # zone_split draws rectangles (TILED = 2)
            ring = DILATE_RING if dilate_fill else reach
            widest = float(max(sigmas))
            if narrow:  # whole-texel taps: ISLAND_CHECK(NARROW_TAPS + 0.5)
                reach_texels = float(plan.blur_defines["NARROW_TAPS"]) + 0.5
            else:  # bilinear taps: ISLAND_CHECK(3 |step| + 1.5), the step at most the largest stretch
                reach_texels = 3.0 * max_stretch(ec, stretch) * widest * n + 1.5
            split = zone_split(ec, n, ring, tiles, reach_texels + 1.0)  # + 1: float32 rounding
            if split is not None:
                parts = [(prog, split[0]), (free, split[1])] if split[0] is not None else [(free, split[1])]
        # (program, uniforms, textures, source, target, tiles), in order: H then V per sub-step (eq. 25-26)
        draws: list[tuple[Any, dict[str, Any], dict[str, Any], Any, Any, Any, int]] = []
        for k, sigma in enumerate(sigmas):
            last = k == len(sigmas) - 1
            # past an open border: nothing in E itself (the first pass over it), the odd reflection in a blur of it
            refl = {"u_reflect": int(not (k == 0 and step.source == IRRADIANCE))} if border else {}
            for dd, (direction, source, target) in enumerate((((1.0, 0.0), src, tmp),  # horizontal: src -> tmp
                                                             ((0.0, 1.0), tmp, plan.output if last else tmp2))):
                fill_at, blur_at = 4 * k + 2 * dd, 4 * k + 2 * dd + 1  # view_cull.separable_draws' order
                if seam:  # the source with its seam gutters continued across the seam
                    first = down is not None and source is plan.source
                    prog_fill = down if first else fill
                    maps = {"seam_map": seam, **({"gutter": plan.gutter} if dilate_fill or prog_fill is down else {})}
                    plain = plain_down if first else plain_fill
                    split = seam_split(ec, n, fill_tiles) if plain is not None and fill_tiles is not None else None
                    if split is None:
                        draws.append((prog_fill, refl, maps, source, filled, fill_tiles, fill_at))
                    else:
                        for p_, where in ((prog_fill, split[0]), (plain, split[1])):
                            if where is not None:
                                draws.append((p_, refl, maps, source, filled, where, fill_at))
                    source = filled
                for p_, where in parts:  # spacing = sigma (eq. 25)
                    draws.append((p_, {"u_sigma_mm": float(sigma), "u_dir": direction, **refl}, {}, source, target, where,
                                  blur_at))
            src = tmp2
        note_tiles(ec, work, f"{compute_failed}{2 * len(sigmas)} directions, {len(draws)} "
                   f"{'compute dispatches' if compute else 'draws'}",
                   directions=2 * len(sigmas), compute=bool(compute),
                   zone_free_rects=int(sum(w[1] for p_, w in parts if p_ is free and w is not None)))
        if tiles is not None and ec.first_tile:  # texels beyond the tiles: 0, not a pooled texture's
            ec.clear_unwritten(plan.output, (id(ec.scene), n, tiles[1], tiles[2], reach, dilate_fill))
        if work is not None:  # deon.view_cull: each draw on the tiles the next ones read (separable_draws)
            masks = separable_draws(ec, plan.cull_stage, work, STRETCH)[0]
            draws = [dw[:5] + (restrict(ec, j, dw[5], masks[dw[6]], n, output=dw[4] == plan.output),) + dw[6:]
                     for j, dw in enumerate(draws)]
            draws = [dw for dw in draws if dw[5] is not None]
        for d, sub, subs in ec.units(len(draws)):
            program, values, maps, source, target, where, _ = draws[d]
            for name, value in values.items():
                ec.set(program, name, value)
            for name, tex in maps.items():
                ec.bind(program, name, tex)
            ec.bind(program, "source", source)
            with ec.band(sub, subs):
                if compute:  # the same texels: the draw's tiles as CS_TILE x CS_TILE workgroups
                    ec.dispatch(program, target, tiles=compute_tiles(ec, where) if where is not None else None)
                else:
                    ec.draw_fullscreen(program, target, tiles=where)


def blur_sigmas(scene, step: BlurStep, n: int, half: bool, n_in: int, full: int, narrow: bool) -> list[float]:
    """A separable blur step's sub-step sigmas (mm) on its n x n map (eq. 24-26; sub_steps): one for whole-texel
    taps (``narrow``); a half-size map's increment holds the coarser grid's interpolation (half_size_increment)."""
    increment = step.increment
    if half:
        increment = half_size_increment(increment, mean_texel_mm(scene, full), n_in != n)
    if narrow:
        return [float(np.sqrt(step.increment))]
    return [float(x) for x in sub_steps(np.sqrt(max(step.variance - step.increment, 0.0)), increment,
                                        mean_texel_mm(scene, n))]


def cull_chain(r) -> tuple | None:
    """What each texture-space pass of the light chain reads, for deon.view_cull (passes/view_cull.stage_needs),
    forwards: ("names", diffuse sum, transmitted light, visibility, TSM, stretch map), then per blur step that
    runs ("gather", i, n, source, reach in blocks, cullable) or ("blur", i, its map's
    side, source, the source's side, sub-step sigmas, NARROW_TAPS or 0, seam fill, cullable), then ("comb",
    (texture, side)...) and with a TSM ("trans", (texture, side)...). A stage is cullable when it draws rectangle
    tile lists (deon.skip_gutters; a separable one as fragment draws, not render.compute_blur) without an open
    border's reflection or per-Gaussian stretch. None: the diffuse sum is not in texture space (deon_final reads
    the blurs per pixel): nothing is culled."""
    if not combined(r):
        return None
    d = r.settings.deon
    n = map_size(r)
    plan = _plan(r)
    border = open_border(r)
    compute = compute_blur(r)
    stretch = STRETCH if d.stretch else None
    stages: list[tuple] = []
    for i, step in enumerate(plan):
        if step.reused:
            continue
        if gathered(r, step):
            stages.append(("gather", i, n, step.source, gather_reach(r, step, n),
                           island_tiles(r, "irradiance", {"OPEN_BORDER": 1} if border else {})))
            continue
        half = half_size(r, i)
        m = transmitted_size(r) if half else n
        n_in = texture_size(r, step.source)
        narrow = {} if half else GaussianBlurPass._narrow(r, step, stretch, n)
        sigmas = blur_sigmas(r.scene, step, m, half, n_in, n, bool(narrow))
        cull = bool(d.skip_gutters) and TILE_RECTS and not compute and not border and not d.stretch_per_gaussian
        stages.append(("blur", i, m, step.source, n_in, tuple(sigmas), int(narrow.get("NARROW_TAPS", 0)),
                       bool(r.settings.scene.seam_aware), cull))
    mask = used_mask(r)
    m = transmitted_size(r)
    stages.insert(0, ("names", DIFFUSE, TRANSMITTED, VISIBILITY, TSM, STRETCH, texel_surface_resources(m, "p")[0],
                      gutter_resource(m)))  # view_cull.names
    reads = tuple(sorted({(texture_of(step), texture_size(r, texture_of(step)))
                          for i, step in enumerate(plan) if (mask >> i) & 1}))
    stages.append(("comb", reads))
    j = tsm_light_index(r)
    if j is not None:  # E of the lit points (the gather) and the blurs at the TSM's uv, around each exit
        tsm_n, block, radii = tsm_max_plan(r)
        reach = float(tsm_n) if radii[0] >= -(-tsm_n // block) else float(radii[0] * block)  # the widest window
        declare_pose(r.settings.lights[j])  # the TSM's light space
        matrix = tuple(float(x) for x in r.scene.light_space(whole(r.peeked.lights[j])).gl_matrix.ravel()) \
            if texel_shading(r) else None  # the exits' positions: the half-size texel surface map
        stages.append(("trans", reads + (((IRRADIANCE, n),) if d.tsm_gather else ()), matrix, int(tsm_n), reach))
    return tuple(stages)


def view_tiles(r) -> ViewTiles | None:
    """deon.view_cull's needed tiles this frame (passes/view_cull), answered once a frame (frame_memo); None when
    it is off, without a scene, or when nothing is culled (cull_chain, view_cull.make_view_tiles)."""
    return frame_memo(r, "deon.view_tiles", _view_tiles)


def _view_tiles(r) -> ViewTiles | None:
    if r.settings.deon.view_cull != "view" or r.scene is None:
        return None
    chain = cull_chain(r)
    return None if chain is None else make_view_tiles(r, chain, map_size(r), transmitted_size(r))


def cull_stage(vt, i: int) -> tuple | None:
    """Blur step i's stage of the chain (cull_chain), when it is cullable."""
    return next((st for st in vt.chain[1:] if st[0] in ("blur", "gather") and st[1] == i and st[-1]), None)


def compute_blur(r) -> bool:
    """render.compute_blur (issue 27) on this context (kernel/gl.compute_policy): whether the separable blur
    directions and their seam fills run as compute passes; `on` where the context has no compute shaders
    says so in the pass's note and keeps the fragment draws."""
    use, why = compute_choice(r.settings.render.compute_blur, r.scene.ctx)
    if why:
        r.note(why)
    return use


def blur_variant(compute: bool, spec: TexSpec, name: str, defines: dict) -> tuple[str, dict]:
    """(program name, defines) of a separable blur draw's program, or of its compute twin (``name``_cs:
    lib/compute_target.glsl around the same body): the vertex stage's TILED becomes a workgroup per
    TILE x TILE tile (CS_TILES), IMAGE_FORMAT is the output's (TexSpec ``spec``)."""
    if not compute:
        return name, dict(defines)
    d = {k: v for k, v in defines.items() if k != "TILED"}
    if "TILED" in defines:
        d["CS_TILES"] = 1
    return f"{name}_cs", {**d, "CS_TILE": TILE, "IMAGE_FORMAT": image_format(spec.components, spec.dtype)}


def blur_program(r, compute: bool, spec: TexSpec, name: str, **defines: Any) -> None:
    """Declare a separable blur program: the fragment one, and with ``compute`` its twin (``blur_variant``),
    which execute runs unless a driver's compiler refuses it (then the draws, said in the pass's note)."""
    r.program(name, **defines)
    if compute:
        cs_name, cs_defines = blur_variant(True, spec, name, defines)
        r.program(cs_name, **cs_defines)


def whole_target(ec, n: int) -> tuple:
    """The whole n x n target as one TILED = 2 rectangle (a work_tiles-like tuple, kept in gl_objects), for
    seam_split over a draw that covers every texel (the summed step's seam fill)."""
    objs = ec.state.setdefault("gl_objects", {})
    key = ("whole_target", id(ec.scene), n)
    if objs.get(key) is None:
        drop_other_scenes(objs, "whole_target", id(ec.scene))
        objs[key] = rect_tiles(ec.gl, np.ones((1, 1), bool), n)
    return objs[key]


def seam_split(ec, n: int, tiles: tuple) -> tuple | None:
    """A seam fill's tiles (``tiles``, TILED = 2 rectangles, or one whole-target tile) split by whether
    a texel of the tile lies across a UV seam or past a mesh border (the seam map's B > 0.5): (tiles
    with one: None if none, tiles without), or None when every tile has one. seam_fill.frag gives
    the plain copy at the island texel on every texel of the second set, so its NO_SEAM variant (no seam
    lookup, which llvmpipe would run masked on every texel) gives the same values there (issue 27).
    Once per mesh, size and tile set."""
    objs = ec.state.setdefault("gl_objects", {})  # each entry a work_tiles-like tuple or None (Graph.release)
    key = ("seam_split", id(ec.scene), n, id(tiles[0]), int(tiles[1]))
    if key + ("plain",) in objs:
        plain = objs[key + ("plain",)]
        return None if plain is None else (objs[key + ("seam",)], plain)
    drop_other_scenes(objs, "seam_split", id(ec.scene))
    nt = -(-n // TILE)
    if tiles[2] == n:  # one tile: the whole target
        drawn_t = np.ones((nt, nt), bool)
    else:
        boxes = np.frombuffer(tiles[0].read(), np.float32).reshape(int(tiles[1]), 4).astype(np.int64) // TILE
        drawn_t = np.zeros((nt, nt), bool)
        for x0, y0, w, h in boxes:
            drawn_t[y0:y0 + h, x0:x0 + w] = True
    sm = ec.input(seam_resource(n))
    b = np.frombuffer(sm.read(), np.float32).reshape(n, n, sm.components)[..., 2]
    seam_t = per_tile(~(b < 0.5)) & drawn_t  # NaN-safe: a tile is plain only when every texel's B is below 0.5
    plain_t = drawn_t & ~seam_t
    if not plain_t.any():
        objs[key + ("plain",)] = None
        return None
    objs[key + ("seam",)], objs[key + ("plain",)] = rect_tiles(ec.gl, seam_t), rect_tiles(ec.gl, plain_t)
    return objs[key + ("seam",)], objs[key + ("plain",)]


def zone_split(ec, n: int, ring: int, tiles: tuple, reach: float) -> tuple | None:
    """The blur's island tiles (work_tiles(ec, n, ring), drawn as ``tiles``) split by whether a tap can
    reach another UV island zone (issue 27): (tiles with a texel whose zone border, the gutter map's A at
    the island texel it is computed at, lies within ``reach`` texels: None if none; tiles with none), as
    ``tiles`` tuples (TILED = 2 rectangles), or None when every tile has such a texel. deon_blur.frag's
    check (ISLAND_CHECK) is false on every texel of the second set, so the variant without it
    (NO_ZONE_CHECKS) gives the same values there. Once per mesh, size, ring and reach."""
    objs = ec.state.setdefault("gl_objects", {})  # each entry a work_tiles-like tuple or None (Graph.release)
    key = ("zone_split", id(ec.scene), n, int(ring), round(float(reach), 3))
    if key + ("free",) in objs:
        free = objs[key + ("free",)]
        return None if free is None else (objs[key + ("checked",)], free)
    drop_other_scenes(objs, "zone_split", id(ec.scene))
    g = read_gutter(ec.input(gutter_resource(n)))
    y, x = np.mgrid[0:n, 0:n]
    if tiles[2] == n:  # work_tiles drew the whole target as one tile
        drawn = np.ones((n, n), bool)
    else:
        drawn = np.hypot(g[..., 0] - x, g[..., 1] - y) <= ring
    sx = np.clip((g[..., 0] + 0.5).astype(np.int64), 0, n - 1)  # the island texel computed (deon_blur: src)
    sy = np.clip((g[..., 1] + 0.5).astype(np.int64), 0, n - 1)
    checked = drawn & ~(g[sy, sx, 3] >= reach)  # NaN-safe: a texel is free only when its border is beyond reach
    any_t, checked_t = per_tile(drawn), per_tile(checked)
    free_t = any_t & ~checked_t
    if not free_t.any():
        objs[key + ("free",)] = None
        return None
    objs[key + ("checked",)], objs[key + ("free",)] = rect_tiles(ec.gl, any_t & checked_t), rect_tiles(ec.gl, free_t)
    return objs[key + ("checked",)], objs[key + ("free",)]


def texture_shadows(r) -> bool:
    """deon.specular_shadows = texture: the irradiance pass keeps each light's fac_shadow per texel
    (VISIBILITY) and the final pass's specular reads it: a camera move does no shadow-map lookups."""
    return r.settings.deon.specular_shadows == "texture"


def final_defines(mask: int, tsm: bool, combined: bool = False) -> dict[str, int]:
    """deon_final.frag's specialisation: GAUSSIAN_MASK (bit i: Gaussian i has weight), DEON_TSM,
    DEON_COMBINED (the diffuse sum comes from deon_combine)."""
    return {"GAUSSIAN_MASK": int(mask), "DEON_TSM": int(bool(tsm)), "DEON_COMBINED": int(bool(combined))}


def used_mask(r) -> int:
    """Bit i: Gaussian i has weight in some channel (its blur is read; eq. 34)."""
    return sum(1 << i for i, g in enumerate(whole(r.settings.deon.gaussians)) if any(w > 0 for w in g.weights))


def combined(r) -> bool:
    """Whether deon_final reads the texture-space sum (deon.combine_blurs, some Gaussian used, a light on)."""
    return bool(r.settings.deon.combine_blurs) and used_mask(r) != 0 and any(
        light_on(l) for l in whole(r.peeked.lights)[:MAX_LIGHTS])  # shape only: the blurs exist


def plan_blurs(r, chain: list) -> None:
    """Plan ``blurs``: per Gaussian, its blurred texture and the variance it has (what bind_blur_slots binds)."""
    r.plan(blurs=tuple((texture_of(step), float(step.variance)) for step in chain))


def declare_blurs(r, mask: int) -> None:
    """The blurred textures of the used Gaussians (bit i of ``mask``) as inputs (and plan_blurs)."""
    chain = _plan(r)
    plan_blurs(r, chain)
    for i, step in enumerate(chain):
        if (mask >> i) & 1:
            r.input(texture_of(step))


def bind_blur_slots(ec, prog) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bind each declared blur to its sampler blur{i} (unbound slots read the graph's dummy) and
    return the per-slot weights, variances and used flags."""
    ws = np.zeros((MAX_GAUSSIANS, 3), np.float32)
    var = np.zeros(MAX_GAUSSIANS, np.float32)
    used = np.zeros(MAX_GAUSSIANS, np.int32)
    for i, (g, (res, variance)) in enumerate(zip(whole(ec.settings.deon.gaussians), ec.plan.blurs)):
        var[i] = variance
        if ec.has_input(res):
            ws[i] = g.weights
            used[i] = 1 if any(w > 0 for w in g.weights) else 0
            ec.bind(prog, f"blur{i}", res)
    return ws, var, used


def bind_blurs(ec, prog) -> None:
    """lib/deon_blurs.glsl's blur samplers and per-Gaussian uniforms."""
    ws, var, used = bind_blur_slots(ec, prog)
    ec.uniforms(prog, u_count=len(whole(ec.settings.deon.gaussians)), u_w=ws, u_var=var, u_used=used)


def declare_tsm_read(r) -> dict[str, Any]:
    """What lib/tsm_transmit.glsl reads besides the blurs: the TSM, its form, the blurs' gutter map
    (island zones), the stretch map, and for the gather the irradiance; returns its defines."""
    declare(r.settings.deon.tsm_form)
    r.plan(tsm_light=tsm_light_index(r), zone_map=gutter_resource(map_size(r)))  # for bind_tsm_read
    declare_pose(r.settings.lights[r.planned.tsm_light])  # its light space
    r.input(TSM)
    r.input(r.planned.zone_map)  # island zones: whether the blur already carries A's light
    if r.settings.deon.stretch:
        r.input(STRETCH)
    if r.settings.deon.tsm_gather:
        r.input(IRRADIANCE)  # E of the lit points around the ray
    return {"TSM_GATHER_N": int(r.settings.deon.tsm_gather)}


def bind_tsm_read(ec, prog) -> None:
    """lib/tsm_transmit.glsl's TSM, stretch and gate uniforms (declare_tsm_read)."""
    ec.bind(prog, "tsm_map", TSM)
    ec.bind(prog, "zone_map", ec.plan.zone_map)
    if ec.has_input(STRETCH):
        ec.bind(prog, "stretch_map", STRETCH)
    ls = set_tsm_uniforms(ec, prog, ec.plan.tsm_light)
    # thickness below ~2 TSM texels is the point's own surface (it is lit): no transmission
    texel_mm = ls.texel_world(ec.input(TSM).size[0]) * ec.scene.mm_per_unit
    ec.set(prog, "u_tsm_gate_mm", float(max(2.0 * texel_mm, 0.25)))
    s = ec.scene.mean_uv_per_mm
    ec.uniforms(prog, u_tsm_printed=ec.settings.deon.tsm_form == "printed",
                u_use_stretch=ec.has_input(STRETCH), u_uniform_stretch=(s, s))
    if ec.settings.deon.tsm_gather:
        ec.set(prog, "u_tsm_map_mm", float(ls.extent * ec.scene.mm_per_unit))
        ec.bind(prog, "irradiance_map", IRRADIANCE)


def shade_tiles(ec, prog, resource: str, mask: np.ndarray, *more: str) -> None:
    """shade_dilated on the tiles ``mask`` of ``resource`` (and ``more``) only (deon.view_cull): the program
    shades the island texels the gutter dilation reads for those tiles (view_cull.gutter_links), the dilation
    (TILED = 2; a pair in one draw as dilate_all) writes those tiles; the others keep what they held."""
    shading = ec.plan.shading
    size, maps = shading.size, shading.maps
    for k, res in zip(maps, texel_surface_resources(size, maps)):
        ec.bind(prog, TEXEL_SURFACE_SAMPLERS[k], res)
    island, pairs = gutter_links(ec, size)
    raws = [ec.held(f"raw{i}", TexSpec((size, size), 4 if i == 0 else ec.output(r).components,
                                       "f4" if i == 0 else ec.output(r).dtype, filter="nearest"))[0]
            for i, r in enumerate((resource,) + more)]
    shaded = through_links(mask, pairs)
    # every island tile needed: work_tiles' own list (one quad for the whole target when it is nearly all)
    tiles = work_tiles(ec, size, 0) if not (island & ~shaded).any() else island_origins(ec, size, shaded, island)
    if ec.first_tile:  # the tiles no view needs: 0, not a pooled texture's (a run for new tiles keeps all)
        for res in (resource,) + more:
            ec.clear_unwritten(res, ("view_cull", id(ec.scene), size))
    with ec.band():
        if tiles is not None:
            ec.draw_fullscreen(prog, *raws, tiles=tiles)
    rects = mask_rects(ec, mask, "dilate")
    if not ec.last_tile or rects is None:
        return
    targets = (resource,) + more
    limit = [HALF_MAX if ec.output(t).dtype == "f2" else FLOAT_MAX for t in targets]
    if len(targets) == 2 and texture_space.DILATE_PAIRS and ec.plan.dilate_pair:  # as dilate_all
        dil = ec.program("dilate", DILATE_MORE=1, TILED=2)
        ec.textures(dil, source=raws[0], source1=raws[1], gutter=gutter_resource(size))
        ec.uniforms(dil, u_limit=limit[0], u_limit1=limit[1])
        ec.draw_fullscreen(dil, *targets, tiles=rects)
        return
    dil = ec.program("dilate", TILED=2)
    for src, target, lim in zip(raws, targets, limit):
        ec.textures(dil, source=src, gutter=gutter_resource(size))
        ec.set(dil, "u_limit", lim)
        ec.draw_fullscreen(dil, target, tiles=rects)


def transmitted_size(r) -> int:
    """deon_transmitted's map: half the irradiance map's (the term is smooth: a 3x3-filtered TSM)."""
    return max(map_size(r) // 2, 32)


class TransmittedPass(Pass):
    """eq. 33's transmitted light (lib/tsm_transmit.glsl) in texture space, gutters dilated: it
    does not depend on the camera, so with deon.combine_blurs it joins the diffuse sum and an
    orbit does not pay its 3x3 TSM taps and per-Gaussian terms per pixel."""
    name = "deon_transmitted"
    tileable = True  # one draw (view mesh / texel shading): in row bands under a frame budget (issue 27)

    def reflect(self, r: Reflection) -> None:
        if not combined(r) or tsm_light_index(r) is None:
            return
        mask = used_mask(r)
        declare_blurs(r, mask)
        tsm_defines = declare_tsm_read(r)
        if TSM_SKIP:  # the texels no TSM read can reach are skipped (deon_tsm_max)
            r.input(TSM_MAX)
            r.plan(tsm_max=tsm_max_plan(r))
            tsm_defines["TSM_SKIP"] = 1
            if TSM_CUT:
                tsm_defines["TSM_ZERO"] = TSM_CUT_ZERO
            if TSM_SKIP_MARK:
                tsm_defines["TSM_SKIP_MARK"] = -1.0
        if not TSM_TAPS_CUT:
            tsm_defines.update(TSM_TAPS_NARROW=0, TSM_TAPS_SKIP=0)
        n = transmitted_size(r)
        declare_shaded(r, "deon_transmitted", n, TRANSMITTED, TexSpec((n, n), 4, "f4"), GAUSSIAN_MASK=mask,
                       **tsm_defines)
        # deon.view_cull: the combine's reads of it (F at half size); over the texel surface map only
        vt = view_tiles(r) if r.planned.shading.texels else None
        r.plan(cull=(vt.n, vt.m) if vt is not None else None)
        if vt is not None:
            r.program("dilate", TILED=2)
            declare_cull_inputs(r, vt)
            r.cover(vt.token)

    def execute(self, ec) -> None:
        prog = ec.program(ec.plan.shading.program)
        bind_blurs(ec, prog)
        bind_tsm_read(ec, prog)
        if ec.has_input(TSM_MAX):  # optional: a variant compiled with TSM_SKIP=0 (an A/B) has none
            ec.bind(prog, "tsm_max_map", TSM_MAX, optional=True)
            ec.set(prog, "u_tsm_max_block", int(ec.plan.tsm_max[1]), optional=True)
            ec.set(prog, "u_tsm_max_reach", tsm_max_covered(ec.plan.tsm_max), optional=True)  # per channel
        work = work_of(ec, TRANSMITTED)  # deon.view_cull: the tiles to make (None: every tile)
        if work is not None:
            note_tiles(ec, work)
            shade_tiles(ec, prog, TRANSMITTED, work)
        else:
            shade_dilated(ec, prog, TRANSMITTED)


class DiffuseSumPass(Pass):
    """sum_i w_i blur_i (eq. 34's sum) in texture space, once per change of the blurs or the weights:
    an orbit re-runs only deon_final, which then reads this one texture instead of every blur."""
    name = "deon_combine"

    def reflect(self, r: Reflection) -> None:
        if not combined(r):
            return
        mask = used_mask(r)
        declare_blurs(r, mask)
        if tsm_light_index(r) is not None:
            r.input(TRANSMITTED)
        n = map_size(r)
        r.plan(size=n)
        # the blurs made at half size (deon.half_res_above_texels): filtered up, not fetched per texel
        half = sum(1 << i for i, step in enumerate(_plan(r)) if (mask >> i) & 1 and texture_size(r, texture_of(step)) != n)
        textures = tuple(texture_of(step) for step in _plan(r))
        r.plan(textures=textures)
        defines = combine_defines(textures, mask, half)
        r.program("deon_combine", **defines)
        vt = view_tiles(r)  # deon.view_cull: the tiles the final pass reads (F), drawn as rectangles
        r.plan(defines=tuple(sorted(defines.items())), cull=(vt.n, vt.m) if vt is not None else None)
        if vt is not None:
            r.program("deon_combine", **defines, TILED=2)
            declare_cull_inputs(r, vt)
            r.cover(vt.token)
        r.output(DIFFUSE, TexSpec((n, n), 4, "f4"))

    def likely_programs(self, r: Reflection) -> list[tuple[str, dict]]:
        """deon_combine one weight toggle away: warmed while idle, with deon_final's."""
        textures = r.planned.textures if "textures" in r.planned else ()
        out = []
        for n, d in r.programs:
            if n != "deon_combine" or "TILED" in dict(d):
                continue
            for v in likely_final_variants(dict(d))[:MAX_GAUSSIANS]:
                v.pop("BLUR_SOURCES", None)  # the sources of the toggled mask (blur_sources)
                out.append(("deon_combine", combine_defines(textures, v["GAUSSIAN_MASK"], v.get("HALF_MASK", 0), v)))
        return out

    def execute(self, ec) -> None:
        defines = dict(ec.plan.defines)
        rects = None
        work = work_of(ec, DIFFUSE)  # deon.view_cull: the tiles to make (None: every tile)
        if work is not None:
            note_tiles(ec, work)
            if not work.all():  # else one full-screen draw, as without culling
                ec.clear_unwritten(DIFFUSE, ("view_cull", id(ec.scene), ec.plan.size))  # the tiles no view needs: 0
                rects = mask_rects(ec, work)
                if rects is None:
                    return
                defines["TILED"] = 2
        prog = ec.program("deon_combine", **defines)
        ws, _, _ = bind_blur_slots(ec, prog)
        n = ec.plan.size
        ec.uniforms(prog, u_w=ws, u_transmitted=ec.has_input(TRANSMITTED), u_size=(float(n), float(n)))
        ec.set(prog, "u_one", 1.0, optional=True)  # BLUR_SOURCES' shared values times 1 (deon_combine.frag)
        if ec.has_input(TRANSMITTED):
            ec.bind(prog, "transmitted", TRANSMITTED)
        ec.draw_fullscreen(prog, DIFFUSE, tiles=rects)


def blur_sources(textures: tuple, mask: int) -> int:
    """deon_combine.frag's BLUR_SOURCES: 3 bits a slot k < 4, the earliest used slot (bit of ``mask``) that
    reads the same texture as k (k itself if none), slots 4..7 their own; 0o76543210 when no slot shares."""
    out = 0
    for k in range(8):
        src = k
        if k < 4 and k < len(textures) and (mask >> k) & 1:
            src = next(j for j in range(k + 1) if (mask >> j) & 1 and textures[j] == textures[k])
        out |= src << (3 * k)
    return out


def combine_defines(textures: tuple, mask: int, half: int, base: dict | None = None) -> dict:
    """deon_combine's defines: GAUSSIAN_MASK, HALF_MASK (when some), BLUR_SOURCES (COMBINE_ONCE, when a
    texture is shared by two used slots)."""
    out = {**(base or {}), "GAUSSIAN_MASK": int(mask)}
    if half:
        out["HALF_MASK"] = int(half)
    sources = blur_sources(textures, mask)
    if COMBINE_ONCE and sources != 0o76543210:
        out["BLUR_SOURCES"] = sources
    return out


def likely_final_variants(defines: dict, gather: int | None = None) -> list[dict]:
    """The deon_final variants one toggle away from ``defines`` (a weight to/from zero, the TSM
    on/off): what the viewer compiles while idle so a toggle does not stall. ``gather``:
    deon.tsm_gather, the TSM_GATHER_N a variant with the TSM on is declared with (final_defines)."""
    out = []
    mask, n = defines.get("GAUSSIAN_MASK", 0), MAX_GAUSSIANS
    for i in range(n):
        out.append({**defines, "GAUSSIAN_MASK": mask ^ (1 << i)})
    flipped = {k: v for k, v in defines.items() if k != "TSM_GATHER_N"}
    flipped["DEON_TSM"] = 1 - defines.get("DEON_TSM", 0)
    if flipped["DEON_TSM"] and gather is not None:
        flipped["TSM_GATHER_N"] = int(gather)
    out.append(flipped)
    return out


def max_stretch(ec, stretch: str | None) -> float:
    """The largest UV per mm of the stretch map (read back once per version), or the uniform one."""
    if not stretch:
        return ec.scene.mean_uv_per_mm
    key = ("max_stretch", stretch, ec.input_version(stretch), id(ec.scene))
    s_max = ec.state.get(key)
    if s_max is None:
        tex = ec.input(stretch)
        a = np.frombuffer(tex.read(), np.float32).reshape(-1, tex.components).astype(np.float64)
        if a.shape[1] >= 3 and ec.settings.deon.stretch_shear:  # the sheared pass's step (deon_blur shear_step)
            c = np.clip(np.nan_to_num(a[:, 2]), -0.95, 0.95)
            a = np.column_stack([a[:, 0], np.sqrt((c * c * a[:, 0] ** 2 + a[:, 1] ** 2) / (1.0 - c * c))])
        a = a[:, :2][np.isfinite(a[:, :2])]  # RG: UV per mm (B: shear)
        s_max = ec.state[key] = float(a.max()) if a.size else 0.0
    return s_max


NARROW_TEXELS = 8.0  # a blur whose sigma is 1 to this many texels takes whole-texel taps (deon_blur.frag)
NARROW_TAPS = (3, 6, 12, 24)  # program variants: +-taps covering 3 sigma of the widest texel


def narrow_taps(sigma_texels: float) -> int:
    return next(t for t in NARROW_TAPS if t >= 3.0 * sigma_texels)


def ring_sigma(r, i: int | None = None) -> float:
    """The widest sigma (mm) whose taps reach past blur_i: this blur's own V taps on its H output and the
    next blur's taps on its output (sigma <= sqrt(increment); i None: the whole chain). Shape only (peeked)."""
    plan = plan_of([g.variance for g in whole(r.peeked.deon.gaussians)], r)  # the whole chain's widest step
    near = plan if i is None else plan[i:i + 2]
    return float(max((np.sqrt(step.increment) for step in near if not step.reused), default=0.0))


def blur_ring(ec, n: int, stretch: str | None, sigma: float) -> int:
    """Texels beyond the islands that readers of a blur can reach (seed 000 eq. 25: taps at k * s *
    sigma, |k| <= 3, s in UV per mm): 3 * max stretch * sigma * n (sigma: ring_sigma, planned in
    reflect), plus one for bilinear taps and one for the final pass's bilinear lookups."""
    s_max = max_stretch(ec, stretch)
    return int(np.ceil(3.0 * s_max * sigma * n)) + 2


# issue 27: the final pass split in a light-independent view pass (DeonFinalViewPass: the shading normal,
# the specular parameters, C^(1-mix) rho_dt(N.V), the environment's specular and translucency; kept across
# light moves) and the light pass (DeonFinalPass, DEON_FINAL_PART = 2); bit-identical to the one-pass shader.
# SKINVIEWER_SPLIT_FINAL: auto (a software rasterizer: there a pixel's light-independent work costs per
# lane; on a GPU the whole camera-only frame is 1.6 ms (H200) and the maps would hold 174 MiB at 1920x1080), 1, 0 (the one-pass
# shader, for before | after runs: notes/deon_light_move.md section 15)
SPLIT_FINAL = os.environ.get("SKINVIEWER_SPLIT_FINAL", "auto")


def final_view_resource(role: str) -> str:
    """Render-size map ``role`` of the final pass's light-independent values (DeonFinalViewPass)."""
    return f"deon_final_view_{role}"


def split_final(r) -> bool:
    """Whether deon_final adds the lights to the view pass's maps (SPLIT_FINAL): not when every light is
    off (the black one-pass shader); auto: on a software rasterizer (kernel/gl; off the GL thread before
    the renderer is known: as one, like quad_sum). Shape only (peeked)."""
    if SPLIT_FINAL == "0":
        return False
    if not any(analytic_on(whole(l)) for l in whole(r.peeked.lights)[:MAX_LIGHTS]) and env_index(r) is None:
        return False
    if SPLIT_FINAL == "1" or r.scene is None:
        return True
    info = gl_info(r.scene.ctx)
    return not info or software_renderer(r.scene.ctx)


def final_screen(r) -> bool:
    """Whether the light part is drawn full-screen (deon_final_light.frag) from the kept fragment's stored
    position and uv, or over the mesh again (deon_final.frag): a beam light's footprint is dFdx of the
    mesh's position (lib/beam.glsl), which a full-screen draw does not have. Shape only (peeked)."""
    return not any(analytic_on(whole(l)) and l.kind == "beam" for l in whole(r.peeked.lights)[:MAX_LIGHTS])


FINAL_VIEW_FORMATS = {"n": 4, "f": 4, "p": 4, "s": 1, "e": 4, "x": 4, "nrm": 4}  # components (float32)


def final_view_roles(r) -> tuple[tuple[str, ...], dict[str, int]]:
    """The view pass's maps in location order and the FINAL_LOC_* defines (lib/deon_final.glsl): N, the
    factor C^(1-mix) rho_dt(N.V), and with an environment light its specular, and with its occlusion bake
    and deon.tsm its translucency (declares deon.tsm there). Full-screen (final_screen) the position too,
    uv, m and rho_s in the w channels (rho_s in a map of its own without an environment), and the vertex
    normal where the light part reads it (shadow-map lookups, the TSM read per pixel); over the mesh m and
    rho_s in N's and the factor's w."""
    env = env_defines(r)
    screen = final_screen(r)
    roles = ["n", "f"] + (["p"] if screen else [])
    if env:
        roles.append("e")
        if int(env.get("ENV_RAYS", 0)) > 0 and r.settings.deon.tsm:
            roles.append("x")
    elif screen:
        roles.append("s")
    pk = r.peeked.deon  # shape only: the view pass does not read these
    summed = pk.combine_blurs and any(any(w > 0 for w in g.weights) for g in whole(pk.gaussians))
    if screen and (pk.specular_shadows != "texture" or not summed):  # shadow-map lookups, the TSM per pixel
        roles.append("nrm")
    loc = {k: roles.index(k) if k in roles else -1 for k in ("p", "s", "e", "x", "nrm")}
    return tuple(roles), {f"FINAL_LOC_{k.upper()}": v for k, v in loc.items()}


class DeonFinalViewPass(Pass):
    """The light-independent part of eq. (34)-(35) per pixel (issue 27; deon_final.frag with DEON_FINAL_PART
    = 1): the shading normal N (the normal map, back faces reversed) and m, C^(1-mix) rho_dt(N.V) and rho_s,
    the environment's split-sum specular and its translucency, as exact float32. It reads the camera, the
    mesh, the albedo, normal, region and specular maps, deon.mix, the specular settings, the rho_dt table and
    the environment light; no analytic light: a light move keeps it, a camera move re-runs it."""
    name = "deon_final_view"
    tileable = True
    view_dependent = True

    def reflect(self, r: Reflection) -> None:
        if not split_final(r):
            return
        roles, locs = final_view_roles(r)
        declare(r.settings.deon.mix)
        declare_specular(r, lut=False)  # m, rho_s per texel and rho_dt's; the Beckmann LUT is the light pass's
        if r.settings.deon.energy_conservation:
            r.input(RHO_DT_RESOURCE)
        defines = declare_environment(r)
        if "x" in roles:
            whole(r.settings.deon.gaussians)  # the translucency's profile (u_env_tr_w, u_env_tr_v)
        declare_view_mesh(r)
        w, h = r.settings.render.width, r.settings.render.height
        r.program("deon_final", DEON_FINAL_PART=1, **locs, LIGHT_COUNT=0, POINT_MASK=0, BEAM_MASK=0,
                  SHADOW_MASK=0, **final_defines(0, False, True), **defines)
        outs = tuple(final_view_resource(k) for k in roles)
        r.plan(outs=outs)
        for role, res in zip(roles, outs):
            r.output(res, TexSpec((w, h), FINAL_VIEW_FORMATS[role], "f4", depth=True, filter="nearest"))

    def execute(self, ec) -> None:
        prog = ec.program("deon_final")
        set_camera(ec, prog)
        bind_surface(ec, prog)
        energy = ec.has_input(RHO_DT_RESOURCE)
        ec.uniforms(prog, u_mix=float(ec.settings.deon.mix), u_energy=energy)
        if energy:
            ec.bind(prog, "rho_dt_tex", RHO_DT_RESOURCE)
        sp = ec.settings.specular  # lib/specular_params.glsl less the Beckmann LUT (the light pass's ks)
        m, rho = per_region_specular(sp)
        ec.uniforms(prog, u_spec_m=m, u_spec_rho_s=rho, u_spec_rho_s_table=float(sp.rho_s))
        ec.textures(prog, region_map=ec.scene.region_map, specular_map=ec.scene.specular_map)
        set_environment(ec, prog)
        if "u_env_tr_w" in prog:
            set_env_translucency(ec, prog)
        draw_view_mesh(ec, prog, *ec.plan.outs)


def set_env_translucency(ec, prog) -> None:
    """deon_final's environment translucency profile: every Gaussian's weights and variance, the mm a unit."""
    gs = whole(ec.settings.deon.gaussians)[:MAX_GAUSSIANS]
    w = np.zeros((MAX_GAUSSIANS, 3), np.float32)
    v = np.zeros(MAX_GAUSSIANS, np.float32)
    for i, g in enumerate(gs):
        w[i], v[i] = g.weights, g.variance
    ec.set(prog, "u_env_tr_w", w, optional=True)
    ec.set(prog, "u_env_tr_v", v, optional=True)
    ec.set(prog, "u_mm_per_unit", float(ec.scene.mm_per_unit), optional=True)  # the thickness in mm


class DeonFinalPass(Pass):
    """eq. (34)-(35), view-dependent: the only pass an orbit re-runs (with the output). Split (split_final):
    the light part, adding the lights to DeonFinalViewPass's maps."""
    name = "deon_final"
    tileable = True  # one draw (view mesh / texel shading): in row bands under a frame budget (issue 27)
    view_dependent = True

    def reflect(self, r: Reflection) -> None:
        vis = texture_shadows(r)
        lighting = declare_lighting(r, shadow_maps=not vis)  # texture shadows: no shadow map is read
        gs = whole(r.settings.deon.gaussians)
        plan = _plan(r)
        r.plan(dark=not any(light_on(l) for l in whole(r.settings.lights)[:MAX_LIGHTS]))  # no analytic light on
        plan_blurs(r, plan)
        if lighting["LIGHT_COUNT"] == 0 and env_index(r) is None:  # every light off: black (no irradiance, no specular)
            for step in plan:
                r.drop(texture_of(step), "every light is off or at zero intensity")
            declare_lit(r, "deon_final", **lighting, **final_defines(0, False))
            declare_view_mesh(r)
            return
        split = split_final(r)
        part: dict[str, int] = {}
        program = "deon_final"
        if split:  # N, m, rho_s, the factor, the environment's terms (and the fragment) from the view pass
            roles, locs = final_view_roles(r)
            part = {"DEON_FINAL_PART": 2, **locs}
            screen = final_screen(r)
            program = "deon_final_light" if screen else "deon_final"
            r.plan(view_maps=tuple((role, final_view_resource(role)) for role in roles), screen=screen)
            for _, res in r.planned.view_maps:
                r.input(res)
            sp = r.settings.specular  # surface_ks: f0 and the mode (m, rho_s per pixel from the view pass)
            declare(sp.f0)
            if sp.mode == "beckmann_lut":
                r.input(BECKMANN_LUT)
        else:
            declare(r.settings.deon.mix)
            declare_specular(r)
            if r.settings.deon.energy_conservation:
                r.input(RHO_DT_RESOURCE)
        summed = combined(r)
        tsm = tsm_light_index(r) is not None and not summed  # summed: deon_transmitted has it
        if summed:
            r.input(DIFFUSE)
        tsm_defines = declare_tsm_read(r) if tsm else {}
        if vis:
            r.input(VISIBILITY)
        mask = 0
        for i, (g, step) in enumerate(zip(gs, plan)):
            if any(w > 0 for w in g.weights):
                mask |= 1 << i
                if not summed:
                    r.input(texture_of(step))
                if tsm and i >= 1:
                    r.input(texture_of(plan[i - 1]))  # its blurred thickness
            else:
                r.drop(texture_of(step), f"Gaussian {i} has zero weight")
        declare_lit(r, program, **lighting, **final_defines(mask, tsm, summed), **tsm_defines,
                    DEON_TEXTURE_SHADOWS=int(vis), **(part or declare_environment(r)))
        declare_view_mesh(r)

    def likely_programs(self, r: Reflection) -> list[tuple[str, dict]]:
        """deon_final one toggle away (a weight to/from zero, the TSM on/off): warmed while idle."""
        return [(n, v) for n, d in r.programs if n in ("deon_final", "deon_final_light")
                for v in likely_final_variants(dict(d), r.peeked.deon.tsm_gather)]

    def execute(self, ec) -> None:
        screen = bool(ec.plan.get("screen"))
        prog = ec.program("deon_final_light" if screen else "deon_final")
        if screen:  # full-screen: the eye only (the position comes from the view pass)
            ec.set(prog, "u_eye", tuple(float(x) for x in ec.view.eye))
        else:
            set_camera(ec, prog)
        if ec.plan.dark:
            draw_view_mesh(ec, prog, LIT)
            return
        has = ec.has_input
        set_lighting(ec, prog, shadow_maps=not has(VISIBILITY))
        bind_blurs(ec, prog)  # unbound blur slots read the graph's dummy texture
        ec.uniforms(prog, u_tsm=has(TSM), u_combined=has(DIFFUSE))
        if has(DIFFUSE):
            ec.bind(prog, "diffuse_sum", DIFFUSE)
        if has(TSM):
            bind_tsm_read(ec, prog)
        if has(VISIBILITY):
            ec.bind(prog, "visibility", VISIBILITY)
        view_maps = ec.plan.get("view_maps")
        if view_maps:  # the light part: the view pass's values (split_final)
            for role, res in view_maps:
                ec.bind(prog, f"final_view_{role}", res)
            sp = ec.settings.specular  # surface_ks's f0 and Beckmann LUT
            ec.uniforms(prog, u_f0=float(sp.f0), u_spec_lut=has(BECKMANN_LUT))
            if has(BECKMANN_LUT):
                ec.bind(prog, "beckmann_tex", BECKMANN_LUT)
            if screen:
                with ec.band():  # every pixel written (the clear colour where no fragment was kept)
                    ec.draw_fullscreen(prog, LIT)
            else:
                draw_view_mesh(ec, prog, LIT)
            return
        bind_surface(ec, prog)
        ec.uniforms(prog, u_mix=float(ec.settings.deon.mix), u_energy=has(RHO_DT_RESOURCE))
        if has(RHO_DT_RESOURCE):
            ec.bind(prog, "rho_dt_tex", RHO_DT_RESOURCE)
        bind_specular(ec, prog)
        set_environment(ec, prog)
        ec.set(prog, "u_env_tr", bool(ec.settings.deon.tsm), optional=True)
        if "u_env_tr" in prog:  # the environment's translucency profile
            set_env_translucency(ec, prog)
        draw_view_mesh(ec, prog, LIT)
