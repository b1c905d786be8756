"""Scene-driven rules (issue 14): simulate only what the scene calls for. Each rule decides the
graph's shape from the scene and the settings, and says why in the frame report
(``Reflection.skip`` / ``drop`` / ``note``):

* a light of zero intensity (or black colour) is no light: no shadow map, no lighting;
* the TSM runs only when a light is behind a part thin enough to transmit and that part is in view;
* the irradiance-map size follows the head's screen coverage (deon.irradiance_size_mode = "auto"),
  with hysteresis so an orbit does not thrash the cache;
* d'Eon's diffusion is skipped when its widest Gaussian spans under a pixel on screen;
* the mesh is drawn at a coarser level of detail when its triangles are far under a pixel.
"""
from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from skinviewer.ground.constants import MAX_LIGHTS
from skinviewer.ground.settings import LightSettings

if TYPE_CHECKING:
    from skinviewer.kernel.frame_view import FrameView
    from skinviewer.kernel.pass_api import Reflection

TSM_EPS = 5e-3      # transmitted radiance / light radiance under which the TSM term is not drawn
MAX_RAYS = 4096     # rays cast per light pose for the TSM rule (Embree via trimesh)
MAX_LIT = 32768     # lit vertices the rule's gather estimate pairs with them (rules.lit_beside)
MIN_AUTO_SIZE = 64  # smallest irradiance map "auto" chooses
HYSTERESIS = 1.25   # "auto" changes size only when the wanted size leaves [c / 2 / H, c * H]
LOD_TRIANGLES_PER_PX = 4.0  # a level of detail keeps at least this many triangles per pixel of the head
LOD_HYSTERESIS = 0.2  # in levels: the level changes only when the wanted one leaves [c - H, c + 1 + H)


def light_on(light) -> bool:
    """A light that adds radiance: enabled, intensity > 0 and a colour that is not black."""
    return bool(light.enabled) and light.intensity > 0.0 and max(light.color) > 0.0


def analytic_on(light) -> bool:
    """A light of the per-light loops and shadow maps (not an environment, which
    shaders/lib/environment.glsl adds as a whole)."""
    return light_on(light) and light.kind != "environment"


def environment_light(lights: list[LightSettings]) -> tuple[int, LightSettings] | None:
    """(index, light) of the first environment light that adds radiance among the first MAX_LIGHTS,
    or None (issue 32: one environment at a time)."""
    for i, light in enumerate(lights[:MAX_LIGHTS]):
        if light.kind == "environment" and light_on(light):
            return i, light
    return None


def light_off_reason(i: int, light) -> str:
    if light.enabled and light.kind == "environment":
        return f"light {i} is an environment (no shadow map)"
    return f"light {i} is disabled" if not light.enabled else f"light {i} has zero intensity"


# -- screen coverage -------------------------------------------------------------------------------

def screen_diameter_px(view: FrameView) -> float:
    """The projected diameter (pixels, along the image height) of what the rendered camera frames
    (the head of a bust, not its shoulders): the frame's view's (kernel/frame_view.FrameView)."""
    return view.screen_diameter_px


def wanted_map_size(view: FrameView) -> float:
    """Map size (texels) at which the atlas has one texel per pixel of the head on screen, on
    average: pixels per mm at the head = D_px / (2 r mm); texels per mm = n * mean UV per mm."""
    if not math.isfinite(view.screen_diameter_px):
        return float("inf")
    return view.px_per_mm / max(view.scene.mean_uv_per_mm, 1e-12)


def coverage_size(r: Reflection, user: int, mode: str, key: str, wanted_fn=None) -> int:
    """The map size for a size setting whose value is ``user`` (the maximum) and whose mode setting
    is ``mode`` (both read, so declared, by the caller through ``r.settings``): ``user`` itself in
    "fixed" mode; in "auto" the power of two from the screen coverage, changed only when the wanted
    size leaves the hysteresis band (``key`` names the map's memory in ``r.state``). ``r``: a scene
    pass's Reflection (the passes plan the size for execute)."""
    user = int(user)
    if mode != "auto":
        return user
    scene = r.scene
    wanted = (wanted_fn or wanted_map_size)(r.view)
    memo = (key, id(scene))
    cur = min(r.state.get(memo, user), user)
    if not (cur / 2.0 / HYSTERESIS <= wanted <= cur * HYSTERESIS):
        pow2 = 2 ** math.ceil(math.log2(min(max(wanted, MIN_AUTO_SIZE), 1 << 20)))
        cur = int(min(pow2, user))
    r.state[memo] = cur
    if cur != user:
        r.note(f"map {cur}\u00b2 from screen coverage (head {screen_diameter_px(r.view):.0f} px)")
    return cur


def mesh_lod(settings, view: FrameView, state: dict) -> tuple[int, str]:
    """The mesh's level of detail for this frame (render.mesh_lod = "auto"): the coarsest level
    (scene/lod.py, 1/4 of the triangles per level) that still has LOD_TRIANGLES_PER_PX triangles per
    pixel of the head (half the triangles face the camera, over the disc of the bounding sphere on
    screen), so silhouettes and shading stay sub-pixel; with hysteresis. ``view``: the frame's view
    (its scene, camera and coverage). Returns (level, reason)."""
    scene = view.scene
    key = ("mesh_lod", id(scene))
    levels = scene.lod_triangles
    if settings.render.mesh_lod != "auto" or len(levels) < 2:
        state[key] = 0
        return 0, ""
    d_px = screen_diameter_px(view)
    area = math.pi / 4.0 * d_px * d_px
    if not area > 0.0 or not math.isfinite(area):
        state[key] = 0
        return 0, ""
    per_px = levels[0] / 2.0 / area
    wanted = math.log(max(per_px / LOD_TRIANGLES_PER_PX, 1e-9), 4.0)  # fractional level
    cur = state.get(key)
    if cur is None or not (cur - LOD_HYSTERESIS <= wanted < cur + 1 + LOD_HYSTERESIS):
        cur = int(min(max(math.floor(wanted), 0), len(levels) - 1))
    cur = int(min(max(cur, 0), len(levels) - 1))
    state[key] = cur
    if cur == 0:
        return 0, ""
    return cur, (f"mesh LOD {cur}: ~{levels[cur]:,} of {levels[0]:,} triangles from screen coverage "
                 f"(head {d_px:.0f} px)")


def kernel_px(settings, view: FrameView) -> float:
    """The widest used Gaussian's standard deviation (seed 000 eq. 21) in screen pixels at the
    head: sqrt(v_max) mm * pixels per mm of the framed part (the head) on screen (``view``: the frame's)."""
    v = max((g.variance for g in settings.deon.gaussians if max(g.weights) > 0), default=0.0)
    scene = view.scene
    d_px = screen_diameter_px(view)
    return math.sqrt(max(v, 0.0)) * d_px / (2.0 * scene.frame[1] * scene.mm_per_unit)


def frame_memo(r: Any, key: Any, rule: Callable[[Any], Any]) -> Any:
    """``rule(r)`` answered once a frame for ``key`` when ``r`` is a graph's Reflection
    (Reflection.memo: the reads, notes and drops replayed); an ExecuteContext asks afresh. ``rule``
    reads only through the reflection it is given."""
    memo = getattr(r, "memo", None)
    return rule(r) if memo is None else memo((key, r.scene is None), rule)


def kernel_under_pixel(r: Reflection) -> str | None:
    """Asked by most of d'Eon's passes a frame: answered once (frame_memo); see _kernel_under_pixel."""
    return frame_memo(r, "kernel_under_pixel", _kernel_under_pixel)


def _kernel_under_pixel(r: Reflection) -> str | None:
    """The screen-space rule of the Burley techniques (kernel under a pixel: no blur) for d'Eon:
    when the widest Gaussian spans under deon.subpixel_kernel_px pixels on screen, diffusion cannot
    show, so the blurs, stretch and TSM are skipped and the final pass reads the irradiance. With
    hysteresis (on below the limit, off above HYSTERESIS x it). Returns the reason, or None."""
    limit = float(r.settings.deon.subpixel_kernel_px)
    if r.scene is None:
        return None
    key = ("subpixel_kernel", id(r.scene))
    if not limit > 0.0:
        r.state[key] = False
        return None
    px = kernel_px(r.peeked, r.view)  # peeked: the graph sees the rule read the Gaussians (Reflection.memo)
    on = px < limit * (HYSTERESIS if r.state.get(key, False) else 1.0)
    r.state[key] = on
    return f"kernel under a pixel (widest Gaussian sigma {px:.2f} px on screen)" if on else None


def light_map_size(r, user: int, mode: str, key: str) -> int:
    """A map seen from a light that frames the bounding sphere (shadow maps, the TSM): about one
    texel per pixel of the scene's screen diameter (``coverage_size``'s arguments)."""
    return coverage_size(r, user, mode, key, screen_diameter_px)


def shadow_map_size(r) -> int:
    sh = r.settings.shadow
    return light_map_size(r, sh.map_size, sh.map_size_mode, "shadow_map")


# -- translucent shadow map ----------------------------------------------------------------------

POSE_MEMORY = 48  # light poses whose rays and pairs the rule keeps per scene (a drag makes hundreds)
TSM_BIN = 6  # governed previews: the light direction binned to round(TSM_BIN * d) (bins of ~10 degrees)
PAIRS_MAX_VERTICES = 200_000  # sheet_pairs once per mesh up to this many vertices; above, a search per pose
TSM_WORKER = True  # governed previews: a bin's rule is made in a worker thread (the TSM kept until then)
# the rule's work in chunks, with a pause between them off the main thread: a numpy call holds the GIL
# (the selection over every sheet pair: 1.8 ms CPU) and the worker competes with the frame loop and
# llvmpipe for the cores (2 here); chunked and paused it takes about a tenth of a core
RAY_CHUNK = 512     # rays per Embree call (0.14 ms CPU; embreex releases the GIL while casting)
PAIR_CHUNK = 16384  # sheet pairs selected per step (lit_beside; 0.15 ms CPU)
BESIDE_MAX_PAIRS = 1_000_000  # lit_beside's pairs (estimated; the head 4e4, the scan 4e3) past which it pairs nothing
WORKER_PAUSE_S = 0.001  # the pause: the GIL and the CPU go to the main thread meanwhile


def _pause() -> None:
    """Between two chunks of the rule's work: off the main thread (the previews' worker, the start's
    warm-up) the frame loop gets the GIL (time.sleep releases it); on the main thread, nothing."""
    if threading.current_thread() is not threading.main_thread():
        time.sleep(WORKER_PAUSE_S)


def _lock(scene) -> threading.RLock:
    """The rule's lock on ``scene``: its caches are filled by the main thread, the start's warm-up
    thread (ui/warm.py) and the previews' worker (_BinWorker)."""
    cache = _rule_cache(scene)
    lock = cache.get("lock")
    if lock is None:
        lock = cache.setdefault("lock", threading.RLock())
    return lock


class _BinWorker:
    """Makes the rule's answer for a light-direction bin a governed preview asked about, in a daemon
    thread (the newest request wins; the thread ends when none is left), so a drag's frames never
    compute the rule: until the bin is known the preview keeps the TSM."""

    def __init__(self) -> None:
        self._mutex = threading.Lock()
        self._want: tuple | None = None
        self._thread: threading.Thread | None = None

    def request(self, bkey, args) -> None:
        with self._mutex:
            self._want = (bkey, args)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="skinviewer-tsm-rule", daemon=True)
                self._thread.start()

    def _run(self) -> None:
        while True:
            with self._mutex:
                job, self._want = self._want, None
                if job is None:
                    self._thread = None
                    return
            bkey, (settings, scene, pose, gaussians) = job
            bins = _rule_cache(scene).setdefault("tsm_bins", {})
            if bkey in bins:
                continue
            try:
                cand = tsm_candidates(settings, scene, pose, gaussians)
            except Exception:  # no Embree (ImportError), or anything else: unknown, the TSM is kept
                cand = None
            bins.setdefault(bkey, cand)

    def wait(self, timeout: float = 60.0) -> None:
        """Until no request is left (tests)."""
        t = self._thread
        while t is not None:
            t.join(timeout)
            with self._mutex:
                t = self._thread


def bin_worker(scene) -> _BinWorker:
    cache = _rule_cache(scene)
    w = cache.get("bin_worker")
    if w is None:
        w = cache.setdefault("bin_worker", _BinWorker())
    return w


def _rule_cache(scene) -> dict:
    """The rule's memory on the scene (its mesh is fixed for the scene's life)."""
    return scene.caches.rules


def _remember(cache: dict, key, value):
    """Keep ``value`` under a per-pose ``key``, forgetting the oldest beyond POSE_MEMORY."""
    order = cache.setdefault("_pose_keys", [])
    cache[key] = value
    order.append(key)
    while len(order) > POSE_MEMORY:
        cache.pop(order.pop(0), None)
    return value


def _mesh_rays(scene):
    """Embree (embreex, 0.2 s to import; trimesh's wrapper costs 2-3 s of start-up) over the mesh,
    with its face normals; cached on the scene."""
    cache = _rule_cache(scene)
    if "ray" not in cache:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh
        m = scene.mesh
        tris = m.positions.astype(np.float64)[m.indices.reshape(-1, 3)]
        fn = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-30)
        sc = rtcore_scene.EmbreeScene()
        TriangleMesh(sc, tris.astype(np.float32))
        cache["ray"] = (sc, fn)
    return cache


def _pose_key(pose) -> tuple:
    return (pose.kind, tuple(pose.direction), tuple(pose.position))


def _toward_light(pose, p: np.ndarray) -> np.ndarray:
    """Unit directions from points ``p`` towards the light ``pose`` (LightSettings fields)."""
    if pose.kind == "point":
        L = np.asarray(pose.position, np.float64) - p
        return L / np.maximum(np.linalg.norm(L, axis=1, keepdims=True), 1e-12)
    d = np.asarray(pose.direction, np.float64)
    return np.broadcast_to(d / np.linalg.norm(d), p.shape)


def _facing(scene, pose):
    """The mesh's positions, normals, directions to the light and N.L, and the vertices whose normal
    faces away from the light (N.L < -0.05; a sample of MAX_RAYS: thin parts span many vertices).
    The last pose's answer is kept (thickness_toward and lit_beside both ask)."""
    cache = _rule_cache(scene)
    key = ("facing",) + _pose_key(pose)
    last = cache.get("facing")
    if last is not None and last[0] == key:
        return last[1]
    if "vertex_arrays" not in cache:
        cache["vertex_arrays"] = (scene.mesh.positions.astype(np.float64), scene.mesh.normals.astype(np.float64))
    p, n = cache["vertex_arrays"]
    L = _toward_light(pose, p)
    nl = np.einsum("ij,ij->i", n, L)
    back = np.nonzero(nl < -0.05)[0]
    out = (p, n, L, nl, back[::max(1, len(back) // MAX_RAYS)])
    cache["facing"] = (key, out)
    return out


def thickness_toward(scene, pose) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each vertex whose normal faces away from the light (``pose``: LightSettings fields):
    (vertex index, thickness in mm to the lit surface along the ray to the light, cos at that entry
    point). Cached per scene and light pose (the last POSE_MEMORY poses)."""
    cache = _mesh_rays(scene)
    key = ("thick",) + _pose_key(pose)
    if key in cache:
        return cache[key]
    sc, face_normals = cache["ray"]
    p, _, L, _, back = _facing(scene, pose)
    out = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0))
    if len(back):
        eps = 1e-4 * scene.radius
        origins = p[back] + L[back] * eps
        o32, d32 = origins.astype(np.float32), np.ascontiguousarray(L[back], np.float32)
        tri_c, tfar_c = [], []
        for c in range(0, len(back), RAY_CHUNK):  # each ray is independent: chunks give the same hits
            if c:
                _pause()
            hit = sc.run(np.ascontiguousarray(o32[c:c + RAY_CHUNK]), np.ascontiguousarray(d32[c:c + RAY_CHUNK]), output=1)
            tri_c.append(np.asarray(hit["primID"]))
            tfar_c.append(np.asarray(hit["tfar"], np.float64))
        tri, tfar = np.concatenate(tri_c), np.concatenate(tfar_c)
        ray_i = np.nonzero(tri >= 0)[0]
        if len(ray_i):
            t = (tfar[ray_i] + eps) * scene.mm_per_unit
            cos_a = np.abs(np.einsum("ij,ij->i", face_normals[tri[ray_i]], L[back][ray_i]))
            out = (back[ray_i], t, cos_a)
    return _remember(cache, key, out)


def _vertex_area(scene) -> np.ndarray:
    """A third of each incident triangle's area per vertex, mm^2 (cached on the scene)."""
    cache = _rule_cache(scene)
    if "vertex_area" not in cache:
        m = scene.mesh
        p = m.positions.astype(np.float64)
        tri = p[m.indices.reshape(-1, 3)] * scene.mm_per_unit
        made = np.zeros(len(p))
        np.add.at(made, m.indices.reshape(-1, 3), (0.5 / 3.0) * np.linalg.norm(
            np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)[:, None])
        cache["vertex_area"] = made
    area: np.ndarray = cache["vertex_area"]
    return area


def sheet_pairs(scene, radius_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Every pair (i, j), i < j, of the mesh's vertices within ``radius_mm`` whose normals are more
    than 60 degrees apart (another sheet: the same sheet's light is the surface blur's, not the TSM's).
    It does not depend on the light: made once per scene and radius (one KD-tree over the vertices),
    so a light move only selects from it (lit_beside)."""
    from scipy.spatial import cKDTree
    cache = _rule_cache(scene)
    key = ("sheet_pairs", round(radius_mm, 3))
    if key not in cache:
        p = scene.mesh.positions.astype(np.float64)
        n = scene.mesh.normals.astype(np.float64)
        ij = cKDTree(p).query_pairs(radius_mm / scene.mm_per_unit, output_type="ndarray").astype(np.int64)
        other = np.einsum("ij,ij->i", n[ij[:, 0]], n[ij[:, 1]]) < 0.5
        old = [k for k in cache if isinstance(k, tuple) and k[0] == "sheet_pairs"]
        for k in old[:-2]:  # a profile edit changes the radius: keep the last few
            cache.pop(k, None)
        cache[key] = (np.ascontiguousarray(ij[other, 0]), np.ascontiguousarray(ij[other, 1]))
    pairs: tuple[np.ndarray, np.ndarray] = cache[key]
    return pairs


def lit_beside(scene, pose, radius_mm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What the TSM's light-space gather (deon.tsm_gather) reaches beside the ray: for each vertex
    whose normal faces away from the light, the vertices within ``radius_mm`` that face the light
    from another sheet (normals more than 60 degrees apart: the same sheet's light is the surface
    blur's, not the TSM's), as pairs (vertex index, pair's vertex k, distance in mm, lit area A cos
    in mm^2). Shadows ignored (conservative). The pairs are the light-independent sheet_pairs,
    selected by which end faces the light. Cached per scene, light pose and radius."""
    cache = _rule_cache(scene)
    key = ("beside",) + _pose_key(pose) + (round(radius_mm, 3),)
    if key in cache:
        return cache[key]
    p, n, _, nl, back = _facing(scene, pose)
    lit = np.nonzero(nl > 0.05)[0]
    stride = max(1, len(lit) // MAX_LIT)  # a dense scan: a sample of the lit vertices, each for `stride`
    lit = lit[::stride]
    mm = scene.mm_per_unit
    area = _vertex_area(scene)
    k = q = np.zeros(0, np.int64)
    if len(back) and len(lit) and len(p) > PAIRS_MAX_VERTICES:  # a dense scan: every pair would not fit
        from scipy.spatial import cKDTree
        pairs = cKDTree(p[back]).sparse_distance_matrix(cKDTree(p[lit]), radius_mm / mm, output_type="ndarray")
        k, q = pairs["i"].astype(np.int64), lit[pairs["j"]]
        other = np.einsum("ij,ij->i", n[q], n[back[k]]) < 0.5
        k, q = k[other], q[other]
    elif len(back) and len(lit):
        i, j = sheet_pairs(scene, radius_mm)
        slot = np.full(len(p), -1, np.int64)  # vertex -> its place in `back` (-1: not a ray's vertex)
        slot[back] = np.arange(len(back))
        is_lit = np.zeros(len(p), bool)
        is_lit[lit] = True
        ka, qa, kb, qb = [], [], [], []
        for c in range(0, len(i), PAIR_CHUNK):  # in chunks (_pause), the pairs' order kept
            if c:
                _pause()
            ic, jc = i[c:c + PAIR_CHUNK], j[c:c + PAIR_CHUNK]
            a = (slot[ic] >= 0) & is_lit[jc]  # i faces away, j is lit
            b = (slot[jc] >= 0) & is_lit[ic]
            ka.append(slot[ic[a]])
            qa.append(jc[a])
            kb.append(slot[jc[b]])
            qb.append(ic[b])
        k = np.concatenate(ka + kb) if ka else k
        q = np.concatenate(qa + qb) if qa else q
    out = (back, k, np.linalg.norm(p[q] - p[back[k]], axis=1) * mm, stride * area[q] * nl[q])
    return _remember(cache, key, out)


def _profile_key(gaussians) -> tuple:
    return tuple((g.variance, tuple(g.weights)) for g in gaussians)


def _pose_bin(scene, pose) -> tuple:
    """The light's coarse pose: its direction (a point light: its direction from the scene's centre
    and its distance in scene radii, halved steps) rounded to 1 / TSM_BIN."""
    if pose.kind == "point":
        v = np.asarray(pose.position, np.float64) - np.asarray(scene.frame[0], np.float64)
        dist = float(np.linalg.norm(v))
        d = v / max(dist, 1e-12)
        return ("point", tuple(np.round(d * TSM_BIN).astype(int)), round(2.0 * dist / max(scene.radius, 1e-12)))
    d = np.asarray(pose.direction, np.float64)
    d = d / max(float(np.linalg.norm(d)), 1e-12)
    return (pose.kind, tuple(np.round(d * TSM_BIN).astype(int)))


def tsm_needed(settings, scene, pose, gaussians, frame: FrameView, interactive: bool = False) -> tuple[bool, str]:
    """Whether the TSM term can show: a vertex in view whose normal faces away from the light
    while the light enters the mesh within a thickness that transmits, estimated as in
    lib/tsm_transmit.glsl: w_i exp(-d^2 / 2 v_i) min(r / 3 sigma_i, 1) cos_A (r ~ d), above TSM_EPS;
    with deon.tsm_gather also sum_i w_i G(v_i, d) A cos over tissue of another sheet lit beside the ray.
    Memoised per light pose, profile and view (several passes ask every frame). ``frame``: the
    frame's view (Reflection.view), whose camera the thin part must be in view of.

    ``interactive`` (a governed preview while the user drags or edits, issue 27): the answer of the
    light's coarse pose (_pose_bin, ~10 degrees): the union of the vertices the exact rule found for
    every pose of that bin it was asked about, so a drag computes the rule once per bin, not once per
    frame, and keeps the TSM wherever any pose of the bin needed it. The final image always asks
    the exact rule (interactive False): the refined image is the ungoverned render."""
    gather = settings.deon.tsm_gather
    memo = scene.caches.tsm_needed
    view_key = (settings.camera.model_dump_json(), settings.render.width, settings.render.height)
    if interactive:
        bins = _rule_cache(scene).setdefault("tsm_bins", {})
        if len(bins) > 512:  # profile edits: bins of old profiles
            bins.clear()
        bkey = (_pose_bin(scene, pose), _profile_key(gaussians), gather)
        key = ("bin", bkey) + view_key
        if key not in memo:
            if bkey not in bins:
                if TSM_WORKER:  # made in the background; until then keep the TSM (not memoised)
                    bin_worker(scene).request(bkey, (settings, scene, pose, gaussians))
                    return True, ""
                try:
                    bins[bkey] = tsm_candidates(settings, scene, pose, gaussians)
                except ImportError:
                    bins[bkey] = None
            if len(memo) > 16:
                memo.clear()
            need, why = _decide(settings, scene, bins[bkey], frame)
            memo[key] = (need, why + " (preview: the light's ~10\u00b0 direction bin)" if why else why)
        return memo[key]
    key = _pose_key(pose) + (_profile_key(gaussians), gather) + view_key
    if key not in memo:
        if len(memo) > 16:
            memo.clear()
        memo[key] = _tsm_needed(settings, scene, pose, gaussians, frame)
    return memo[key]


def beside_pairs(scene, pose, reach_mm: float) -> float:
    """About how many (vertex facing away, lit vertex) pairs lie within ``reach_mm``: their product times the
    share of the mesh's surface a disc of that reach covers (its bounding sphere's, at most 1)."""
    _, _, _, nl, back = _facing(scene, pose)
    lit = min(int(np.count_nonzero(nl > 0.05)), MAX_LIT)
    r_mm = float(scene.radius) * float(scene.mm_per_unit)
    share = min(1.0, reach_mm * reach_mm / (4.0 * r_mm * r_mm)) if r_mm > 0 else 1.0
    return float(len(back)) * lit * share


def tsm_candidates(settings, scene, pose, gaussians) -> np.ndarray:
    """The exact rule's vertices through which the TSM term transmits more than TSM_EPS (in view
    or not), cached per light pose, profile and gather (the last POSE_MEMORY). ImportError: no Embree.
    A governed preview's bin (tsm_needed) takes the union of these."""
    with _lock(scene):
        cache = _rule_cache(scene)
        key = ("cand",) + _pose_key(pose) + (_profile_key(gaussians), settings.deon.tsm_gather)
        if key in cache:
            return cache[key]
        idx, t, cos_a = thickness_toward(scene, pose)
        amp = np.zeros(len(idx))
        for i, g in enumerate(gaussians):
            if i == 0 or not (g.variance > 0) or max(g.weights) <= 0:
                continue
            sig = math.sqrt(g.variance)
            amp = np.maximum(amp, max(g.weights) * np.exp(-t * t / (2.0 * g.variance)) * np.minimum(t / (3.0 * sig), 1.0))
        amp *= cos_a
        cand = idx[amp > TSM_EPS]
        if settings.deon.tsm_gather:  # lit tissue of another sheet beside the ray (lib/tsm_transmit.glsl)
            wide = [(g.variance, max(g.weights)) for i, g in enumerate(gaussians)
                    if i > 0 and g.variance > 0 and max(g.weights) > TSM_EPS]
            reach = max((math.sqrt(2.0 * v * math.log(w / TSM_EPS)) for v, w in wide), default=0.0)
            if beside_pairs(scene, pose, reach) > BESIDE_MAX_PAIRS:  # e.g. a dense head a few mm across (its
                # units not mm): nearly every pair is within reach (10 s and 3 GB a light move on the scan at 1
                # mm a unit); every vertex facing away is kept, as the gather could reach it (never drop, unproven)
                cand = np.union1d(cand, _facing(scene, pose)[4])
            elif reach > 0:  # sum_i w_i sum_q G(v_i, d_q) A_q cos_q: the gather's integral over those vertices
                back, k, d, acos = lit_beside(scene, pose, reach)
                a2 = np.zeros(len(back))
                for v, w in wide:
                    np.add.at(a2, k, w * np.exp(-d * d / (2.0 * v)) / (2.0 * math.pi * v) * acos)
                cand = np.union1d(cand, back[a2 > TSM_EPS])
        bins = cache.get("tsm_bins")
        if bins is not None:  # a bin the previews use keeps every pose's vertices asked exactly since
            bkey = (_pose_bin(scene, pose), _profile_key(gaussians), settings.deon.tsm_gather)
            if bins.get(bkey) is not None:
                bins[bkey] = np.union1d(bins[bkey], cand)
        return _remember(cache, key, cand)


def _tsm_needed(settings, scene, pose, gaussians, frame: FrameView) -> tuple[bool, str]:
    """The exact rule (tsm_needed without the memo)."""
    try:
        cand = tsm_candidates(settings, scene, pose, gaussians)
    except ImportError:  # no Embree: keep the TSM (never drop an effect we cannot rule out)
        return True, ""
    return _decide(settings, scene, cand, frame)


def _decide(settings, scene, cand: np.ndarray | None, frame: FrameView) -> tuple[bool, str]:
    """Whether any of the vertices ``cand`` faces the camera inside the view (None: unknown, keep)."""
    if cand is None:
        return True, ""
    if len(cand) == 0:
        return False, "no light behind a thin part"
    view = frame.camera  # the rendered camera (the frame's view)
    p = scene.mesh.positions[cand].astype(np.float64)
    facing = np.einsum("ij,ij->i", scene.mesh.normals[cand].astype(np.float64), view.eye - p) > 0
    ph = np.hstack([p, np.ones((len(p), 1))]) @ view.view_proj.T
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = ph[:, :3] / ph[:, 3:4]
    inside = (ph[:, 3] > 0) & np.all(np.abs(ndc[:, :2]) <= 1.02, axis=1)
    if not np.any(facing & inside):
        return False, "the thin part the light is behind is out of view"
    return True, ""
