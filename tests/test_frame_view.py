"""Issue 28: one per-frame view of the scene and camera, and a GpuScene that passes cannot write.

* The renderer builds the frame's view (kernel/frame_view.FrameView: the rendered camera, what it
  frames, the screen coverage) once a frame; the passes draw with its camera and the scene rules read
  it in reflect. On a bust (the camera frames the head, not the shoulders) the rules' camera is the
  rendered one -- their own copy once framed the whole bust. No pass module builds a camera
  (``framed_view``, ``orbit_view``, a ``FrameView``): an AST check, with a planted violation it must see.
* What passes and rules keep for a scene's life lives in ``GpuScene.caches`` (and ``texel_table``); no
  pass module sets an attribute of a scene or reaches into its ``__dict__`` (an AST check with a planted
  violation), and a made GpuScene refuses any attribute set at run time."""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from conftest import LPS_GLB
from helpers import small_settings

from skinviewer.ground.settings import with_values
from skinviewer.kernel.execute import ExecuteContext
from skinviewer.kernel.frame_view import FrameView
from skinviewer.kernel.pass_api import Reflection
from skinviewer.passes import rules
from skinviewer.scene.camera import framed_view, orbit_view

PASSES = Path(__file__).resolve().parents[1] / "skinviewer" / "passes"
MODULES = sorted(str(f.relative_to(PASSES)) for f in PASSES.rglob("*.py"))
CAMERA_BUILDERS = {"framed_view", "orbit_view"}  # only the renderer makes the frame's camera (and its FrameView)


# -- no pass module builds a camera -------------------------------------------------------------------

def camera_builds(source: str) -> list[tuple[int, str]]:
    """(line, name) for each use of a camera builder in ``source``: a call, an import or a reference
    (``framed_view(...)``, ``camera.framed_view``, ``from skinviewer.scene.camera import orbit_view``), or
    a FrameView made (``FrameView(...)``; naming the type is allowed)."""
    out = []
    for n in ast.walk(ast.parse(source)):
        if isinstance(n, ast.Call):
            f = n.func
            if (f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)) == "FrameView":
                out.append((n.lineno, "FrameView(...)"))
        if isinstance(n, ast.ImportFrom):
            out += [(n.lineno, a.name) for a in n.names if a.name in CAMERA_BUILDERS]
        elif isinstance(n, ast.Name) and n.id in CAMERA_BUILDERS:
            out.append((n.lineno, n.id))
        elif isinstance(n, ast.Attribute) and n.attr in CAMERA_BUILDERS:
            out.append((n.lineno, n.attr))
    return sorted(set(out))


def test_the_camera_check_sees_a_camera_built_in_a_pass():
    planted = ("from skinviewer.scene.camera import framed_view, gl_bytes\n"
               "import skinviewer.scene.camera as cam\n"
               "def screen(settings, scene):\n"
               "    v = framed_view(settings.camera, scene, (8, 8))\n"
               "    w = cam.orbit_view(settings.camera, scene.center, scene.radius, (8, 8))\n"
               "    f = FrameView(v, scene, 30.0)\n"
               "    return r.view.camera, gl_bytes(v.view)\n"  # the frame's view: allowed
               "def rule(view: FrameView) -> float:\n"  # naming the type: allowed
               "    return view.screen_diameter_px\n")
    assert camera_builds(planted) == [(1, "framed_view"), (4, "framed_view"), (5, "orbit_view"), (6, "FrameView(...)")]


def test_every_pass_module_is_checked():
    assert {"rules.py", "deon.py", "common.py", "screen_space/lighting.py"} <= set(MODULES)


@pytest.mark.parametrize("module", MODULES)
def test_no_pass_module_builds_a_camera(module):
    found = camera_builds((PASSES / module).read_text())
    assert not found, (f"{module}: read the frame's view (r.view, ec.view) instead of building a camera "
                       f"from settings: {found}")


# -- no pass module writes into a scene ---------------------------------------------------------------

def _is_scene(node: ast.AST) -> bool:
    """``scene``, ``ec.scene``, ``r.scene``, ``self.scene``, ``frame.scene``...: a GpuScene by name."""
    return (isinstance(node, ast.Name) and node.id in ("scene", "sc", "gpu")) or \
        (isinstance(node, ast.Attribute) and node.attr in ("scene", "gpu"))


def scene_writes(source: str) -> list[tuple[int, str]]:
    """(line, what) for each write into a scene object in ``source``: an attribute assigned, augmented
    or deleted (``ec.scene.env_rays = 12``), ``setattr``/``delattr``/``vars`` on it, or its ``__dict__``."""
    out = []
    for n in ast.walk(ast.parse(source)):
        targets: list[ast.AST] = []
        if isinstance(n, ast.Assign):
            targets = list(n.targets)
        elif isinstance(n, (ast.AugAssign, ast.AnnAssign)):
            targets = [n.target]
        elif isinstance(n, ast.Delete):
            targets = list(n.targets)
        for t in targets:
            for e in (t.elts if isinstance(t, ast.Tuple) else [t]):
                if isinstance(e, ast.Attribute) and _is_scene(e.value):
                    out.append((n.lineno, f"sets .{e.attr}"))
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in ("setattr", "delattr", "vars") \
                and n.args and _is_scene(n.args[0]):
            out.append((n.lineno, f"{n.func.id}(scene)"))
        if isinstance(n, ast.Attribute) and n.attr == "__dict__" and _is_scene(n.value):
            out.append((n.lineno, "__dict__"))
    return sorted(set(out))


def test_the_scene_check_sees_a_pass_writing_into_the_scene():
    planted = ("def execute(self, ec):\n"
               "    ec.scene.env_rays = 12\n"
               "    cache = ec.scene.__dict__.setdefault('_tables', {})\n"
               "    r.scene.memo += 1\n"
               "    setattr(scene, 'x', 1)\n"
               "    ec.scene.caches.rules['ray'] = 1\n"  # its cache's table: allowed
               "    ec.plan_size = ec.scene.radius\n")  # reading the scene: allowed
    assert scene_writes(planted) == [(2, "sets .env_rays"), (3, "__dict__"), (4, "sets .memo"), (5, "setattr(scene)")]


@pytest.mark.parametrize("module", MODULES)
def test_no_pass_module_writes_into_the_scene(module):
    found = scene_writes((PASSES / module).read_text())
    assert not found, f"{module}: keep what a pass computes in GpuScene.caches, not on the scene: {found}"


def test_a_made_scene_refuses_an_attribute_and_keeps_the_passes_tables(renderer):
    """The runtime side: setting an attribute of a made GpuScene raises (the environment's ray count used
    to be set on it by a pass); the texture-space tables and the rules' rays live in its caches."""
    s = small_settings("backlit-ear", "deon", 48)
    renderer.render(s)
    gpu = renderer.scene.gpu
    with pytest.raises(AttributeError, match="immutable"):
        gpu.env_rays = 12
    with pytest.raises(AttributeError, match="immutable"):
        gpu.mean_uv_per_mm = 1.0
    assert any(k[0] == "gutter" for k in gpu.caches.texel_tables)
    assert "ray" in gpu.caches.rules  # the TSM rule's Embree scene (the ear is lit from behind)
    made = dict(gpu.caches.texel_tables)
    renderer.render(s, force=True)  # a forced re-run only uploads the tables it made
    assert all(gpu.caches.texel_tables[k] is v for k, v in made.items())


# -- the rules read the rendered camera on a bust ------------------------------------------------------

def _bust_scene():
    """A built-in bust: a head (sphere, r = 100 mm) on a neck and shoulders, so MeshData.frame (the
    head) is much smaller than the bounding sphere, as for the scan."""
    import trimesh

    from skinviewer.scene import scenes
    from skinviewer.scene.mesh import MeshData, vertex_normals
    head = trimesh.creation.icosphere(subdivisions=3, radius=100.0)
    neck = trimesh.creation.cylinder(radius=50.0, height=120.0, sections=24)
    neck.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    neck.apply_translation([0, -140.0, 0])
    shoulders = trimesh.creation.box(extents=[400.0, 150.0, 200.0])
    shoulders.apply_translation([0, -260.0, 0])
    shoulders = shoulders.subdivide().subdivide()
    mesh = trimesh.util.concatenate([head, neck, shoulders])
    p, idx = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces)
    r = np.linalg.norm(p, axis=1)
    uv = np.stack([0.5 + np.arctan2(p[:, 2], p[:, 0]) / (2 * np.pi), 0.5 + np.arcsin(np.clip(p[:, 1] / r, -1, 1)) / np.pi], 1)
    data = MeshData(p, vertex_normals(p, idx), uv, idx, albedo=np.full((2, 2, 3), 0.8, np.float32), name="bust")
    return scenes.SceneDef("head", data, {}, "built-in bust")


@pytest.mark.parametrize("which", ["built-in bust", "scan"])
def test_the_rules_read_the_rendered_camera_on_a_bust(renderer, monkeypatch, which):
    """Every scene rule of a d'Eon frame (the map sizes from coverage, the mesh LOD, the kernel under a
    pixel, the TSM 'in view') reads the frame's view the renderer built, whose camera is the one every
    view-dependent pass draws with; on a bust that camera frames the head (not the whole bust, the
    camera the rules once built themselves) and the coverage they measure is the head's on screen."""
    if which == "scan":
        if not LPS_GLB.is_file():
            pytest.skip(f"needs the shared Lee Perry-Smith scan at {LPS_GLB}")
        scene = {"scene.mesh": str(LPS_GLB), "scene.mm_per_unit": 48.0}
    else:
        sdef = _bust_scene()
        monkeypatch.setattr("skinviewer.engine.renderer.build_scene", lambda name, detail=1: sdef)
        scene = {"scene.mm_per_unit": 1.0}
    s = with_values(small_settings("head", "deon", 64), {
        **scene, "camera.yaw": 30.0, "deon.irradiance_size_mode": "auto", "shadow.map_size_mode": "auto",
        "render.mesh_lod": "auto", "deon.tsm_auto": True, "deon.subpixel_kernel_px": 0.01})
    seen_by_rules: list[object] = []
    drawn_with: list[object] = []
    real_view, real_ec_view = Reflection.view, ExecuteContext.view
    monkeypatch.setattr(Reflection, "view", property(lambda r: seen_by_rules.append(real_view.fget(r)) or seen_by_rules[-1]))
    monkeypatch.setattr(ExecuteContext, "view", property(lambda ec: drawn_with.append(real_ec_view.fget(ec)) or drawn_with[-1]))
    lod_views: list[object] = []
    real_lod = rules.mesh_lod
    monkeypatch.setattr(rules, "mesh_lod", lambda st, v, state: lod_views.append(v) or real_lod(st, v, state))
    tsm_frames: list[object] = []
    real_tsm = rules._tsm_needed
    monkeypatch.setattr(rules, "_tsm_needed", lambda *a: tsm_frames.append(a[-1]) or real_tsm(*a))

    report = renderer.render(s)
    fv = renderer.last_frame_view
    assert isinstance(fv, FrameView) and report.complete
    gpu = renderer.scene.gpu
    # the rules (map sizes, kernel under a pixel, the TSM rule, the LOD) and the passes saw this one frame view
    # (a memoised rule through the wrapper that records what it reads of it: Reflection.memo)
    def the(v):
        return getattr(v, "_view", v)
    assert seen_by_rules and all(the(v) is fv for v in seen_by_rules)
    assert lod_views == [fv] and tsm_frames and all(the(f) is fv for f in tsm_frames)
    assert drawn_with and all(v is fv.camera for v in drawn_with) and renderer.last_view is fv.camera
    # ... whose camera frames the head of the bust: the portrait framing, not the whole bust's sphere
    fc, fr = gpu.frame
    assert fr < 0.6 * gpu.radius
    size = (s.render.width, s.render.height)
    assert np.array_equal(fv.camera.view_proj, framed_view(s.camera, gpu, size).view_proj)
    whole = orbit_view(s.camera, gpu.center, gpu.radius, size)  # the rules' camera before the fix
    assert not np.allclose(fv.camera.view_proj, whole.view_proj)
    # the coverage the rules measure is the head's on screen through the rendered projection: project the
    # framed sphere's rim, seen from the eye, with the drawn view_proj
    eye = fv.camera.eye
    d = np.linalg.norm(eye - fc)
    half = np.arcsin(fr / d)
    fwd = (fc - eye) / d
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    rim = [eye + d * np.cos(half) * (np.cos(half) * fwd + sgn * np.sin(half) * up) for sgn in (1.0, -1.0)]
    ndc_y = [(fv.camera.view_proj @ np.append(p, 1.0)) for p in rim]
    diameter = abs(ndc_y[0][1] / ndc_y[0][3] - ndc_y[1][1] / ndc_y[1][3]) / 2.0 * s.render.height
    assert fv.screen_diameter_px == pytest.approx(diameter, rel=0.02)
    # the rules' own words quote the frame view's coverage (the auto map sizes)
    assert f"from screen coverage (head {fv.screen_diameter_px:.0f} px)" in " ".join(p.reason for p in report.passes)
