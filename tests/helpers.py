"""Reusable test helpers: small settings for a scene, and the all-textures-finite check every
technique's hard-case tests call."""
from __future__ import annotations

import numpy as np

from skinviewer.ground.settings import Settings, three_light_rig, with_values
from skinviewer.scene.scenes import scene_overrides


def small_settings(scene: str = "head", technique: str = "phong", size: int = 96, **assign) -> Settings:
    """Settings for a quick render: a built-in scene with its own lights/camera, small maps. A scene
    without lights of its own (the head) gets the three-light rig these tests were written for (the
    default rig's environment is tested in test_env_default.py and test_environment.py)."""
    values = {"scene.name": scene, "lights": [light.model_dump() for light in three_light_rig()],
              **scene_overrides(scene), "technique": technique,
              "render.width": size, "render.height": size, "scene.head_detail": 0,
              "shadow.map_size": 256, "gosselin.light_map_size": 256, "deon.irradiance_size": 256,
              "deon.tsm_size": 256}
    values.update(assign)
    return with_values(Settings(), values)


def flat_grid(n: int = 12, half: float = 10.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A flat n x n vertex grid in z = 0 over [-half, half]^2 (x fastest), normals +z, two
    counter-clockwise triangles per cell: positions, normals, triangle indices."""
    xs = np.linspace(-half, half, n)
    x, y = np.meshgrid(xs, xs)
    P = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], 1)
    idx = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            idx += [(a, a + 1, a + n + 1), (a, a + n + 1, a + n)]
    return P, np.tile([0.0, 0.0, 1.0], (n * n, 1)), np.array(idx)


def first_gathered_step(renderer, s: Settings, n: int):
    """Render ``s`` (d'Eon, irradiance maps of ``n``^2) and return its graph, the mean texel (mm) and
    the first blur step that is not reused: it must be summed over the surface straight from the
    irradiance (deon.surface_gather_below_texels), which the callers check against numpy."""
    from skinviewer.passes.deon import mean_texel_mm
    from skinviewer.physics.diffusion import IRRADIANCE, blur_plan_texels
    renderer.render(s)
    g = renderer.graph("deon")
    texel = mean_texel_mm(renderer.scene.gpu, n)
    plan = blur_plan_texels([x.variance for x in s.deon.gaussians], s.deon.reuse_irradiance_below_texels, texel,
                            s.deon.fold_below_texels)
    step = next(st for st in plan if not st.reused)
    assert step.source == IRRADIANCE and np.sqrt(step.increment) <= s.deon.surface_gather_below_texels * texel
    return g, texel, step


def assert_all_finite(renderer, settings: Settings, report=None) -> dict[str, np.ndarray]:
    """Render (unless a report is given) and check every texture the graph holds is finite.
    Returns the textures by name for further checks."""
    if report is None:
        report = renderer.render(settings)
    g = renderer.graph(settings.technique)
    out = {}
    bad = []
    for name in g.resources():
        arr = g.read(name)
        if not np.all(np.isfinite(arr)):
            n = int((~np.isfinite(arr)).sum())
            bad.append(f"{name}: {n} non-finite values")
        out[name] = arr
    assert not bad, "non-finite texels: " + "; ".join(bad)
    return out


def settings_fields():
    """(dotted path, field name, FieldInfo) of every editable settings field the panel draws: every
    section of the model (new techniques' included) and the first light."""
    from pydantic import BaseModel

    from skinviewer.ground.settings import Settings
    from skinviewer.ui.widgets import classify
    out = []

    def walk(model, prefix):
        for name, f in type(model).model_fields.items():
            kind, _, _ = classify(f)
            if kind == "model":
                walk(getattr(model, name), f"{prefix}{name}.")
            elif kind != "other":
                out.append((f"{prefix}{name}", name, f))
    s = Settings()
    for sec, value in s:
        if isinstance(value, BaseModel):
            walk(value, sec + ".")
    walk(s.lights[0], "lights.0.")
    return out


def backlit_flap_column(renderer, s: Settings):
    """Render ``s`` (the backlit-ear scene, a screen-space technique) and read the lighting pass's
    diffuse down the image's centre column over the flap: (row indices, flap thickness in mm there,
    diffuse RGB there). The flap is 1.5 mm thick at y = 20 mm and 6 mm at y = -20 mm."""
    from skinviewer.passes.screen_space import DEPTH, DIFFUSE, focal_px
    renderer.render(s)
    E = renderer.read(s, DIFFUSE)
    dep = renderer.read(s, DEPTH)
    h = s.render.height
    f = focal_px(s.camera.fov_y, h)
    col = h // 2
    rows = [r for r in range(h) if dep[r, col, 3] > 0.5]
    ys = np.array([(r + 0.5 - h / 2) * dep[r, col, 0] / f for r in rows])  # world y (mm) at the centre column
    keep = np.abs(ys) < 17.0
    rows = np.array(rows)[keep]
    return rows, 1.5 + (20.0 - ys[keep]) / 40.0 * 4.5, E[rows, col, :3]


def backlit_ear_deviation(renderer, n: int = 160) -> dict[float, np.ndarray]:
    """backlit-ear lit from behind, d'Eon at 512^2 maps: at the front points 2, 3 and 4 mm thick, the final
    image / C^(1-mix) sum_i w_i exp(-m^2/2v_i) blur_i(uv_A) - 1 per channel (seed 000 eq. 33; m the path
    through the flap along the light, A where that ray enters the back). Shared by test_fidelity.py and
    benchmarks/claims.py."""
    from skinviewer.passes.deon import mean_texel_mm
    from skinviewer.physics.color import srgb_to_linear
    from skinviewer.physics.diffusion import blur_plan_texels, texture_of
    from skinviewer.scene.camera import orbit_view
    from skinviewer.scene.scenes import _flap_thickness
    s = small_settings("backlit-ear", "deon", n, **{"deon.irradiance_size": 512, "deon.tsm_size": 512,
                                                   "deon.energy_conservation": False})
    renderer.render(s)
    g = renderer.graph("deon")
    lit = renderer.read(s, "lit")[..., :3].astype(np.float64)
    scene = renderer.scene.gpu
    view = orbit_view(s.camera, scene.center, scene.radius, (n, n))
    L = np.array(s.lights[0].direction, np.float64)
    L /= np.linalg.norm(L)
    plan = blur_plan_texels([x.variance for x in s.deon.gaussians], s.deon.reuse_irradiance_below_texels,
                            mean_texel_mm(scene, 512))
    blurs = [g.read(texture_of(p))[..., :3].astype(np.float64) for p in plan]
    albedo = srgb_to_linear(np.array([0.85, 0.62, 0.55]))  # the scene's sRGB albedo, linear in the shaders
    out = {}
    for d in (2.0, 3.0, 4.0):
        y = 20.0 - (d - 1.5) * 40.0 / 4.5
        C = np.array([0.0, y, 0.5 * _flap_thickness(np.array(y))])
        # walk towards the light to the back surface z = -t(y)/2
        ts = np.linspace(0.0, 3 * d, 30001)
        P = C[None, :] + ts[:, None] * L[None, :]
        k = int(np.argmax(P[:, 2] <= -0.5 * _flap_thickness(P[:, 1])))
        A, m = P[k], ts[k]
        s_a, t_a = (A[0] + 15.0) / 30.0, (A[1] + 20.0) / 40.0
        uvA = np.array([0.52 + 0.46 * (1.0 - s_a), 0.02 + 0.96 * t_a])
        ij = (uvA[::-1] * 512).astype(int)
        expect = sum(np.asarray(x.weights) * np.exp(-m * m / (2 * x.variance)) * b[ij[0], ij[1]]
                     for x, b in zip(s.deon.gaussians, blurs)) * albedo ** (1 - s.deon.mix)
        c = view.view_proj @ np.append(C, 1.0)
        ndc = c[:3] / c[3]
        row, col = int((ndc[1] + 1) / 2 * n), int((ndc[0] + 1) / 2 * n)  # row 0 at the bottom
        with np.errstate(divide="ignore", invalid="ignore"):
            out[d] = lit[row, col] / expect - 1.0
    return out


def quad_gltf(uv: np.ndarray, uri: str | None = None) -> tuple[dict, bytes]:
    """The buffer part of a glTF of one unit quad (positions, ``uv`` as TEXCOORD_0, six indices): the
    dict's buffers, bufferViews and accessors 0/1/2, and the buffer's bytes — embedded as a data URI
    unless ``uri`` names the external .bin the caller writes."""
    import base64
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint32)
    buf = P.tobytes() + np.asarray(uv, np.float32).tobytes() + idx.tobytes()
    d = {"asset": {"version": "2.0"},
         "buffers": [{"byteLength": len(buf),
                      "uri": uri or "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
         "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                         {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                         {"buffer": 0, "byteOffset": 80, "byteLength": 24}],
         "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                        "min": [0, 0, 0], "max": [1, 1, 0]},
                       {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                       {"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}]}
    return d, buf


# a full-screen triangle (gl_VertexID 0..2) with v_uv: the graph tests' vertex stage
FS_VERT = """#version 330 core
out vec2 v_uv;
void main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2); v_uv = p; gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }
"""


def graph_test_shaders(folder):
    """The graph tests' shaders in ``folder``: fill (f = u_value) and add (texture a + texture b)."""
    (folder / "fill.vert").write_text(FS_VERT)
    (folder / "fill.frag").write_text("#version 330 core\nuniform float u_value;\nout vec4 f;\n"
                                      "void main() { f = vec4(u_value); }\n")
    (folder / "add.vert").write_text(FS_VERT)
    (folder / "add.frag").write_text("#version 330 core\nin vec2 v_uv;\nuniform sampler2D a;\nuniform sampler2D b;\n"
                                     "out vec4 f;\nvoid main() { f = texture(a, v_uv) + texture(b, v_uv); }\n")
    return folder


def viewer_app(tmp_path_factory, scene: str, size: tuple[int, int], **assign):
    """A viewer (ui.app) for a module's tests, as a generator for a module fixture: the scene's own
    lights and camera with 256² maps, its own empty cache folder (no calibration), no frame budget,
    two frames drawn. Skips without a display, imgui or a window."""
    import os

    import pytest
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY and no Xvfb")
    pytest.importorskip("imgui_bundle")
    from skinviewer.ui.app import WindowUnavailableError, create_app, destroy_app
    old = os.environ.get("SKINVIEWER_CACHE")
    os.environ["SKINVIEWER_CACHE"] = str(tmp_path_factory.mktemp("cache"))  # no calibration here
    s = with_values(Settings(), {"scene.name": scene, **scene_overrides(scene), "technique": "deon",
                                 "shadow.map_size": 256, "deon.irradiance_size": 256, "deon.tsm_size": 256,
                                 **assign})
    try:
        try:
            a = create_app(s, size=size, vsync=False)
        except WindowUnavailableError as exc:  # no window at all (display or GL driver); a start-up bug fails
            pytest.skip(f"cannot open a window: {exc}")
        a.frame.set_frame_budget(None)
        a.step(2)
        yield a
        destroy_app(a)
    finally:
        if old is None:
            os.environ.pop("SKINVIEWER_CACHE", None)
        else:
            os.environ["SKINVIEWER_CACHE"] = old


def splash_app(size: tuple[int, int]):
    """The viewer as it starts (its start-up screen in the view): d'Eon on the shadow-edge scene at a
    64² render. Skips without a display, imgui or a window; the caller destroys it (destroy_app)."""
    import os

    import pytest
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY")
    pytest.importorskip("imgui_bundle")
    from skinviewer.ui.app import WindowUnavailableError, create_app
    s = with_values(small_settings("shadow-edge", "deon", size=64), {**scene_overrides("shadow-edge")})
    try:
        return create_app(s, size=size, vsync=False, splash=True)
    except WindowUnavailableError as exc:
        pytest.skip(f"cannot open a window: {exc}")


def edge_viewer():
    """A viewer of its own for a module fixture (``yield from edge_viewer()``): d'Eon on the shadow-edge
    scene at 420 x 300 with 256² shadow/TSM and 512² irradiance maps, the panel hidden, two frames drawn.
    Its own GL context and shader library. Skips without a display, imgui or a window."""
    import os

    import pytest
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY and no Xvfb")
    pytest.importorskip("imgui_bundle")
    from skinviewer.ui.app import create_app, destroy_app
    s = with_values(Settings(), {"scene.name": "shadow-edge", **scene_overrides("shadow-edge"), "technique": "deon",
                                 "shadow.map_size": 256, "deon.irradiance_size": 512, "deon.tsm_size": 256})
    try:
        a = create_app(s, size=(420, 300), vsync=False)
    except RuntimeError as exc:
        pytest.skip(f"cannot open a window: {exc}")
    a.state.set_show_ui(False)
    a.step(2)
    yield a
    destroy_app(a)
