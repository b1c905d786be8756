"""Rendering through the graph: every scene finite, the default head plausible, the CLI."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from helpers import assert_all_finite, small_settings

from skinviewer import techniques
from skinviewer.cli import main
from skinviewer.ground.settings import with_values
from skinviewer.scene.scenes import SCENES


@pytest.mark.parametrize("scene", SCENES)
def test_every_scene_every_technique_is_finite(renderer, scene):
    for tech in techniques.names():
        s = small_settings(scene, tech, size=64)
        renderer.render(s)
        assert_all_finite(renderer, s)


def test_head_renders_a_plausible_image(renderer):
    s = small_settings("head", "phong", size=128)
    renderer.render(s)
    img = renderer.image(s).astype(np.float32)
    subject = np.abs(img - img[0, 0]).sum(axis=2) > 12
    assert 0.15 < subject.mean() < 0.9, "the head should fill a good part of the frame"
    lit = img[subject]
    # skin: red > green > blue on average, and real shading variation
    assert lit[:, 0].mean() > lit[:, 1].mean() > lit[:, 2].mean()
    assert lit.std() > 12


def test_camera_orbit_changes_image_only_through_final(renderer):
    s = small_settings("head", "phong", size=64)
    renderer.render(s)
    a = renderer.image(s)
    s2 = with_values(s, {"camera.yaw": s.camera.yaw + 60})
    rep = renderer.render(s2)
    assert set(rep.ran) == {"phong", "output"}
    assert np.abs(renderer.image(s2).astype(int) - a).mean() > 2


def test_cli_render_dump_and_timings(tmp_path, renderer):
    out, dump, tj = tmp_path / "x.png", tmp_path / "dump", tmp_path / "t.json"
    rc = main(["render", "--scene", "shadow-edge", "--technique", "phong", "--size", "64x48", "--out", str(out),
               "--dump-passes", str(dump), "--timings", str(tj), "--set", "shadow.map_size=256"])
    assert rc == 0
    from PIL import Image
    assert Image.open(out).size == (64, 48)
    graph = json.loads((dump / "graph.json").read_text())
    # render.timing = auto: sync on a software rasterizer, timer queries on a GPU (renderer.timing_mode)
    assert graph["timing_mode"] == renderer.timing_mode("auto") and graph["order"][-1] == "output"
    statuses = {p["name"]: p["status"] for p in graph["passes"]}
    assert statuses["shadow_map_0"] == "ran" and statuses["shadow_map_3"] == "pruned"
    for name in ("shadow_map_0", "lit", "image"):
        arr = np.load(dump / f"{name}.npy")
        assert arr.dtype == np.float32 and np.all(np.isfinite(arr))
        assert (dump / f"{name}.png").is_file()
    t = json.loads(tj.read_text())
    assert {"frame", "timing_mode", "passes", "total_ms"} <= set(t)


def test_cli_render_verbose_prints_the_pass_table_and_the_memory_held(tmp_path, capsys):
    from skinviewer.engine.memory import texture_bytes
    out = tmp_path / "x.png"
    assert main(["render", "--scene", "shadow-edge", "--technique", "phong", "--size", "64x48", "--out", str(out),
                 "--set", "shadow.map_size=256", "-v"]) == 0
    text = capsys.readouterr().out
    assert "shadow_map_0" in text
    line = next(ln for ln in text.splitlines() if ln.startswith("GPU memory held:"))
    mib = float(line.split(":")[1].split("MiB")[0])
    class _T:  # the 64x48 RGBA32F image alone: the renderer holds more (maps, mesh), and nothing absurd
        size, components, dtype = (64, 48), 4, "f4"
    assert texture_bytes(_T()) / 2**20 < mib < 512


@pytest.mark.parametrize("argv,msg", [
    (["--scene", "nowhere"], "invalid choice"),
    (["--set", "lights.0.intensity=-1"], "lights.0.intensity"),
    (["--set", "no.such=1"], "no such setting"),
    (["--mesh", "/nonexistent/head.glb"], "not found"),
    (["--preset", "/nonexistent/p.json"], "cannot read"),
    (["--technique", "raytracing"], "technique"),
    (["--size", "big"], "WxH"),
])
def test_cli_errors_are_one_clear_line(tmp_path, argv, msg):
    p = subprocess.run([sys.executable, "-m", "skinviewer.cli", "render", "--out", str(tmp_path / "o.png"), *argv],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2
    assert msg in p.stderr
    assert "Traceback" not in p.stderr
    assert not (tmp_path / "o.png").exists()


def test_headless_context_failure_says_what_to_install(monkeypatch):
    import moderngl

    from skinviewer.kernel import gl

    def refuse(*a, **k):
        raise Exception("eglInitialize failed")

    monkeypatch.setattr(moderngl, "create_standalone_context", refuse)
    with pytest.raises(gl.GLUnavailableError, match="libegl1"):
        gl.headless_context()


def test_package_data_globs_cover_shaders_and_presets():
    """The wheel ships shaders/ and presets/ (pyproject package-data): every file must match a glob,
    read as setuptools reads it (recursive glob: `**/` matches zero or more folders)."""
    import tomllib

    from skinviewer.ground import paths
    cfg = tomllib.loads((paths.shaders_dir().parent / "pyproject.toml").read_text())["tool"]["setuptools"]
    for pkg, folder in (("skinviewer.shaders", paths.shaders_dir()), ("skinviewer.presets", paths.presets_dir())):
        covered = {p for g in cfg["package-data"][pkg] for p in folder.glob(g)}
        for f in folder.rglob("*"):
            if f.is_file() and "__pycache__" not in f.parts:
                assert f in covered, f"{f.relative_to(folder).as_posix()} would be missing from the wheel"


def test_viewer_without_a_display_says_how_to_run_it(tmp_path):
    pytest.importorskip("moderngl_window")  # without the viewer's packages it says that instead (GPU check)
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    p = subprocess.run([sys.executable, "-m", "skinviewer.cli", "--frames", "1", "--screenshot", str(tmp_path / "s.png")],
                       capture_output=True, text=True, timeout=120, env=env)
    assert p.returncode == 2
    assert "xvfb-run" in p.stderr and "Traceback" not in p.stderr


def test_negative_camera_yaw_on_the_command_line(tmp_path):
    from skinviewer.cli import _join_negative_values, build_parser
    argv = _join_negative_values(["render", "--camera", "-75,5", "--out", "x.png"])
    args = build_parser().parse_args(argv)
    assert args.camera == [-75.0, 5.0]


def test_render_writes_linear_exr(tmp_path):
    """`render --exr`: the linear HDR image (before exposure and tone map) for compositing tools."""
    from skinviewer.ground.files import load_exr
    out, exr = tmp_path / "x.png", tmp_path / "x.exr"
    p = subprocess.run([sys.executable, "-m", "skinviewer", "render", "--scene", "laser", "--technique", "phong",
                        "--size", "32x32", "--set", "render.exposure=4", "--out", str(out), "--exr", str(exr)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    a = load_exr(exr)
    assert a.shape == (32, 32, 4) and a.dtype == np.float32 and np.isfinite(a).all()
    assert a[..., 3].max() == 1.0 and 0.0 < a[..., :3].max() < 4.0  # linear: the exposure is not applied
    # `--out` with an .exr name writes that same image as OpenEXR, not PNG bytes under an .exr name
    only = tmp_path / "only.exr"
    p = subprocess.run([sys.executable, "-m", "skinviewer", "render", "--scene", "laser", "--technique", "phong",
                        "--size", "32x32", "--set", "render.exposure=4", "--out", str(only)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert np.array_equal(load_exr(only), a)


@pytest.mark.parametrize("pcf_filter", ["bilinear", "box"])
def test_pcf_filter_bilinear_has_no_shadow_map_terraces(renderer, pcf_filter):
    """shadow.pcf_filter: across the shadow-edge scene's edge, sampled much finer than a shadow-map
    texel (d'Eon's per-texel visibility, 1024^2 over the 60 mm plane, 256^2 shadow map), the box
    PCF takes only the (2 pcf + 2) levels k / (2 pcf + 1) of whole texels (terraces one shadow texel
    wide); the bilinear one slides with the position: many levels, monotonic, the same 0 and 1."""
    s = small_settings("shadow-edge", "deon", 32, **{"shadow.map_size": 256, "shadow.pcf": 1,
                                                     "shadow.pcf_filter": pcf_filter, "deon.irradiance_size": 1024,
                                                     "deon.subpixel_kernel_px": 0.0})
    renderer.render(s)
    vis = renderer.graph("deon").read("deon_visibility")[..., 0].astype(np.float64)
    n = vis.shape[0]
    row = vis[n // 2, int(0.3 * n):int(0.75 * n)]  # across the edge at x = 0, on the plane's island
    assert row.min() < 0.01 and row.max() > 0.99
    levels = np.unique(np.round(row, 4))
    if pcf_filter == "box":
        assert len(levels) <= 4 and np.allclose(levels * 3, np.round(levels * 3), atol=1e-3)
    else:
        assert len(levels) >= 8
    edge = np.nonzero((row > 0.001) & (row < 0.999))[0]
    window = row[max(edge.min() - 8, 0):edge.max() + 9]  # the edge at x = 0 (the blade's far edge is not in it)
    assert edge.max() - edge.min() < 40 and (np.diff(window) >= -1e-3).all()  # one monotonic ramp (half floats)



def _coarse_sphere():
    import trimesh

    from skinviewer.scene.mesh import MeshData, vertex_normals
    sp = trimesh.creation.icosphere(subdivisions=1, radius=15.0)  # 80 facets: smooth normals far from the facets'
    p, idx = np.asarray(sp.vertices, np.float64), np.asarray(sp.faces)
    uv = np.stack([0.5 + np.arctan2(p[:, 2], p[:, 0]) / (2 * np.pi), 0.5 + np.arcsin(p[:, 1] / 15.0) / np.pi], 1)
    return MeshData(p, vertex_normals(p, idx), uv, idx, albedo=np.full((2, 2, 3), 0.8, np.float32), name="coarse")


@pytest.mark.parametrize("technique,resource", [("phong", "lit"), ("ssss", "ss_diffuse")])
def test_front_faces_keep_their_normal_near_the_silhouette(renderer, monkeypatch, technique, resource):
    """Near a silhouette the interpolated normal of a front face can point away from the camera.
    Reversing it there ("two-sided" by N.V) shaded lit skin with the far side's normal: black pixels
    along lit contours (the ear's rim). Only a back face (gl_FrontFacing) reverses it now. On a
    coarse sphere lit from the side, the diffuse per unit N.L is the same where N.V < 0 as elsewhere."""
    from skinviewer.engine.reference import Surface, camera_hits
    from skinviewer.scene import scenes
    sdef = scenes.SceneDef("laser", _coarse_sphere(), {}, "coarse sphere")
    monkeypatch.setattr("skinviewer.engine.renderer.build_scene", lambda name, detail=1: sdef)
    light = [{"kind": "directional", "direction": [1.0, 0.2, -0.3], "intensity": 1.0, "cast_shadow": False}]
    s = small_settings("laser", technique, 160, lights=light, **{"camera.yaw": 0.0, "camera.pitch": 0.0,
                                                                 "phong.specular": 0.0, "phong.ambient": 0.0})
    renderer.render(s)
    img = renderer.read(s, resource)[::-1, :, 0].astype(np.float64)
    mask, tri, bary, eye = camera_hits(Surface(sdef.mesh, 1.0, s), s)
    a = Surface(sdef.mesh, 1.0, s).attributes(tri, bary)
    V = eye[None] - a["P"]
    V /= np.linalg.norm(V, axis=1)[:, None]
    L = np.array(light[0]["direction"]) / np.linalg.norm(light[0]["direction"])
    ndl, ndv = a["N"] @ L, (a["N"] * V).sum(1)
    per_ndl = img[mask] / np.maximum(ndl, 1e-6)
    away = (ndv < -0.02) & (ndl > 0.3)
    inside = (ndv > 0.2) & (ndl > 0.3)
    assert away.sum() >= 20 and inside.sum() >= 200  # the case is there
    assert np.percentile(per_ndl[away], 5) > 0.8 * np.median(per_ndl[inside])


def test_back_faces_culled_on_a_closed_mesh_shown_on_an_open_one(renderer, monkeypatch):
    """scene.back_faces = auto: from inside a closed sphere nothing can be seen (its inside is never
    visible from outside, so a back face the camera meets has won a depth fight with the near side
    or comes from a self-intersection); `show` draws it. An open sheet seen from behind stays visible,
    lit through its reversed normal. The ground truth's camera does the same."""
    from skinviewer.engine.reference import Surface, camera_hits
    from skinviewer.scene import scenes
    sdef = scenes.SceneDef("laser", _coarse_sphere(), {}, "coarse sphere")
    monkeypatch.setattr("skinviewer.engine.renderer.build_scene", lambda name, detail=1: sdef)
    inside = {"camera.distance": 5.0, "camera.target": [0.0, 0.0, 0.0]}
    light = [{"kind": "directional", "direction": [0.0, 0.0, 1.0], "intensity": 1.0, "cast_shadow": False}]
    seen = {}
    for mode in ("auto", "cull", "show"):
        s = small_settings("laser", "phong", 48, lights=light, **inside, **{"scene.back_faces": mode})
        renderer.render(s)
        lit = renderer.read(s, "lit")[::-1]
        seen[mode] = lit[..., 3] > 0.5
        assert (seen[mode] == camera_hits(Surface(sdef.mesh, 1.0, s), s)[0]).mean() > 0.99
        if mode == "show":
            assert lit[seen[mode], 0].max() > 0.3  # the inside, lit through the reversed normal
    assert not seen["auto"].any() and not seen["cull"].any() and seen["show"].all()
    monkeypatch.undo()
    s = small_settings("laser", "phong", 48, **{"camera.yaw": 180.0})  # the open slab from behind
    renderer.render(s)
    assert (renderer.read(s, "lit")[..., 3] > 0.5).mean() > 0.2
