"""Issue 27: d'Eon's separable blur directions and their seam fills as compute passes (render.compute_blur,
shaders/deon_blur_cs.comp and seam_fill_cs.comp around the fragment programs' own bodies, ExecuteContext.dispatch).
llvmpipe's GL 4.5 has compute shaders, so `on` runs them here: every blur texture, the diffuse sum and the image
must equal the fragment path's bit for bit above llvmpipe's run-to-run subnormal noise (values under 1e-30
flushed, as tests/test_tiles.py; measured: max |difference| 0, or 1.5e-38 in a texel of the diffuse sum). `auto` keeps the
fragment draws on a software rasterizer and dispatches on a GL >= 4.3 GPU; `on` without compute says so and draws."""
from __future__ import annotations

import numpy as np
import pytest

import skinviewer.passes.deon as deon_passes
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.gl import compute_policy
from skinviewer.physics.diffusion import blur_resource, stretch_blur_resource
from skinviewer.scene.scenes import scene_overrides
from tests.helpers import small_settings
from tests.test_tiles import same

CASES = {
    # island tiles, zone_split and seam_split (both program variants per draw), every step full size
    "tiles-full-size": ("head", {"deon.irradiance_size": 256, "deon.half_res_above_texels": 0.0}),
    # wide steps on a half-size map: the DOWN fill of the full-size input
    "half-size": ("head", {"deon.irradiance_size": 512, "deon.half_res_above_texels": 2.0}),
    # no tiles: whole-target dispatches
    "no-tiles": ("head", {"deon.irradiance_size": 256, "deon.skip_gutters": False}),
    # the stretch chain (RG32F: rg32f images) beside the light's
    "stretch-chain": ("head", {"deon.irradiance_size": 256, "deon.stretch_per_gaussian": True,
                               "deon.fold_below_texels": 0.0}),
}


def _settings(scene: str, mode: str, extra: dict) -> Settings:
    return small_settings(scene, "deon", 48, **{"deon.surface_gather_below_texels": 0.0, **extra,
                                                "render.compute_blur": mode})


def _slab(mode: str) -> Settings:
    """The laser slab: an open mesh border (the OPEN_BORDER variants of both programs)."""
    return with_values(Settings(), {"scene.name": "laser", **scene_overrides("laser"), "technique": "deon",
                                    "render.width": 48, "render.height": 48, "deon.irradiance_size": 256,
                                    "deon.tsm": False, "deon.surface_gather_below_texels": 0.0,
                                    "deon.open_border": "reflect", "render.compute_blur": mode,
                                    "lights": [{"kind": "directional", "direction": [0, 0, 1], "intensity": 1.0,
                                                "cast_shadow": False}]})


def _render(renderer, s: Settings) -> tuple[dict[str, np.ndarray], list]:
    """Every separable blur's output (and stretch blur's), the diffuse sum and the image; the blur passes."""
    rep = renderer.render(s, force=True)
    sep = [p for p in rep.passes if p.name.startswith(("deon_blur_", "deon_stretch_blur_")) and p.status == "ran"
           and "directions" in p.figures]
    names = ["lit", "image", "deon_diffuse"]
    for p in sep:
        i = int(p.name.rsplit("_", 1)[1])
        names.append(stretch_blur_resource(i) if "stretch" in p.name else blur_resource(i))
    return {k: renderer.read(s, k) for k in names}, sep


def _agree(renderer, a: np.ndarray, b: np.ndarray) -> bool:
    """Bit for bit (subnormal noise aside) on llvmpipe, where both paths run the same JIT; elsewhere within
    float rounding (a GPU's compiler may contract a stage's arithmetic differently): 1e-5 relative."""
    if "llvmpipe" in str(renderer.ctx.info.get("GL_RENDERER", "")):
        return same(a, b)
    return bool(np.allclose(a, b, rtol=1e-5, atol=1e-6 * max(float(np.abs(b).max()), 1e-30)))


def _same(renderer, on: Settings, off: Settings) -> list:
    a, sep_on = _render(renderer, on)
    b, sep_off = _render(renderer, off)
    assert sep_on and all(p.figures["compute"] for p in sep_on), [(p.name, p.note) for p in sep_on]
    assert not any(p.figures["compute"] for p in sep_off)
    assert all("compute dispatches" in p.note for p in sep_on)
    assert a.keys() == b.keys()
    for k in a:
        diff = float(np.abs(a[k].astype(np.float64) - b[k]).max())
        assert _agree(renderer, a[k], b[k]), (k, diff)
    return sep_on


@pytest.mark.parametrize("case", list(CASES))
def test_compute_blurs_equal_the_fragment_draws_bit_for_bit(renderer, case):
    scene, extra = CASES[case]
    sep = _same(renderer, _settings(scene, "on", extra), _settings(scene, "off", extra))
    if case == "stretch-chain":
        assert any("stretch" in p.name for p in sep)


def test_compute_tiles_in_several_rows_cover_the_same_texels(renderer, monkeypatch):
    """compute_tiles lays the origins out row by row (a 4096^2 map has more tiles than a texture is wide):
    with 7 a row (the last row padded) the dispatch writes the same texels."""
    import skinviewer.passes.texture_space as ts
    monkeypatch.setattr(ts, "COMPUTE_TILE_COLS", 7)
    scene, extra = CASES["tiles-full-size"]
    _same(renderer, _settings(scene, "on", extra), _settings(scene, "off", extra))
    objs = renderer.graph("deon").shape_state["gl_objects"]
    lists = [v for k, v in objs.items() if k[0] == "compute_tiles" and k[-1] == 7]
    assert lists and all(v[0].width == 7 and v[0].height == -(-v[1] // 7) for v in lists)
    assert any(v[1] % 7 for v in lists)  # a padded last row


def test_compute_blurs_over_an_open_border_equal_the_fragment_draws(renderer):
    _same(renderer, _slab("on"), _slab("off"))


def test_compute_blurs_in_bands_equal_the_whole_fragment_pass(renderer):
    """Under the viewer's frame budget each dispatch runs in row bands (its clip rectangle, as the draws'
    scissor), complete before the next starts: the result is the whole fragment pass's."""
    off = _settings("head", "off", CASES["tiles-full-size"][1])
    renderer.render(off, force=True)
    want = renderer.read(off, "blur_5").copy()
    on = with_values(off, {"render.compute_blur": "on"})
    banded = False
    for _ in range(4000):
        rep = renderer.render(on, budget_ms=1e-6)
        banded |= any(p.name == "deon_blur_5" and "band" in p.reason for p in rep.passes)
        if rep.complete:
            break
    assert rep.complete and banded
    assert _agree(renderer, renderer.read(on, "blur_5"), want)


def test_auto_picks_fragment_on_llvmpipe_and_compute_on_a_gpu():
    """The policy by context (no GPU needed): auto dispatches on a GL >= 4.3 hardware renderer only."""
    assert compute_policy("auto", 450, "llvmpipe (LLVM 15.0.6, 256 bits)") == (False, "")
    assert compute_policy("auto", 450, "softpipe") == (False, "")
    assert compute_policy("auto", 460, "NVIDIA H200/PCIe/SSE2") == (True, "")
    assert compute_policy("auto", 330, "NVIDIA H200/PCIe/SSE2") == (False, "")  # a 3.3 context: no compute
    assert compute_policy("on", 450, "llvmpipe (LLVM 15.0.6, 256 bits)") == (True, "")
    assert compute_policy("off", 460, "NVIDIA H200/PCIe/SSE2") == (False, "")
    use, why = compute_policy("on", 330, "NVIDIA H200/PCIe/SSE2")
    assert not use and "4.3" in why and "fragment" in why


def test_auto_keeps_the_fragment_draws_here(renderer, gl_ctx):
    if "llvmpipe" not in gl_ctx.info.get("GL_RENDERER", ""):
        pytest.skip("a hardware renderer: auto dispatches there")
    _, sep = _render(renderer, _settings("head", "auto", CASES["tiles-full-size"][1]))
    assert sep and not any(p.figures["compute"] for p in sep)


def test_on_without_compute_says_so_and_draws(renderer, monkeypatch):
    """A context without compute shaders (a 3.3 one, as NVIDIA's EGL gives when asked 3.3): `on` puts one
    line in the blur passes' frame-report entries and renders the fragment path's image."""
    extra = CASES["tiles-full-size"][1]
    want, _ = _render(renderer, _settings("head", "off", extra))
    monkeypatch.setattr(deon_passes, "compute_choice",
                        lambda mode, ctx: compute_policy(mode, 330, str(ctx.info.get("GL_RENDERER", ""))))
    got, sep = _render(renderer, _settings("head", "on", extra))
    assert sep and not any(p.figures["compute"] for p in sep)
    assert all("no compute shaders" in p.reason and "fragment draws" in p.reason for p in sep), [p.reason for p in sep]
    assert same(got["image"], want["image"])


def test_compute_twins_that_do_not_compile_fall_back_to_the_draws(renderer, monkeypatch):
    """A driver whose compiler refuses the compute twins (here: an image format that does not exist): the
    blur passes draw with the fragment programs reflect also declared, say so, and the image is theirs."""
    extra = CASES["tiles-full-size"][1]
    want, _ = _render(renderer, _settings("head", "off", extra))
    real = deon_passes.blur_variant

    def broken(compute, spec, name, defines):
        n, d = real(compute, spec, name, defines)
        return (n, {**d, "IMAGE_FORMAT": "no_such_format"}) if compute else (n, d)
    monkeypatch.setattr(deon_passes, "blur_variant", broken)
    got, sep = _render(renderer, _settings("head", "on", extra))
    assert sep and not any(p.figures["compute"] for p in sep)
    assert all("compute blur did not compile" in p.note and "fragment draws" in p.note for p in sep), [p.note for p in sep]
    assert same(got["image"], want["image"])


def test_a_dispatch_refuses_a_target_of_another_image_format(renderer, gl_ctx):
    """ExecuteContext.dispatch checks the program's IMAGE_FORMAT against the texture it stores into."""
    from skinviewer.kernel.execute import ExecuteContext
    from skinviewer.kernel.pass_api import GraphError, Pass, Reflection, TexSpec
    from skinviewer.kernel.report import FrameInputs

    s = small_settings("head", "phong", 48)
    renderer.render(s)
    g = renderer.graph("phong")
    p = Pass()
    p.name = "probe"
    r = Reflection(s)
    r.program("seam_fill_cs", CS_TILE=16, IMAGE_FORMAT="rgba32f")
    ec = ExecuteContext(g, p, r, FrameInputs(s, None, 0, None, ""))
    tex = ec.scratch(TexSpec((32, 32), 2, "f4"))
    with pytest.raises(GraphError, match="IMAGE_FORMAT rg32f"):
        ec.dispatch(ec.program("seam_fill_cs"), tex)
    ec._finish()


def test_a_headless_context_asks_4_3_first_and_says_its_fallback(monkeypatch):
    """NVIDIA's EGL gives exactly the version asked: 4.3 is asked first (compute shaders); a driver that
    refuses it gets a 3.3 context, and describe() says so (no real context made here)."""
    import moderngl

    from skinviewer.kernel import gl

    asked = []

    class Ctx:
        version_code = 330
        info = {"GL_RENDERER": "some GPU", "GL_VERSION": "3.3.0"}

        def release(self):
            pass

    def create(require=330, **kw):
        asked.append(require)
        if require >= 430:
            raise Exception("no 4.3 context")
        return Ctx()

    monkeypatch.setattr(moderngl, "create_standalone_context", create)
    ctx = gl.headless_context()
    assert asked == [430, 330]
    assert "OpenGL 4.3 unavailable, running 3.3: no compute shaders" in gl.describe(ctx)
    assert gl.compute_choice("on", ctx)[0] is False and gl.compute_choice("auto", ctx)[0] is False


def test_the_viewer_window_asks_4_3_first_and_says_its_fallback(monkeypatch, capsys):
    """ui/startup.create_window asks each window library for OpenGL 4.3, then 3.3; a 3.3 window is said on
    stderr and in kernel.gl.describe (fake window classes: no display needed)."""
    mglw = pytest.importorskip("moderngl_window")  # the viewer's window library (not on a headless GPU box)

    from skinviewer.kernel import gl
    from skinviewer.ui import startup

    asked = []

    class Ctx:
        info = {"GL_RENDERER": "some GPU", "GL_VERSION": "3.3.0"}

    class Window:
        def __init__(self, gl_version=(3, 3), **kw):
            asked.append(gl_version)
            if gl_version >= (4, 3):
                raise RuntimeError("GLFW: requested OpenGL version 4.3, got 3.3")
            self.ctx = Ctx()

    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(mglw, "get_local_window_cls", lambda name: Window)
    monkeypatch.setattr(mglw, "activate_context", lambda window=None, ctx=None: None)
    monkeypatch.setattr(startup, "RETRY_PAUSE_S", 0.0)
    wnd = startup.create_window((64, 64), visible=False)
    assert asked == [(4, 3), (4, 3), (3, 3)]  # 4.3 asked twice (a transient glfw init failure), then 3.3
    assert "running 3.3: no compute shaders" in gl.describe(wnd.ctx)
    assert "OpenGL 4.3 unavailable twice" in capsys.readouterr().err


def test_the_viewer_window_retries_4_3_once_after_a_transient_failure(monkeypatch, capsys):
    """Under Xvfb glfw's init failed once ("Failed to initialize glfw") and the window ran 3.3, losing the compute
    blurs on a GPU: a window library that fails 4.3 once is asked 4.3 again and its window is 4.3; the GL line
    (describe) and stderr say it took a second try. One that opens 4.3 at once says nothing."""
    mglw = pytest.importorskip("moderngl_window")

    from skinviewer.kernel import gl
    from skinviewer.ui import startup

    asked, fails = [], [1]

    class Ctx:
        info = {"GL_RENDERER": "some GPU", "GL_VERSION": "4.3.0"}

    class Window:
        def __init__(self, gl_version=(3, 3), **kw):
            asked.append(gl_version)
            if fails[0]:
                fails[0] -= 1
                raise ValueError("Failed to initialize glfw")
            self.ctx = Ctx()
            self.version = gl_version

    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(mglw, "get_local_window_cls", lambda name: Window)
    monkeypatch.setattr(mglw, "activate_context", lambda window=None, ctx=None: None)
    monkeypatch.setattr(startup, "RETRY_PAUSE_S", 0.0)
    wnd = startup.create_window((64, 64), visible=False)
    assert asked == [(4, 3), (4, 3)] and wnd.version == (4, 3)
    line = gl.describe(wnd.ctx)
    assert "OpenGL 4.3 on the second try" in line and "Failed to initialize glfw" in line and "3.3" not in line
    assert "OpenGL 4.3 on the second try" in capsys.readouterr().err
    asked.clear()
    again = startup.create_window((64, 64), visible=False)  # no failure: one ask, nothing said (wnd kept: ids differ)
    assert asked == [(4, 3)] and again.ctx is not wnd.ctx and gl.describe(again.ctx) == "some GPU / OpenGL 4.3.0"
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("timing", ["sync", "gpu"])
def test_a_dispatching_pass_is_timed_and_checked_like_a_drawing_one(renderer, timing):
    """The graph times a pass that dispatches (glFinish or a timer query around it) and scans its outputs
    for NaN/Inf after it (render.check_finite) as it does a pass that draws."""
    s = with_values(_settings("head", "on", CASES["tiles-full-size"][1]),
                    {"render.timing": timing, "render.check_finite": True})
    rep = renderer.render(s, force=True)
    sep = [p for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran" and "directions" in p.figures]
    assert sep and all(p.figures["compute"] for p in sep)
    assert all(p.ms is not None and p.ms > 0.0 and p.nonfinite == [] for p in sep), [(p.ms, p.nonfinite) for p in sep]


@pytest.mark.skipif(__import__("shutil").which("glslangValidator") is None, reason="glslangValidator not installed")
def test_compute_twins_pass_the_reference_compiler(gl_ctx, tmp_path):
    """Every compute variant the blur passes declare compiles with Khronos' reference compiler (stricter than
    Mesa about GLSL 4.30: what a GPU driver's compiler may refuse that llvmpipe accepts)."""
    import subprocess

    from skinviewer.kernel.shaders import ShaderLibrary
    lib = ShaderLibrary(gl_ctx)
    variants = [{}, {"ISLAND_ZONES": 1}, {"ISLAND_ZONES": 1, "NO_ZONE_CHECKS": 1}, {"ISLAND_ZONES": 1, "OPEN_BORDER": 1},
                {"ISLAND_ZONES": 1, "NARROW_TAPS": 6}, {"DILATE": 1}, {"DOWN": 1, "NO_SEAM": 1}, {"OPEN_BORDER": 1}]
    for name in ("deon_blur_cs", "seam_fill_cs"):
        for v in variants:
            for fmt in ("rgba32f", "rg32f"):
                d = tuple((str(k), str(x)) for k, x in sorted({**v, "CS_TILES": 1, "CS_TILE": 16, "IMAGE_FORMAT": fmt}.items()))
                src = lib._assemble(name, d)[0]["compute_shader"]
                f = tmp_path / f"{name}.comp"
                f.write_text(src)
                r = subprocess.run(["glslangValidator", str(f)], capture_output=True, text=True, timeout=60)
                assert r.returncode == 0, (name, v, fmt, r.stdout[-600:])


def test_gl_info_is_never_read_off_the_gl_thread():
    """moderngl caches ctx.info at its first read; read from the viewer's warm-up worker it held zeros
    for the whole context (every pass then failed). kernel/gl.gl_info reads it on the main thread only;
    off it, before a read, {} and nothing cached: compute_choice keeps the fragment draws there."""
    import threading

    from skinviewer.kernel import gl

    reads = []

    class Ctx:
        version_code = 450

        @property
        def info(self):
            reads.append(threading.current_thread().name)
            self._info = {"GL_RENDERER": "some GPU", "GL_MAX_TEXTURE_IMAGE_UNITS": 32}
            return self._info

    ctx, seen = Ctx(), {}
    t = threading.Thread(target=lambda: seen.update(info=gl.gl_info(ctx), choice=gl.compute_choice("auto", ctx)))
    t.start()
    t.join()
    assert seen["info"] == {} and seen["choice"][0] is False and reads == [] and not hasattr(ctx, "_info")
    assert gl.gl_info(ctx)["GL_RENDERER"] == "some GPU" and reads == [threading.current_thread().name]
    assert gl.compute_choice("auto", ctx)[0] is True
