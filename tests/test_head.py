"""The procedural default head: determinism, cache, atlas, ears, regions (detail 0 unless noted)."""
import numpy as np
import pytest
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from skinviewer.ground.settings import REGIONS
from skinviewer.scene import head as head_mod
from skinviewer.scene.head import GENERATOR_VERSION, default_head

ARRAYS = ("positions", "normals", "uvs", "indices", "albedo", "normal_map", "specular_map", "region_map")


@pytest.fixture(scope="module")
def head(tmp_path_factory):
    return default_head(detail=0, seed=7, cache_dir=tmp_path_factory.mktemp("cache"))


def _equal(a, b):
    return all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ARRAYS)


def _islands(mesh):
    """Connected components in UV (vertices shared by index): label per triangle."""
    f = mesh.indices.astype(np.int64)
    n = len(mesh.positions)
    rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    return count, labels[f[:, 0]], labels


def _rasterize(uvs, tris, res, inset):
    """Per-texel count of UV triangles covering the texel centre; inset > 0 keeps only interior
    hits (barycentrics > inset), inset < 0 dilates a little (conservative coverage)."""
    cover = np.zeros((res, res), dtype=np.int32)
    t = uvs[tris].astype(np.float64) * res
    lo = np.floor(t.min(axis=1) - 1).astype(int).clip(0, res - 1)
    hi = np.ceil(t.max(axis=1) + 1).astype(int).clip(0, res - 1)
    for (a, b, c), (x0, y0), (x1, y1) in zip(t, lo, hi):
        gx, gy = np.meshgrid(np.arange(x0, x1 + 1) + 0.5, np.arange(y0, y1 + 1) + 0.5)
        det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        if abs(det) < 1e-12:
            continue
        w1 = ((gx - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (gy - a[1])) / det
        w2 = ((b[0] - a[0]) * (gy - a[1]) - (gx - a[0]) * (b[1] - a[1])) / det
        w0 = 1.0 - w1 - w2
        inside = (w0 > inset) & (w1 > inset) & (w2 > inset)
        cover[y0:y1 + 1, x0:x1 + 1] += inside
    return cover


def test_deterministic_and_seeded():
    a = head_mod._generate(0, 7)
    b = head_mod._generate(0, 7)
    for k in ARRAYS:
        assert a[k].dtype == b[k].dtype and np.array_equal(a[k], b[k]), k
    c = head_mod._generate(0, 8)
    assert np.array_equal(a["positions"], c["positions"])  # the seed is skin noise only
    assert not np.array_equal(a["albedo"], c["albedo"])
    assert not np.array_equal(a["normal_map"], c["normal_map"])


def test_cache_reused_and_corrupt_cache_regenerated(tmp_path, monkeypatch):
    first = default_head(detail=0, seed=3, cache_dir=tmp_path)
    files = list(tmp_path.glob("*.npz"))
    assert len(files) == 1 and f"v{GENERATOR_VERSION}" in files[0].name
    assert not list(tmp_path.glob("*.tmp"))

    real = head_mod._generate
    calls = []

    def counting(detail, seed):
        calls.append((detail, seed))
        return real(detail, seed)

    monkeypatch.setattr(head_mod, "_generate", counting)
    again = default_head(detail=0, seed=3, cache_dir=tmp_path)
    assert calls == [] and _equal(first, again)

    files[0].write_bytes(b"PK\x03\x04 not really a zip")
    healed = default_head(detail=0, seed=3, cache_dir=tmp_path)
    assert calls == [(0, 3)] and _equal(first, healed)
    default_head(detail=0, seed=3, cache_dir=tmp_path)
    assert len(calls) == 1  # the regenerated file was written back


def test_cache_dir_from_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    path = head_mod._cache_path(0, 1, None)
    assert path.parent == tmp_path
    path.write_bytes(b"")  # an empty (interrupted) cache file is regenerated, not a crash
    default_head(detail=0, seed=1)
    assert path.stat().st_size > 0


def test_triangle_counts(tmp_path):
    coarse = default_head(detail=0, cache_dir=tmp_path)
    assert 4_000 <= len(coarse.indices) <= 12_000
    assert coarse.albedo.shape == (512, 512, 3)
    normal = default_head(detail=1, cache_dir=tmp_path)
    assert 20_000 <= len(normal.indices) <= 70_000
    assert normal.albedo.shape == (1024, 1024, 3) and normal.region_map.shape == (1024, 1024)


def test_finite_unit_normals_uvs_in_range(head):
    assert head.mm_per_unit == 1.0
    for k in ("positions", "normals", "uvs", "tangents"):
        assert np.all(np.isfinite(getattr(head, k))), k
    np.testing.assert_allclose(np.linalg.norm(head.normals, axis=1), 1.0, atol=1e-4)
    assert head.uvs.min() >= 0.0 and head.uvs.max() <= 1.0
    for k in ("albedo", "normal_map", "specular_map"):
        m = getattr(head, k)
        assert m.dtype == np.float32 and np.all(np.isfinite(m)) and m.min() >= 0 and m.max() <= 1, k
    assert head.specular_map.shape[-1] == 1 and head.region_map.dtype == np.uint8
    assert head.region_map.max() < len(REGIONS)
    # tangent-space normals point out of the surface
    assert (head.normal_map[..., 2] * 2 - 1).min() > 0.5


def test_adult_proportions(head):
    lo, hi = head.bounds
    count, _, vlabel = _islands(head)
    main = np.bincount(vlabel).argmax()
    skull = head.positions[vlabel == main]
    chin = skull[(np.abs(skull[:, 0]) < 10) & (skull[:, 2] > 65)][:, 1].min()
    assert 215 <= hi[1] - chin <= 245          # crown to chin
    assert 140 <= 2 * np.abs(skull[skull[:, 1] > 0][:, 0]).max() <= 165   # head width
    assert hi[1] - 100 > 0 > lo[1] + 100 and 70 <= chin - lo[1] <= 110     # origin in the head, short neck
    # the collar cut is closed (no open tube, no hole): the band runs to a pole under the neck
    bottom = head.positions[head.positions[:, 1] < lo[1] + 25]
    assert np.ptp(bottom[:, 0]) > 90                                         # the cut spans the neck
    throat = skull[(np.abs(skull[:, 0]) < 8) & (skull[:, 2] > 20)][:, 1].min()
    assert 50 <= chin - throat <= 90                                         # chin to sternal notch
    assert head.positions[:, 2].argmax() in np.flatnonzero(vlabel == main)  # faces +Z (nose tip)


def test_uv_atlas_has_no_overlaps(head):
    cover = _rasterize(head.uvs, head.indices, 512, inset=1e-3)
    assert cover.max() == 1
    assert cover.sum() > 0.25 * 512 * 512  # the atlas is reasonably used


def test_uv_islands_are_separated_by_gutters(head):
    count, tri_label, _ = _islands(head)
    assert count == 8  # head band, crown cap, two sides of two ears, two eyeballs
    res = 1024
    masks = [_rasterize(head.uvs, head.indices[tri_label == i], res, inset=-0.02) > 0 for i in range(count)]
    for i, m in enumerate(masks):
        dist = ndimage.distance_transform_edt(~m)
        for j in range(i + 1, count):
            assert dist[masks[j]].min() >= 8.0, (i, j)
    uv = head.uvs
    assert uv.min() >= 0.005 and uv.max() <= 0.995


def test_no_degenerate_uv_triangles(head):
    t = head.uvs[head.indices].astype(np.float64)
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    assert area.min() > 0.0


def _ray_hits(origins, dirs, tri):
    """Nearest positive hit distance of each ray against triangles (Möller–Trumbore), inf if none."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    out = np.full(len(origins), np.inf)
    for i, (o, d) in enumerate(zip(origins, dirs)):
        p = np.cross(d, e2)
        det = np.sum(e1 * p, axis=1)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - v0
        u = np.sum(s * p, axis=1) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.sum(e2 * q, axis=1) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)
        if hit.any():
            out[i] = t[hit].min()
    return out


def test_ears_are_thin_closed_flaps(head):
    count, tri_label, vlabel = _islands(head)
    pos = head.positions.astype(np.float64)
    ears = [i for i in range(count) if np.abs(pos[vlabel == i, 0]).mean() > 60]
    assert len(ears) == 4
    region_at = head.region_map[(head.uvs[:, 1] * 512).astype(int).clip(0, 511),
                                (head.uvs[:, 0] * 512).astype(int).clip(0, 511)]
    for side in (+1, -1):
        front, back = sorted((i for i in ears if np.sign(pos[vlabel == i, 0].mean()) == side),
                             key=lambda i: -side * head.normals[vlabel == i, 0].mean())
        assert np.all(region_at[vlabel == front] == REGIONS.index("ears"))
        # both sheets are sampled at the same ear-plane points: the rim points coincide (closed shell)
        fv, bv = pos[vlabel == front], pos[vlabel == back]
        assert len(fv) == len(bv)
        gap = np.linalg.norm(fv - bv, axis=1)
        assert np.sum(gap < 1e-4) >= 24
        # thickness: rays from the front sheet across the flap to the first back-sheet triangle;
        # thin (~2 mm) a few mm inside the helix rim, thicker (~3.5-4.5 mm) towards the root
        rim = fv[gap < 1e-4]
        sel = np.flatnonzero(gap > 0.5)
        from_rim = np.linalg.norm(fv[sel, None] - rim[None], axis=-1).min(axis=1)
        across = (bv[sel] - fv[sel]) / gap[sel, None]
        thickness = _ray_hits(fv[sel], across, pos[head.indices[tri_label == back]])
        hit = np.isfinite(thickness)
        assert hit.mean() > 0.85  # a few rays leave the coarse (detail 0) sheet at its border
        assert np.all((thickness[hit] > 0.3) & (thickness[hit] < 5.5))
        near_rim = hit & (from_rim >= 3.0) & (from_rim < 7.0)
        root = hit & (from_rim >= 11.0)
        assert near_rim.sum() >= 10 and root.sum() >= 10
        assert 1.8 <= np.median(thickness[near_rim]) <= 2.8
        assert np.median(thickness[root]) >= 3.2
        assert np.median(thickness[root]) > np.median(thickness[near_rim]) + 0.8


def test_regions_present_and_anatomical(head):
    ids = set(np.unique(head.region_map).tolist())
    for name in ("forehead", "nose", "cheeks", "lips", "chin", "ears", "neck", "scalp"):
        assert REGIONS.index(name) in ids, name
    res = head.region_map.shape[0]
    at = head.region_map[(head.uvs[:, 1] * res).astype(int).clip(0, res - 1),
                         (head.uvs[:, 0] * res).astype(int).clip(0, res - 1)]
    p = head.positions
    z_of = lambda name: p[at == REGIONS.index(name), 2]
    y_of = lambda name: p[at == REGIONS.index(name), 1]
    assert z_of("nose").max() == pytest.approx(p[:, 2].max(), abs=1.0)  # the nose tip leads
    assert z_of("nose").mean() > z_of("cheeks").mean()
    assert y_of("forehead").mean() > y_of("nose").mean() > y_of("lips").mean() > y_of("chin").mean()
    assert y_of("neck").mean() < y_of("chin").mean()
    assert y_of("scalp").max() == pytest.approx(p[:, 1].max(), abs=1.0)


def test_maps_fill_gutters_and_redden_lips(head):
    count, tri_label, _ = _islands(head)
    # gutter texels were filled from islands: no black/unset albedo anywhere
    assert head.albedo.min() > 0.02
    lips = head.region_map == REGIONS.index("lips")
    cheeks = head.region_map == REGIONS.index("cheeks")
    redness = lambda m: (head.albedo[m, 0] - head.albedo[m, 1]).mean()
    assert redness(lips) > redness(cheeks)


def test_eyeballs_sit_in_the_orbits_behind_open_lids(head):
    count, tri_label, vlabel = _islands(head)
    pos = head.positions.astype(np.float64)
    res = head.region_map.shape[0]
    eyes = [i for i in range(count)
            if np.linalg.norm(pos[vlabel == i].mean(axis=0) - [np.sign(pos[vlabel == i, 0].mean()) * 32, 12, 70]) < 5]
    assert len(eyes) == 2
    assert sorted(np.sign(pos[vlabel == i, 0].mean()) for i in eyes) == [-1, 1]
    for i in eyes:
        p = pos[vlabel == i]
        side = np.sign(p[:, 0].mean())
        centre = head_mod.EYE_C * [side, 1, 1]
        r = np.linalg.norm(p - centre, axis=1)
        assert 11.5 <= r.min() and r.max() <= 14.0 and np.ptp(p[:, 1]) >= 23.0  # a ~24 mm globe
        assert np.sum(tri_label == i) <= 1500                                   # cheap
        at = head.region_map[(head.uvs[vlabel == i, 1] * res).astype(int).clip(0, res - 1),
                             (head.uvs[vlabel == i, 0] * res).astype(int).clip(0, res - 1)]
        assert np.all(at == REGIONS.index("other"))
        # inside the orbit: behind the nose tip and brow, between the nose and the temple
        assert p[:, 2].max() < pos[:, 2].max() - 15 and 14 < np.abs(p[:, 0]).min() < 32 < np.abs(p[:, 0]).max() < 48
        # the lids are open around the cornea, cover the top of the globe, and the lid margin
        # lies on the eyeball (skin just behind it inside the fissure, in front of it outside)
        sdf = lambda q: head_mod.head_sdf(q[:, 0], q[:, 1], q[:, 2])
        ahead = centre + np.array([[0, 0, 14.0], [0, -3.5, 13.5], [side * 6, 0, 13.0]])
        assert np.all(sdf(ahead) > 0)                       # iris and pupil visible
        top = centre + 12.5 * np.array([[0, np.sin(0.6), np.cos(0.6)], [0, -np.sin(0.75), np.cos(0.75)]])
        assert np.all(sdf(top) < 0)                         # upper and lower lids over the globe
    # the iris and pupil are painted: a dark centre and a bright sclera on the eyeball islands
    albedo = head.albedo
    for i in eyes:
        uv = head.uvs[vlabel == i]
        pole = uv[np.argmax(pos[vlabel == i, 2])]
        c = albedo[int(pole[1] * res), int(pole[0] * res)]
        assert c.max() < 0.15                               # pupil
    sclera = head.region_map == REGIONS.index("other")
    assert np.percentile(albedo[sclera].mean(axis=1), 90) > 0.7


def test_neck_widens_into_the_trapezius(head):
    """Not a cylinder cut flat: the neck's narrowest slice is well below the head's width and
    the base flares out towards the shoulders; the cut is lower at the sides than at the middle."""
    count, _, vlabel = _islands(head)
    skin = head.positions[vlabel == np.bincount(vlabel).argmax()].astype(np.float64)
    lo_y = skin[:, 1].min()
    width = lambda y0, y1: np.ptp(skin[(skin[:, 1] >= y0) & (skin[:, 1] < y1), 0])
    neck = min(width(y, y + 8) for y in np.arange(-150.0, -110.0, 4.0))
    base = width(lo_y + 10, lo_y + 25)
    assert 95 <= neck <= 125
    assert base > 1.25 * neck
    rim = skin[skin[:, 1] < lo_y + 40]
    assert rim[np.abs(rim[:, 0]) > 60, 1].min() < rim[np.abs(rim[:, 0]) < 15, 1].min() + 5


def test_only_the_eyes_are_region_other(head):
    """Region "other" marks non-skin (the eyeballs), so screen-space passes can skip it."""
    count, _, vlabel = _islands(head)
    res = head.region_map.shape[0]
    at = head.region_map[(head.uvs[:, 1] * res).astype(int).clip(0, res - 1),
                         (head.uvs[:, 0] * res).astype(int).clip(0, res - 1)]
    other = at == REGIONS.index("other")
    eye_c = np.abs(head.positions - head_mod.EYE_C * np.array([1, 1, 1])).max(axis=1)
    eye_c = np.minimum(eye_c, np.abs(head.positions - head_mod.EYE_C * np.array([-1, 1, 1])).max(axis=1))
    assert other.any() and np.all(eye_c[other] <= head_mod.EYE_R + 2.0)
    # and the eyeballs' maps: glossy (full specular scale), flat normals
    eye_texels = head.region_map == REGIONS.index("other")
    assert head.specular_map[eye_texels, 0].min() > 0.95
    assert np.abs(head.normal_map[eye_texels] - [0.5, 0.5, 1.0]).max() < 0.01


def test_normal_map_detail_spans_several_texels(head):
    """Pore-scale relief without single-texel noise (blocky when magnified): neighbouring texels'
    normals are strongly correlated, and the relief is there (not flat)."""
    skin = (head.region_map != REGIONS.index("other"))
    skin = ndimage.binary_erosion(skin, iterations=4)
    nx = head.normal_map[..., 0].astype(np.float64) * 2 - 1
    a, b = nx[:, :-1][skin[:, :-1] & skin[:, 1:]], nx[:, 1:][skin[:, :-1] & skin[:, 1:]]
    assert a.std() > 0.003
    assert np.corrcoef(a, b)[0, 1] > 0.55   # single-texel pits (the old map): 0.48


def test_ear_rings_are_zipped_into_regular_strips(head):
    """The helix, scapha and antihelix run along the ear's rings. Rings joined by a Delaunay
    triangulation with differing point counts zig-zagged across those ridges (a serrated helix and
    rippled shading) and left the detail-0 rim open; rings are now zipped band by band, and from
    OUTER_RING out they share one count, staggered: each band is a regular strip."""
    from skinviewer.scene.head.tessellate import _zip_rings
    from skinviewer.scene.mesh import is_closed
    for na, nb in ((6, 12), (93, 93), (40, 57), (57, 40)):
        a = (np.arange(na) + 0.5 * (na == nb)) * 2 * np.pi / na
        b = np.arange(nb) * 2 * np.pi / nb
        t = _zip_rings(a, b, 0, na)
        assert len(t) == na + nb
        assert np.all((t < na).sum(1) >= 1) and np.all((t >= na).sum(1) >= 1)  # corners on both rings
        ring_edges = [tuple(sorted(e)) for tri in t for e in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0]))
                      if (e[0] < na) == (e[1] < na)]
        assert sorted(ring_edges) == sorted({tuple(sorted((i, (i + 1) % na))) for i in range(na)}
                                            | {tuple(sorted((na + j, na + (j + 1) % nb))) for j in range(nb)})
        if na == nb:  # a staggered pair of equal rings: triangles alternate between the rings
            on_a = (t < na).sum(1) == 2
            assert np.all(on_a[1:] != on_a[:-1])
    assert is_closed(head.positions, head.indices)  # detail 0 too
