"""Issue 13: every bad input gets one clear line, resources are bounded, hot reload recovers,
nothing is left behind. One test per fix; each failed before the fix."""
from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import quad_gltf, small_settings

from skinviewer.cli import main as cli_main
from skinviewer.ground import files
from skinviewer.ground.settings import (
    Settings,
    SettingsError,
    get_path,
    load_preset,
    parse_assignments,
    save_preset,
    to_dict,
    validate,
    with_values,
)
from skinviewer.kernel.graph import (
    FrameInputs,
    Pass,
    Reflection,
    RenderGraph,
    ResourceLimitError,
    TexSpec,
)
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.scene.camera import light_space, orbit_view
from skinviewer.scene.mesh import MeshData, MeshError, load_mesh, load_texture_maps
from skinviewer.scene.scenes import grid

ROOT = Path(__file__).resolve().parents[1]


def _preset(tmp_path, raw: bytes, name="p.json") -> Path:
    p = tmp_path / name
    p.write_bytes(raw)
    return p


def _errors(exc) -> str:
    return "; ".join(f"{p}: {m}" for p, m in exc.value.errors)


# -- presets: every bad file is one SettingsError --------------------------------------------------

@pytest.mark.parametrize("raw,expect", [
    (b'{"schema_version":1,"technique":"\xff"}', "not UTF-8"),
    ('{"schema_version":1}'.encode("utf-16"), "UTF-16"),
    (b'{"schema_version":1,"render":{"width":' + b"1" * 5000 + b"}}", "digits"),
    (b'{"schema_version":1,"x":' + b"[" * 100000 + b"]" * 100000 + b"}", "nested too deeply"),
])
def test_undecodable_presets_are_settings_errors(tmp_path, raw, expect):
    with pytest.raises(SettingsError) as exc:
        load_preset(_preset(tmp_path, raw))
    assert expect in _errors(exc)


def _in_child(code: str, *args: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a child with a 20 s timeout and a 2 GB address-space limit: a regression
    (reading /dev/zero forever, blocking on a FIFO) fails the test instead of taking the machine."""
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (2 * 2**30, 2 * 2**30))
    try:
        return subprocess.run([sys.executable, "-c", code, *args], cwd=ROOT, capture_output=True, text=True,
                              timeout=20, preexec_fn=limit)
    except subprocess.TimeoutExpired:
        pytest.fail(f"hangs: {args}")


def test_preset_from_a_device_fifo_or_folder_is_refused_without_reading(tmp_path):
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    targets = [fifo, tmp_path] + ([Path("/dev/zero")] if Path("/dev/zero").exists() else [])
    code = ("import sys\nfrom skinviewer.ground.settings import load_preset, SettingsError\n"
            "try:\n    load_preset(sys.argv[1])\nexcept SettingsError as e:\n    print(e)\n")
    for target in targets:
        r = _in_child(code, str(target))
        assert r.returncode == 0 and "not a regular file" in r.stdout, (target, r.stdout, r.stderr[-500:])


def _catch(fn, *a):
    try:
        fn(*a)
    except Exception as exc:  # noqa: BLE001 - the test inspects it
        return exc
    return None


def test_oversized_preset_is_refused(tmp_path):
    p = _preset(tmp_path, b'{"schema_version":1, "pad": "' + b"x" * (5 * 2**20) + b'"}')
    with pytest.raises(SettingsError, match="limit"):
        load_preset(p)


def test_read_regular_file_never_reads_past_the_limit(tmp_path):
    p = tmp_path / "f"
    p.write_bytes(b"a" * 100)
    assert files.read_regular_file(p, 100) == b"a" * 100
    with pytest.raises(files.FileReadError):
        files.read_regular_file(p, 99)


# -- validation ---------------------------------------------------------------------------------

@pytest.mark.parametrize("path,value", [
    ("camera.target", [float("nan"), 0, 0]), ("camera.target", [0, float("inf"), 0]),
    ("render.background", [0, float("inf"), 0]), ("render.background", [float("nan")] * 3),
    ("scene.mesh", "a\x00b"), ("scene.albedo_map", "a\ud800b"), ("scene.mesh", ""),
    ("lights.0.position", [1e20, 0, 0]),
])
def test_bad_values_are_refused_at_validation(path, value):
    with pytest.raises(SettingsError) as exc:
        with_values(Settings(), {path: value})
    assert exc.value.errors[0][0] == path


def test_negative_list_indices_are_refused():
    s = Settings()
    with pytest.raises(SettingsError, match="no such setting"):
        with_values(s, {"lights.-1.intensity": 2.0})
    with pytest.raises(SettingsError):
        with_values(s, {"deon.gaussians.-2.variance": 1.0})
    with pytest.raises((IndexError, KeyError)):
        get_path(s, "lights.-1")
    assert with_values(s, {"lights.1.intensity": 2.0}).lights[1].intensity == 2.0


def test_set_values_that_json_cannot_hold_are_settings_errors():
    with pytest.raises(SettingsError) as exc:
        parse_assignments(["lights.0.intensity=" + "1" * 5000])
    assert exc.value.errors[0][0] == "lights.0.intensity"
    with pytest.raises(SettingsError, match="nested too deeply"):
        parse_assignments(["lights.0.color=" + "[" * 100000])


def test_surrogate_path_from_a_non_utf8_file_name_is_accepted():
    # argv decodes the byte 0xff of a real file name to U+DCFF (surrogateescape): a usable path
    s = with_values(Settings(), {"scene.mesh": os.fsdecode(b"/tmp/\xffhead.glb")})
    from skinviewer.engine.renderer import Renderer
    assert Renderer.scene_key(s)


# -- far point lights, near plane -----------------------------------------------------------------

def test_light_space_of_a_very_far_point_light_is_finite():
    light = SimpleNamespace(kind="point", position=(1e20, 0.0, 0.0), direction=(0, 0, 1))
    ls = light_space(light, np.zeros(3), 100.0)  # ZeroDivisionError before: near == far in float64
    assert np.all(np.isfinite(ls.view_proj_rowvec))
    d = ls.depth(np.array([[100.0, 0, 0], [-100.0, 0, 0]]))
    assert np.all(np.isfinite(d)) and d[0] < d[1]


@pytest.mark.parametrize("radius", [1e-6, 1e-9, 1.0, 1e6])
def test_near_plane_scales_with_the_mesh(radius):
    cam = Settings().camera
    v = orbit_view(cam, np.zeros(3), radius, (64, 64))
    # the mesh's nearest point (distance - radius along the view axis) must lie beyond near
    near = v.proj[2, 3] / (v.proj[2, 2] - 1.0)
    dist = float(np.linalg.norm(v.eye))
    assert near < dist - radius, (near, dist, radius)


# -- relative paths in presets --------------------------------------------------------------------

def test_relative_mesh_path_resolves_against_the_preset_folder_and_is_saved_relative(tmp_path, monkeypatch):
    folder = tmp_path / "presets"
    (folder / "meshes").mkdir(parents=True)
    p = _preset(folder, json.dumps({"schema_version": 1, "scene": {"mesh": "meshes/head.obj",
                                                                   "albedo_map": "../tex/a.png"}}).encode())
    monkeypatch.chdir(tmp_path)
    s = load_preset(p)
    assert Path(s.scene.mesh) == folder / "meshes" / "head.obj"
    assert Path(s.scene.albedo_map) == tmp_path / "tex" / "a.png"
    out = tmp_path / "elsewhere" / "q.json"
    save_preset(s, out)
    data = json.loads(out.read_text())
    assert data["scene"]["mesh"] == os.path.join("..", "presets", "meshes", "head.obj")
    assert load_preset(out) == s  # round trip from another folder


# -- stale temporaries ----------------------------------------------------------------------------

def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_stale_temporaries_of_killed_saves_are_cleaned_and_never_listed(tmp_path):
    target = tmp_path / "deon.json"
    dead = tmp_path / f".deon.json.{_dead_pid()}-abc12345.tmp"
    live = tmp_path / f".deon.json.{os.getppid()}-def67890.tmp"  # a save in progress elsewhere
    old = tmp_path / ".deon.json.k3j4h5g6.tmp"  # an older build's name, an hour old
    other = tmp_path / ".gosselin.json.q1w2e3r4.tmp"
    for f in (dead, live, old, other):
        f.write_text("{")
    t = time.time() - 3600
    os.utime(old, (t, t))
    assert all(files.is_temporary(f) for f in (dead, live, old, other))
    assert files.list_files(tmp_path) == []
    save_preset(Settings(), target)
    assert not dead.exists() and not old.exists()
    assert live.exists() and other.exists()  # not stale / not this target's
    assert files.list_files(tmp_path) == [target]


def test_killed_saves_leave_nothing_after_the_next_save(tmp_path):
    target = tmp_path / "p.json"
    code = ("import os,sys\nfrom skinviewer.ground import files\n"
            "with files.atomic_path(sys.argv[1]) as t:\n    open(t,'w').write('x')\n    os._exit(9)\n")
    for _ in range(3):  # killed mid-save: its temporary stays behind until the next save
        subprocess.run([sys.executable, "-c", code, str(target)], cwd=ROOT, check=False)
    assert len(list(tmp_path.glob(".p.json.*.tmp"))) == 1  # each save cleaned the one before
    save_preset(Settings(), target)
    assert list(tmp_path.iterdir()) == [target]


# -- meshes and images ----------------------------------------------------------------------------

def _plane(scale=1.0, offset=0.0, name="plane") -> MeshData:
    pos, nrm, uv, idx = grid(4, 4, 2.0, 2.0)
    return MeshData(positions=pos * scale + offset, normals=nrm, uvs=uv, indices=idx, name=name)


def test_vertices_beyond_float32_are_refused():
    with pytest.raises(MeshError, match="float32"):
        _plane(1e39)


@pytest.mark.parametrize("scale,offset,why", [(1e30, 0.0, "rescale"), (1e-20, 0.0, "across"),
                                              (1.0, 1e7, "origin"), (0.0, 0.0, "zero size")])
def test_unrenderable_scales_are_refused_with_the_reason(scale, offset, why):
    with pytest.raises(MeshError, match=why):
        _plane(scale, offset).check_renderable()


def _obj(path: Path, scale: float, mtl: bool = False) -> Path:
    pos, _, uv, idx = grid(6, 6, 2.0, 2.0)
    lines = [f"v {float(x) * scale!r} {float(y) * scale!r} {float(z) * scale!r}" for x, y, z in pos]
    lines += [f"vt {u} {v}" for u, v in uv]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in idx]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("scale", [1e-6, 1e12])
def test_tiny_and_huge_meshes_are_framed(renderer, tmp_path, scale):
    mesh = _obj(tmp_path / "m.obj", scale)
    s = small_settings("head", "phong", size=32, **{"scene.mesh": str(mesh), "scene.mm_per_unit": 1.0,
                                                     "camera.yaw": 0.0, "camera.pitch": 0.0,
                                                     "lights": [{"direction": [0, 0, 1]}]})
    renderer.render(s)
    img = renderer.image(s).astype(float)
    bg = renderer.image(s)[0, 0].astype(float)
    centre = img[12:20, 12:20]
    assert np.abs(centre - bg).max() > 20, "the plane is not in the image (clipped or blank)"


def test_obj_without_material_gets_the_skin_tone_and_says_so(tmp_path):
    m = load_mesh(_obj(tmp_path / "plain.obj", 1.0))
    assert m.albedo is None  # not trimesh's 2x2 grey placeholder
    assert any("no material texture" in n for n in m.notes), m.notes
    assert not any("base colour texture" in n for n in m.notes)


def test_sixteen_bit_textures_keep_their_values(tmp_path):
    from PIL import Image
    ramp = (np.linspace(0, 65535, 64 * 64).reshape(64, 64)).astype(np.uint16)
    p = tmp_path / "ramp16.png"
    Image.fromarray(ramp).save(p)
    m = load_texture_maps(_plane(), albedo=p, specular=p)
    got = m.albedo[::-1][..., 0]  # back to image row order
    assert np.abs(got - ramp / 65535.0).max() < 1e-4
    assert (got > 0.999).mean() < 0.01  # saturated almost everywhere before
    spec = m.specular_map[::-1][..., 0]
    assert np.abs(spec - np.rint(ramp / 257.0) / 255.0).max() < 1e-6


def _png_header(w: int, h: int) -> bytes:
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 16)) + chunk(b"IEND", b"")


@pytest.mark.parametrize("side", [16384, 9000])
def test_huge_images_are_one_clear_error(tmp_path, side):
    p = tmp_path / "huge.png"
    p.write_bytes(_png_header(side, side))
    with pytest.raises(MeshError, match="too large|megapixels"):
        load_texture_maps(_plane(), albedo=p)


def test_fifo_as_a_texture_or_mesh_does_not_hang(tmp_path):
    fifo = tmp_path / "albedo.png"
    os.mkfifo(fifo)
    code = ("import sys\nsys.path.insert(0, 'tests')\nfrom skinviewer.scene.mesh import MeshError, load_mesh, "
            "load_texture_maps, MeshData\nfrom skinviewer.scene.scenes import grid\n"
            "p, n, uv, i = grid(2, 2, 1.0, 1.0)\nm = MeshData(positions=p, normals=n, uvs=uv, indices=i)\n"
            "for fn in (lambda: load_texture_maps(m, albedo=sys.argv[1]), lambda: load_mesh(sys.argv[1])):\n"
            "    try:\n        fn()\n    except MeshError as e:\n        print(e)\n")
    r = _in_child(code, str(fifo))
    assert r.returncode == 0 and r.stdout.count("regular file") == 2, (r.stdout, r.stderr[-500:])


# -- hot reload recovers ----------------------------------------------------------------------------

VERT = '#version 330 core\n#include "lib/a.glsl"\nvoid main() { gl_Position = vec4(f(0.5)); }\n'
FRAG = '#version 330 core\nout vec4 c;\nvoid main() { c = vec4(1.0); }\n'
LIB_A = "float f(float x) { return x; }\n"


@pytest.fixture
def shader_root(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "a.glsl").write_text(LIB_A)
    (tmp_path / "p.vert").write_text(VERT)
    (tmp_path / "p.frag").write_text(FRAG)
    return tmp_path


def _later(path: Path, text: str | None):
    time.sleep(0.01)
    if text is None:
        path.unlink()
    else:
        path.write_text(text)


def test_reload_recovers_after_a_deleted_include_is_restored(gl_ctx, shader_root):
    lib = ShaderLibrary(gl_ctx, shader_root)
    lib.get("p")
    _later(shader_root / "lib" / "a.glsl", None)
    _, errors = lib.reload()
    assert "not found" in str(errors["p"])
    _later(shader_root / "lib" / "a.glsl", LIB_A.replace("x;", "x * 2.0;"))
    replaced, errors = lib.reload()  # stuck with the error before: the include was not watched
    assert replaced == ["p"] and errors == {}


def test_reload_recovers_after_an_include_cycle_is_broken(gl_ctx, shader_root):
    lib = ShaderLibrary(gl_ctx, shader_root)
    lib.get("p")
    (shader_root / "lib" / "b.glsl").write_text('#include "a.glsl"\n')
    _later(shader_root / "lib" / "a.glsl", '#include "b.glsl"\n' + LIB_A)
    _, errors = lib.reload()
    assert "cycle" in str(errors["p"])
    _later(shader_root / "lib" / "b.glsl", "// no include\n")  # only b changes
    replaced, errors = lib.reload()
    assert replaced == ["p"] and errors == {}


def test_reload_recovers_after_a_deleted_stage_file_is_restored(gl_ctx, shader_root):
    lib = ShaderLibrary(gl_ctx, shader_root)
    lib.get("p")
    _later(shader_root / "p.frag", None)
    lib.reload()
    # a fresh program that never compiled must recover as well
    lib2 = ShaderLibrary(gl_ctx, shader_root)
    with pytest.raises(Exception):
        lib2.get("p")
    _later(shader_root / "p.frag", FRAG.replace("1.0", "0.5"))
    for lb in (lib, lib2):
        replaced, errors = lb.reload()
        assert replaced == ["p"] and errors == {}


# -- renderer: release, memory ------------------------------------------------------------------------

def test_release_frees_the_full_screen_vaos(gl_ctx):
    from skinviewer.engine.renderer import Renderer
    r = Renderer(gl_ctx)
    s = small_settings("laser", "phong", size=16)
    r.render(s)
    vaos = [v for g in r.graphs.values() for _, _, v in g.gpu._vaos.values()]  # the graphs' one VAO cache
    progs = [e.program for e in r.shaders._entries.values()]
    assert vaos and progs
    r.release()
    assert all(type(v.mglo).__name__ == "InvalidObject" for v in vaos)
    assert all(type(p.mglo).__name__ == "InvalidObject" for p in progs)  # its own shader library too


LARGEST = {"render.width": 8192, "render.height": 8192, "shadow.map_size": 8192, "deon.tsm_size": 8192,
           "deon.irradiance_size": 4096, "gosselin.light_map_size": 4096, "specular.lut_size": 4096}


def test_configuration_that_does_not_fit_is_refused_before_allocating(gl_ctx):
    from skinviewer.engine.renderer import Renderer
    r = Renderer(gl_ctx)
    r.memory_limit = 2 * 10**9
    try:
        s = small_settings("laser", "deon", size=16, **LARGEST)
        with pytest.raises(ResourceLimitError) as exc:
            r.render(s)
        assert exc.value.needed > 4e9 and "GB" in str(exc.value)
        assert r.pool.allocated == 0  # refused before any texture was made
        small = small_settings("laser", "deon", size=16)
        r.render(small)  # a configuration that fits still renders
        assert r.pool.allocated > 0
    finally:
        r.release()


# -- non-finite pass outputs are named in the frame report ------------------------------------------

FS_VERT = ("#version 330 core\nvoid main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2); "
           "gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }\n")


class Poison(Pass):
    """Writes u_value everywhere, or NaN/Inf into one texel: a user's broken shader edit."""
    uses_scene = False
    name = "poison"

    def __init__(self, value: float, dtype="f2"):
        self.value, self.dtype = value, dtype

    def reflect(self, r: Reflection):
        r.setting("render.exposure")
        r.program("fill")
        r.output("lit", TexSpec((200, 70), 4, self.dtype))

    def execute(self, ec):
        prog = ec.program("fill")
        ec.set(prog, "u_value", self.value)
        ec.draw_fullscreen(prog, "lit")


def _poison_graph(gl_ctx, tmp_path, value, dtype="f2"):
    (tmp_path / "fill.vert").write_text(FS_VERT)
    (tmp_path / "fill.frag").write_text("#version 330 core\nuniform float u_value;\nout vec4 f;\nvoid main() {"
                                        " f = (ivec2(gl_FragCoord.xy) == ivec2(137, 41)) ? vec4(u_value) : vec4(0.5); }\n")
    return RenderGraph(gl_ctx, ShaderLibrary(gl_ctx, tmp_path), [Poison(value, dtype)], ["lit"])


@pytest.mark.parametrize("value,dtype", [(float("nan"), "f2"), (float("inf"), "f2"), (float("-inf"), "f4"),
                                         (float("nan"), "f4")])
def test_a_pass_writing_nan_or_inf_is_named(gl_ctx, tmp_path, value, dtype):
    g = _poison_graph(gl_ctx, tmp_path, value, dtype)
    s = Settings()
    rep = g.run(FrameInputs(s, None, 0, None, "c"))
    assert rep.nonfinite == {"poison": ["lit"]}
    assert "NON-FINITE: lit" in rep.table() and rep.to_json()["nonfinite"] == {"poison": ["lit"]}
    rep = g.run(FrameInputs(with_values(s, {"phong.ambient": 0.5}), None, 0, None, "c"))
    assert rep.cached == ["poison"] and rep.nonfinite == {"poison": ["lit"]}  # the cached output keeps its flag
    g.release()


def test_finite_outputs_and_the_off_switch_flag_nothing(gl_ctx, tmp_path):
    g = _poison_graph(gl_ctx, tmp_path, 1e4)
    assert g.run(FrameInputs(Settings(), None, 0, None, "c")).nonfinite == {}
    g.release()
    g = _poison_graph(gl_ctx, tmp_path, float("nan"))
    off = with_values(Settings(), {"render.check_finite": False})
    assert g.run(FrameInputs(off, None, 0, None, "c")).nonfinite == {}
    g.release()


def test_a_preview_skips_the_check_and_the_final_image_checks_what_it_left(gl_ctx, tmp_path):
    """A governed preview (FrameInputs.interactive, issue 27) does not scan its outputs; the first frame
    that is not a preview and finds that pass cached scans it then, so the final image is checked."""
    g = _poison_graph(gl_ctx, tmp_path, float("nan"))
    s = Settings()
    rep = g.run(FrameInputs(s, None, 0, None, "c", interactive=True))
    assert rep.ran == ["poison"] and rep.nonfinite == {}  # not checked while the user drags
    assert g._check_ms == {}
    rep = g.run(FrameInputs(with_values(s, {"phong.ambient": 0.5}), None, 0, None, "c"))
    assert rep.cached == ["poison"] and rep.nonfinite == {"poison": ["lit"]}  # checked when the image is final
    assert g._check_ms["poison"] > 0.0  # the budget's look-ahead counts what the check costs
    # a preview frame that re-runs it, then a final frame that re-runs it again: checked by that one
    rep = g.run(FrameInputs(with_values(s, {"render.exposure": 2.0}), None, 0, None, "c", interactive=True))
    assert rep.ran == ["poison"] and rep.nonfinite == {}
    rep = g.run(FrameInputs(with_values(s, {"render.exposure": 3.0}), None, 0, None, "c"))
    assert rep.ran == ["poison"] and rep.nonfinite == {"poison": ["lit"]}
    g.release()


def test_output_pass_keeps_the_screen_finite_over_a_poisoned_lit(renderer):
    s = small_settings("laser", "phong", size=16)
    renderer.render(s)
    g = renderer.graph("phong")
    lit = g.texture("lit")
    bad = np.full((16, 16, 4), np.nan, np.float16)
    bad[:8] = np.inf
    lit.write(bad.tobytes())
    g.invalidate("output")
    s = with_values(s, {})  # not the idle frame's object: the graph looks at its cache keys
    assert renderer.render(s).ran == ["output"]
    img = renderer.image(s)
    bg = img[-1, 0].astype(int)  # a corner: background (the laser slab does not reach it)
    flat = img.reshape(-1, 3).astype(int)
    assert np.all(np.abs(flat - bg) <= 1), np.unique(flat, axis=0)  # background, not garbage


# -- the command line: one line, exit 2 -------------------------------------------------------------

@pytest.mark.parametrize("argv_tail", [
    ["--preset", "{b}"], ["--preset", "{huge}"], ["--preset", "{deep}"], ["--preset", "/dev/zero"],
    ["--set", 'scene.mesh="a\\u0000b"'], ["--set", 'scene.mesh="a\\ud800b"'],
    ["--set", "lights.0.kind=point", "--set", "lights.0.position=1e20,0,0"],
    ["--set", "camera.target=[NaN,0,0]"], ["--set", "render.background=0,Infinity,0"],
    ["--set", "lights.-1.intensity=2"], ["--set", "lights.0.intensity=" + "9" * 5000],
])
def test_cli_errors_are_one_line_and_exit_2(tmp_path, capsys, argv_tail):
    b = _preset(tmp_path, b'{"schema_version":1,"technique":"\xff"}', "b.json")
    huge = _preset(tmp_path, b'{"schema_version":1,"render":{"width":' + b"1" * 5000 + b"}}", "huge.json")
    deep = _preset(tmp_path, b'{"schema_version":1,"x":' + b"[" * 100000 + b"}", "deep.json")
    argv = ["render", "--out", str(tmp_path / "x.png")] + [a.format(b=b, huge=huge, deep=deep) for a in argv_tail]
    assert cli_main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("skinviewer:") and "\n" not in err and "Traceback" not in err, err


def test_cli_refuses_a_configuration_that_does_not_fit(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SKINVIEWER_MEMORY_LIMIT", "1G")
    argv = ["render", "--scene", "laser", "--technique", "deon", "--out", str(tmp_path / "x.png"), "--size", "8192x8192"]
    for k, v in LARGEST.items():
        if not k.startswith("render."):
            argv += ["--set", f"{k}={v}"]
    assert cli_main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "GB of texture memory" in err and "\n" not in err
    assert not (tmp_path / "x.png").exists()


def test_settings_roundtrip_unchanged_by_validators():
    s = Settings()
    assert validate(to_dict(s)) == s


# == issue 35: reliability, second round ===========================================================
# What a mesh points at (FIFOs, missing files, huge buffers), glTF UVs, winding, EXIF, output paths,
# numeric arguments, the cache, shader roots. Each test failed on the tree before its fix.

def _gltf(path: Path, meshes=1, material=True, nested=False, bin_uri=None, image_uri=None) -> np.ndarray:
    """A glTF of ``meshes`` unit quads (UVs in [0.25, 0.75]); returns the file's TEXCOORD_0."""
    UV = np.array([[0.25, 0.25], [0.75, 0.3], [0.7, 0.75], [0.3, 0.7]], np.float32)
    d, buf = quad_gltf(UV, bin_uri)
    if bin_uri:
        (path.parent / bin_uri).write_bytes(buf)
    d.update({"meshes": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0})
    for _ in range(meshes):
        prim = {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2}
        if material:
            prim["material"] = 0
        d["meshes"].append({"primitives": [prim]})
    if material:
        d["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1]}}]
        if image_uri:
            d["images"] = [{"uri": image_uri}]
            d["textures"] = [{"source": 0}]
            d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    for k in range(meshes):
        if nested:  # a parent moves, its child rotates 90 degrees about z
            d["nodes"].append({"children": [len(d["nodes"]) + 1], "translation": [k * 2.0, 0, 0]})
            d["nodes"].append({"mesh": k, "rotation": [0, 0, 0.7071068, 0.7071068]})
            d["scenes"][0]["nodes"].append(len(d["nodes"]) - 2)
        else:
            d["nodes"].append({"mesh": k, "translation": [k * 2.0, 0, 0]})
            d["scenes"][0]["nodes"].append(len(d["nodes"]) - 1)
    path.write_text(json.dumps(d))
    return np.tile(UV * [1, -1] + [0, 1], (meshes, 1))  # glTF's v runs down the image


@pytest.mark.parametrize("kw", [{"material": False}, {"meshes": 3, "material": False},
                                {"meshes": 2, "nested": True, "material": False}, {"meshes": 2, "nested": True}])
def test_gltf_uvs_are_kept_without_a_material_and_across_meshes(tmp_path, kw):
    uv = _gltf(tmp_path / "q.gltf", **kw)
    m = load_mesh(tmp_path / "q.gltf")
    assert not any("xatlas" in n for n in m.notes), m.notes
    np.testing.assert_allclose(m.uvs, uv, atol=1e-6)
    if kw.get("nested"):  # the child's rotation and the parent's translation both apply
        np.testing.assert_allclose(np.sort(m.positions[:, 0]), [-1, -1, 0, 0, 1, 1, 2, 2], atol=1e-6)


def _cube_obj(path: Path, inverted: bool, mtl: str | None = None) -> Path:
    import trimesh
    box = trimesh.creation.box()
    f = box.faces[:, ::-1] if inverted else box.faces
    lines = ([f"mtllib {mtl}", "usemtl skin"] if mtl else []) + [f"v {x} {y} {z}" for x, y, z in box.vertices]
    lines += [f"vt {0.1 + 0.1 * (i % 8)} {0.1 + 0.1 * (i // 8)}" for i in range(len(box.vertices))]
    lines += ["f " + " ".join(f"{a + 1}/{a + 1}" for a in tri) for tri in f]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_inverted_winding_of_a_closed_mesh_is_reversed_and_noted(tmp_path):
    from skinviewer.scene.mesh import signed_volume
    good = load_mesh(_cube_obj(tmp_path / "good.obj", inverted=False))
    bad = load_mesh(_cube_obj(tmp_path / "bad.obj", inverted=True))
    assert not any("wound inwards" in n for n in good.notes)
    assert any("wound inwards" in n for n in bad.notes), bad.notes
    assert signed_volume(bad.positions, bad.indices) == pytest.approx(1.0)
    # its normals point outwards, like the correctly wound cube's
    out = bad.positions - bad.positions.mean(0)
    assert ((bad.normals * out).sum(1) > 0).all()


def test_open_mesh_winding_is_left_alone(tmp_path):
    m = load_mesh(_obj(tmp_path / "plane.obj", 1.0))
    assert not any("wound" in n for n in m.notes)


def _jpeg_with_orientation(path: Path, orientation: int) -> np.ndarray:
    from PIL import Image
    a = np.zeros((8, 16, 3), np.uint8)
    a[:, :8] = 255  # left half white: 16 wide, 8 tall as stored
    img = Image.fromarray(a)
    exif = img.getexif()
    exif[0x0112] = orientation
    img.save(path, format="JPEG", exif=exif, quality=100)
    return a


def test_jpeg_exif_orientation_is_applied(tmp_path):
    p = tmp_path / "rot.jpg"
    _jpeg_with_orientation(p, 6)  # shown rotated 90 degrees clockwise: 8 wide, 16 tall
    m = load_texture_maps(_plane(), albedo=p)
    assert m.albedo.shape[:2] == (16, 8)
    shown = m.albedo[::-1][..., 0]  # image row order
    assert shown[:8].mean() > 0.9 and shown[8:].mean() < 0.1  # the white half is on top


def test_exr_as_albedo_says_so(tmp_path):
    p = tmp_path / "lin.exr"
    files.save_exr(p, np.ones((4, 4, 3), np.float32))
    with pytest.raises(MeshError) as exc:
        load_texture_maps(_plane(), albedo=p)
    assert "OpenEXR" in str(exc.value) and "BytesIO" not in str(exc.value)


def test_garbage_obj_is_one_clear_line(tmp_path):
    p = tmp_path / "garbage.obj"
    p.write_bytes(bytes(range(256)) * 64)
    with pytest.raises(MeshError) as exc:
        load_mesh(p)
    msg = str(exc.value)
    assert "module" not in msg and "charset" not in msg and str(p) in msg, msg


def test_missing_textures_and_mtl_are_noted(tmp_path):
    _cube_obj(tmp_path / "nomtl.obj", False, mtl="gone.mtl")
    m = load_mesh(tmp_path / "nomtl.obj")
    assert any("gone.mtl" in n for n in m.notes), m.notes
    (tmp_path / "skin.mtl").write_text("newmtl skin\nKd 1 1 1\nmap_Kd missing_albedo.png\n")
    m = load_mesh(_cube_obj(tmp_path / "notex.obj", False, mtl="skin.mtl"))
    assert any("missing_albedo.png" in n for n in m.notes), m.notes
    _gltf(tmp_path / "q.gltf", image_uri="missing_base.png")
    m = load_mesh(tmp_path / "q.gltf")
    assert any("missing_base.png" in n for n in m.notes), m.notes


def test_fifos_a_mesh_points_at_do_not_hang(tmp_path):
    """mtllib, map_Kd, a glTF image URI and a glTF buffer that are FIFOs: refused without blocking."""
    os.mkfifo(tmp_path / "fifo.mtl")
    os.mkfifo(tmp_path / "fifo.png")
    os.mkfifo(tmp_path / "fifo.bin")
    _cube_obj(tmp_path / "a.obj", False, mtl="fifo.mtl")
    (tmp_path / "tex.mtl").write_text("newmtl skin\nmap_Kd fifo.png\n")
    _cube_obj(tmp_path / "b.obj", False, mtl="tex.mtl")
    _gltf(tmp_path / "c.gltf", image_uri="fifo.png")
    d = json.loads((tmp_path / "c.gltf").read_text())
    d["buffers"][0]["uri"] = "fifo.bin"
    (tmp_path / "d.gltf").write_text(json.dumps(d))
    code = ("import sys\nfrom skinviewer.scene.mesh import MeshError, load_mesh\n"
            "for a in sys.argv[1:]:\n    try:\n        print(a, load_mesh(a).notes)\n"
            "    except MeshError as e:\n        print(a, 'ERROR', e)\n")
    r = _in_child(code, *(str(tmp_path / n) for n in ("a.obj", "b.obj", "c.gltf", "d.gltf")))
    lines = r.stdout.splitlines()
    assert r.returncode == 0 and len(lines) == 4, (r.stdout, r.stderr[-800:])
    assert all("FIFO" in line for line in lines), lines
    assert "ERROR" in lines[3] and "fifo.bin" in lines[3]  # no geometry without its buffer


def test_huge_external_gltf_buffer_is_refused_with_the_reason(tmp_path):
    _gltf(tmp_path / "q.gltf", bin_uri="big.bin")
    with open(tmp_path / "big.bin", "r+b") as f:  # sparse: 3 GiB on paper, nothing on disk
        f.truncate(3 * 2**30)
    with pytest.raises(MeshError) as exc:
        load_mesh(tmp_path / "q.gltf")
    assert "big.bin" in str(exc.value) and "limit" in str(exc.value), str(exc.value)


def test_mesh_references_outside_its_folder_are_not_read(tmp_path):
    (tmp_path / "sub").mkdir()
    secret = tmp_path / "secret.png"
    from PIL import Image
    Image.new("RGB", (4, 4), (255, 0, 0)).save(secret)
    (tmp_path / "sub" / "x.mtl").write_text("newmtl skin\nmap_Kd ../secret.png\n")
    m = load_mesh(_cube_obj(tmp_path / "sub" / "x.obj", False, mtl="x.mtl"))
    assert m.albedo is None and any("outside the mesh's folder" in n for n in m.notes), m.notes


# -- outputs: the extension says the format; an output never replaces an input ---------------------

def _cli(argv) -> int:
    """cli_main's exit status, also when argparse exits."""
    try:
        return cli_main([str(a) for a in argv])
    except SystemExit as exc:
        return int(exc.code)


@pytest.fixture
def no_work(monkeypatch):
    """Every command's expensive step fails the test: a refusal must come before any of it (before
    these fixes, `reference --max-seconds nan` started a 45-minute reference)."""
    import skinviewer.cli.export as export_cli
    import skinviewer.cli.import_ as import_cli
    import skinviewer.cli.profile as profile_cli
    import skinviewer.cli.render as render_cli
    import skinviewer.cli.turntable as turntable_cli
    from skinviewer.engine import bench, reference

    def started(*a, **k):
        raise AssertionError("work started before the arguments were checked")
    for mod, name in [(reference, "compute_reference"), (bench, "run_bench"), (render_cli, "headless_context"),
                      (turntable_cli, "render_frames"), (export_cli, "export"), (import_cli, "read_any"),
                      (profile_cli, "fit_gaussians")]:
        monkeypatch.setattr(mod, name, started)
    try:
        from skinviewer.ui import app
        monkeypatch.setattr(app, "run_viewer", started)
    except ImportError:
        pass


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("ext,fmt", [(".jpg", "JPEG"), (".jpeg", "JPEG"), (".tif", "TIFF"), (".tiff", "TIFF"),
                                     (".bmp", "BMP"), (".png", "PNG")])
def test_render_writes_the_format_its_extension_names(tmp_path, capsys, ext, fmt):
    from PIL import Image
    out = tmp_path / f"x{ext}"
    assert _cli(["render", "--scene", "stretch-plane", "--technique", "phong", "--size", "16x16", "--out", str(out)]) == 0
    with Image.open(out) as img:
        assert img.format == fmt and img.size == (16, 16)


@pytest.mark.parametrize("argv", [
    ["render", "--out", "{d}/x.gif"], ["render", "--out", "{d}/x"], ["render", "--out", "{d}/x.png", "--exr", "{d}/lin.png"],
    ["reference", "--out", "{d}/r.webp"], ["reference", "--out", "{d}/r.png", "--exr", "{d}/r.tif"],
    ["reference", "--out", "{d}/r.png", "--npy", "{d}/r.png2"], ["view", "--frames", "1", "--screenshot", "{d}/s.gif"],
    ["import", "{d}/x.asset", "--preview", "{d}/p.exr"], ["profile", "--plot", "{d}/plot.jpg"],
])
def test_outputs_whose_extension_is_not_written_are_refused_before_any_work(tmp_path, capsys, no_work, argv):
    if argv[0] == "view":
        pytest.importorskip("moderngl_window")  # without the viewer's packages it says that instead (GPU check)
    assert _cli([a.format(d=tmp_path) for a in argv]) == 2
    err = _one_line_error(capsys)
    assert "extension" in err or "name the file" in err, err
    assert list(tmp_path.iterdir()) == []  # nothing written, nothing left


def test_reference_out_exr_is_the_linear_image(tmp_path, capsys):
    out = tmp_path / "r.exr"
    argv = ["reference", "--scene", "stretch-plane", "--size", "16x16", "--h", "2", "--no-cache", "--out", str(out),
            "--npy", str(tmp_path / "r.npy")]
    assert _cli(argv) == 0
    assert out.read_bytes()[:4] == b"\x76\x2f\x31\x01"  # OpenEXR magic, not PNG bytes
    lin = np.load(tmp_path / "r.npy")
    np.testing.assert_array_equal(files.load_exr(out)[..., :3], lin[..., :3])


@pytest.mark.skipif(not os.environ.get("DISPLAY"), reason="needs an X display (Xvfb)")
def test_viewer_screenshot_exr_is_the_linear_image(tmp_path):
    out = tmp_path / "s.exr"
    r = subprocess.run([sys.executable, "-m", "skinviewer", "view", "--scene", "stretch-plane", "--technique", "phong",
                        "--size", "64x64", "--frames", "1", "--screenshot", str(out)], cwd=ROOT, capture_output=True,
                       text=True, timeout=120, check=False)
    assert r.returncode == 0, r.stderr[-800:]
    assert out.read_bytes()[:4] == b"\x76\x2f\x31\x01"
    assert files.load_exr(out).dtype == np.float32


@pytest.mark.parametrize("case", ["map", "mesh", "preset-out", "import", "two-outputs"])
def test_an_output_never_overwrites_an_input(tmp_path, capsys, no_work, case):
    from PIL import Image
    alb = tmp_path / "alb.png"
    Image.new("RGB", (4, 4), (200, 150, 120)).save(alb)
    mesh = _obj(tmp_path / "m.obj", 1.0)
    preset = _preset(tmp_path, b'{"schema_version": 1}', "p.json")
    before = {p: p.read_bytes() for p in (alb, mesh, preset)}
    argv = {"map": ["render", "--set", f"scene.albedo_map={alb}", "--out", str(alb)],
            "mesh": ["render", "--mesh", str(mesh), "--out", str(tmp_path / "m.png"), "--exr",
                     str(tmp_path / ".." / tmp_path.name / "m.obj.exr"), "--timings", str(mesh)],
            "preset-out": ["profile", "--base-preset", str(preset), "--preset-out", str(preset)],
            "import": ["import", str(preset), "--preset-out", str(preset)],
            "two-outputs": ["render", "--out", str(tmp_path / "x.exr"), "--exr", str(tmp_path / "x.exr")],
            }[case]
    assert _cli(argv) == 2
    err = _one_line_error(capsys)
    assert "would overwrite" in err, err
    assert {p: p.read_bytes() for p in before} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["alb.png", "m.obj", "p.json"]


# -- numeric arguments: finite and in range, checked before any work -------------------------------

@pytest.mark.parametrize("argv,flag", [
    (["reference", "--max-seconds", "nan"], "--max-seconds"), (["reference", "--max-seconds", "-5"], "--max-seconds"),
    (["reference", "--h", "inf"], "--h"), (["reference", "--h", "0"], "--h"),
    (["bench", "--budget-ms", "-1"], "--budget-ms"), (["bench", "--budget-ms", "nan"], "--budget-ms"),
    (["bench", "--runs", "1e9"], "--runs"), (["bench", "--runs", "2"], "--runs"),
    (["render", "--camera", "nan,0"], "--camera"), (["render", "--camera", "0,inf"], "--camera"),
    (["render", "--camera", "0,0,-3"], "--camera"), (["render", "--camera", "0,0,0"], "--camera"),
    (["view", "--frames", "-1"], "--frames"), (["view", "--frames", "nan"], "--frames"),
    (["export", "--to", "hdrp", "--world-scale", "nan"], "--world-scale"),
    (["export", "--to", "hdrp", "--unreal-world-unit-scale", "-1"], "--unreal-world-unit-scale"),
    (["turntable", "--frames", "0"], "--frames"), (["turntable", "--fps", "nan"], "--fps"),
    (["turntable", "--fps", "inf"], "--fps"),
    (["profile", "--eta", "nan"], "--eta"), (["profile", "--thickness", "nan"], "--thickness"),
    (["profile", "--thickness", "-inf"], "--thickness"), (["profile", "--material", "Skin1", "--fit", "0"], "--fit"),
    (["profile", "--material", "Skin1", "--fit", "99"], "--fit"),
    (["profile", "--model", "multipole", "--layer", "nan:1,1,1:1,1,1"], "--layer"),
    (["import", "x.asset", "--size", "nanxnan"], "--size"),
])
def test_numeric_arguments_are_checked_up_front(tmp_path, capsys, no_work, argv, flag):
    out = ["--out", str(tmp_path / "o.png")] if argv[0] in ("reference", "render") else \
        ["--out", str(tmp_path / "o")] if argv[0] in ("bench", "turntable") else \
        ["--out", str(tmp_path / "o.asset")] if argv[0] == "export" else []
    assert _cli(argv + out) == 2
    err = _one_line_error(capsys)
    assert flag in err, err
    assert list(tmp_path.iterdir()) == []


def test_schema_version_true_is_not_version_1(tmp_path):
    with pytest.raises(SettingsError) as exc:
        load_preset(_preset(tmp_path, b'{"schema_version": true}'))
    assert "schema_version" in _errors(exc)


# -- Ctrl-C and EXR writer failures: one line, nothing half-written --------------------------------

def test_ctrl_c_during_a_render_exits_130_with_one_line(tmp_path, capsys, monkeypatch):
    from skinviewer.engine.renderer import Renderer

    def interrupted(self, *a, **k):
        raise KeyboardInterrupt
    monkeypatch.setattr(Renderer, "render_settled", interrupted)
    assert _cli(["render", "--scene", "stretch-plane", "--size", "16x16", "--out", str(tmp_path / "x.png")]) == 130
    assert "interrupted" in _one_line_error(capsys)
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_while_writing_leaves_nothing(tmp_path, monkeypatch):
    real = os.fsync

    def interrupted(fd):
        raise KeyboardInterrupt
    monkeypatch.setattr(os, "fsync", interrupted)
    with pytest.raises(KeyboardInterrupt):
        files.save_exr(tmp_path / "x.exr", np.ones((4, 4, 3), np.float32))
    monkeypatch.setattr(os, "fsync", real)
    assert list(tmp_path.iterdir()) == []


def test_exr_writer_on_a_full_disk_is_one_line_and_leaves_nothing(tmp_path):
    """RLIMIT_FSIZE makes every write past 4 KB fail with EFBIG, as a full disk fails with ENOSPC."""
    code = ("import resource, signal, sys, numpy as np\nfrom skinviewer.ground import files\n"
            "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))\n"
            "try:\n    files.save_exr(sys.argv[1], np.random.default_rng(0).random((256, 256, 3)))\n"
            "except OSError as e:\n    print('ERR', e)\n")
    r = _in_child(code, str(tmp_path / "x.exr"))
    assert r.returncode == 0 and r.stdout.startswith("ERR cannot write") and "disk full" in r.stdout, \
        (r.stdout, r.stderr[-500:])
    assert r.stdout.count("\n") == 1 and list(tmp_path.iterdir()) == []


def test_exr_to_a_non_utf8_path_is_written(tmp_path):
    name = os.fsdecode(os.fsencode(str(tmp_path)) + b"/lin\xff.exr")
    a = np.random.default_rng(1).random((8, 8, 3)).astype(np.float32)
    files.save_exr(name, a)
    np.testing.assert_array_equal(files.load_exr(name), a)


# -- caches: an entry that does not validate is discarded and rebuilt, with a note -----------------

def _tiny_reference(**kw):
    from skinviewer.engine.reference import compute_reference
    s = small_settings("stretch-plane", "deon", size=16)
    return s, compute_reference(s, h_mm=2.0, **kw)


def _corrupt_truncated(p: Path):
    p.write_bytes(p.read_bytes()[:300])


def _corrupt_shapes(p: Path):
    with np.load(p) as z:
        d = {k: z[k] for k in z.files}
    d["lit"] = d["lit"][:5]
    np.savez(p, **d)


def _corrupt_nan(p: Path):
    with np.load(p) as z:
        d = {k: z[k] for k in z.files}
    d["diffuse"][0, 0, 0] = np.nan
    np.savez(p, **d)


def _corrupt_fifo(p: Path):
    p.unlink()
    os.mkfifo(p)


@pytest.mark.parametrize("corrupt", [_corrupt_truncated, _corrupt_shapes, _corrupt_nan, _corrupt_fifo])
def test_a_corrupt_reference_cache_entry_is_discarded_and_rebuilt(tmp_path, monkeypatch, corrupt):
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    _, first = _tiny_reference()
    (entry,) = (tmp_path / "reference").glob("*.npz")
    corrupt(entry)
    _, again = _tiny_reference()  # no BadZipFile / ValueError, no hang on the FIFO
    assert not again.meta.get("cached") and any("did not validate" in n for n in again.meta["notes"])
    np.testing.assert_allclose(again.lit, first.lit, rtol=1e-6)
    _, third = _tiny_reference()  # rebuilt: a valid entry again
    assert third.meta.get("cached") and not third.meta.get("notes")


def test_cache_variable_naming_a_file_says_so(tmp_path, monkeypatch, capsys):
    f = tmp_path / "not-a-folder"
    f.write_text("x")
    monkeypatch.setenv("SKINVIEWER_CACHE", str(f))
    assert _cli(["reference", "--scene", "stretch-plane", "--size", "16x16", "--h", "2",
                 "--out", str(tmp_path / "r.png")]) == 2
    err = _one_line_error(capsys)
    assert "SKINVIEWER_CACHE" in err and "is a file" in err and "Errno" not in err, err


# -- shaders read only from the shader root ---------------------------------------------------------

@pytest.mark.parametrize("case", ["relative", "absolute", "symlink", "vertex_stage", "symlinked_stage"])
def test_shaders_never_read_outside_their_root(gl_ctx, tmp_path, case):
    from skinviewer.kernel.shaders import ShaderCompileError
    root = tmp_path / "shaders"
    (root / "lib").mkdir(parents=True)
    (root / "lib" / "a.glsl").write_text(LIB_A)
    secret = tmp_path / "secret.glsl"
    secret.write_text("float f(float x) { return x; }\n")  # would compile: only the rule refuses it
    (tmp_path / "x.vert").write_text(VERT.replace('#include "lib/a.glsl"', "float f(float x) { return x; }"))
    frag = FRAG
    vert = VERT
    if case == "relative":
        vert = VERT.replace("lib/a.glsl", "../secret.glsl")
    elif case == "absolute":
        vert = VERT.replace("lib/a.glsl", str(secret))
    elif case == "symlink":
        (root / "lib" / "link.glsl").symlink_to(secret)
        vert = VERT.replace("lib/a.glsl", "lib/link.glsl")
    elif case == "vertex_stage":
        frag = '#version 330 core\n#pragma vertex_stage "../x.vert"\nout vec4 c;\nvoid main() { c = vec4(1.0); }\n'
    if case != "vertex_stage":
        (root / "p.vert").write_text(vert)
    if case == "symlinked_stage":
        (root / "p.vert").unlink()
        (root / "p.vert").symlink_to(tmp_path / "x.vert")
    (root / "p.frag").write_text(frag)
    lib = ShaderLibrary(gl_ctx, root)
    with pytest.raises(ShaderCompileError) as exc:
        lib.get("p")
    assert "outside the shader folder" in str(exc.value), str(exc.value)
    watched = set(lib._entry("p", None).mtimes)
    assert not any(tmp_path / n in watched or (tmp_path / n).resolve() in watched
                   for n in ("secret.glsl", "x.vert")), watched


def test_a_fifo_among_the_shaders_does_not_hang(tmp_path):
    root = tmp_path / "shaders"
    (root / "lib").mkdir(parents=True)
    os.mkfifo(root / "lib" / "a.glsl")
    (root / "p.vert").write_text(VERT)
    (root / "p.frag").write_text(FRAG)
    code = ("import sys\nfrom skinviewer.kernel.gl import headless_context\nfrom skinviewer.kernel.shaders import "
            "ShaderLibrary, ShaderCompileError\nlib = ShaderLibrary(headless_context(), sys.argv[1])\n"
            "try:\n    lib.get('p')\nexcept ShaderCompileError as e:\n    print(e)\n")
    r = _in_child(code, str(root))
    assert r.returncode == 0 and "FIFO" in r.stdout, (r.stdout, r.stderr[-500:])


# -- a NaN from an edited shader is flagged in the pass that made it -------------------------------

@pytest.mark.parametrize("technique,lib", [("deon", "deon_irradiance.glsl"), ("gosselin", "light_map.glsl")])
def test_nan_from_an_edited_texture_space_shader_is_flagged(tmp_path, monkeypatch, technique, lib):
    """A NaN made at runtime (sqrt of a negative uniform expression) in a user edit: before, the
    gutter fill replaced it by 0 (the skin darkened) and no pass was flagged."""
    import shutil

    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    root = tmp_path / "shaders"
    shutil.copytree(ROOT / "shaders", root)
    p = root / "lib" / lib
    text = p.read_text()
    anchor = "    vec3 E = vec3(0.0);\n"
    assert anchor in text
    poison = "    E = vec3(sqrt(-1.0 - abs(v_uv.x)));\n"  # NaN at run time, which no compiler can fold away
    p.write_text(text.replace(anchor, anchor + poison, 1))
    monkeypatch.setenv("SKINVIEWER_SHADERS", str(root))
    ctx = headless_context()
    r = Renderer(ctx)
    try:
        s = small_settings("head", technique, size=32)
        report = r.render(s)
        flagged = report.nonfinite
        first = {"deon": "deon_irradiance", "gosselin": "gosselin_light_map"}[technique]
        assert first in flagged, flagged  # the pass that made the NaN, by name
        lit = r.read(s, "lit")
        assert np.isfinite(lit).all()  # the blurs after it still keep the screen finite
    finally:
        r.release()
        ctx.release()


# -- beyond the list: environment variables, the bench's files, imports, the soak's schedule -------

@pytest.mark.parametrize("value", ["abc", "inf", "nan", "-1G", "0", "1e999"])
def test_memory_limit_variable_that_is_not_a_size_is_one_line(monkeypatch, capsys, tmp_path, value):
    monkeypatch.setenv("SKINVIEWER_MEMORY_LIMIT", value)
    assert _cli(["render", "--scene", "stretch-plane", "--size", "16x16", "--out", tmp_path / "x.png"]) == 2
    err = _one_line_error(capsys)
    assert "SKINVIEWER_MEMORY_LIMIT" in err, err
    assert list(tmp_path.iterdir()) == []


def test_memory_limit_units_include_a_trailing_b(monkeypatch):
    from skinviewer.engine.renderer import _env_bytes
    monkeypatch.setenv("SKINVIEWER_MEMORY_LIMIT", "2GB")
    assert _env_bytes("SKINVIEWER_MEMORY_LIMIT") == 2 * 2**30  # was 2 bytes


def test_shader_folder_variable_that_is_not_a_folder_says_so(monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("SKINVIEWER_SHADERS", str(tmp_path / "nowhere"))
    assert _cli(["render", "--scene", "stretch-plane", "--size", "16x16", "--out", tmp_path / "x.png"]) == 2
    err = _one_line_error(capsys)
    assert "SKINVIEWER_SHADERS" in err and "not a folder" in err, err


def test_last_bench_pointer_and_results_that_are_special_files_do_not_hang(tmp_path):
    """The viewer's accuracy window reads cache/last_bench.txt and the results.json it names at start."""
    (tmp_path / "cache").mkdir()
    os.mkfifo(tmp_path / "cache" / "last_bench.txt")
    os.mkfifo(tmp_path / "results.json")
    code = ("import os, sys\nos.environ['SKINVIEWER_CACHE'] = sys.argv[1]\n"
            "from skinviewer.engine.bench import last_bench, load_results\nprint(repr(last_bench()))\n"
            "try:\n    load_results(sys.argv[2])\nexcept OSError as e:\n    print(e)\n")
    r = _in_child(code, str(tmp_path / "cache"), str(tmp_path / "results.json"))
    assert r.returncode == 0 and r.stdout.startswith("''") and "FIFO" in r.stdout, (r.stdout, r.stderr[-500:])


@pytest.mark.parametrize("text", ["[1, 2]", '{"results": 5}', '{"results": [1]}', "[" * 100000, '"x"'])
def test_bench_results_that_are_not_results_are_a_value_error(tmp_path, text):
    from skinviewer.engine.bench import load_results
    p = tmp_path / "results.json"
    p.write_text(text)
    with pytest.raises(ValueError):
        load_results(p)


def _import_err(capsys, tmp_path, name, text) -> str:
    p = tmp_path / name
    p.write_text(text)
    assert _cli(["import", p]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("name,text", [
    ("deep.json", '{"a":' + "[" * 50000 + "]" * 50000 + "}"),
    ("deep.asset", "%YAML 1.1\n%TAG !u! tag:unity3d.com,2011:\n--- !u!114 &1\nMonoBehaviour:\n  a: "
     + "[" * 20000 + "]" * 20000 + "\n"),
    ("deep.py", "VALUES = " + "[" * 50000 + "]" * 50000 + "\n"),
])
def test_imports_nested_thousands_deep_are_one_line(tmp_path, capsys, name, text):
    assert "nested" in _import_err(capsys, tmp_path, name, text)


def test_materialx_import_never_follows_xinclude(tmp_path, capsys):
    secret = tmp_path / "secret.mtlx"
    secret.write_text('<?xml version="1.0"?>\n<materialx version="1.38"><standard_surface name="leak" '
                      'type="surfaceshader"><input name="subsurface" type="float" value="1"/></standard_surface>'
                      "</materialx>\n")
    for href in (str(secret), "/etc/passwd", "missing.mtlx"):
        err = _import_err(capsys, tmp_path, "inc.mtlx", '<?xml version="1.0"?>\n<materialx version="1.38" '
                          f'xmlns:xi="http://www.w3.org/2001/XInclude">\n  <xi:include href="{href}" />\n</materialx>\n')
        assert "leak" not in err and "passwd" not in err and "no nodes" in err, err


def test_import_of_a_fifo_or_a_device_does_not_hang(tmp_path):
    os.mkfifo(tmp_path / "p.asset")
    code = "import sys\nfrom skinviewer.cli import main\nsys.exit(main(['import', sys.argv[1]]))\n"
    for target in (tmp_path / "p.asset", Path("/dev/zero")):
        r = _in_child(code, str(target))
        assert r.returncode == 2 and "regular file" in r.stderr and "Traceback" not in r.stderr, r.stderr[-500:]


def test_soak_measures_drift_at_its_defaults():
    """benchmarks/soak.py at its defaults: every technique warms up, then runs again, and the drift
    is measured over as many frames as the warm-up (it was "over 0 frames" with 8 techniques)."""
    import importlib.util

    from skinviewer import techniques
    spec = importlib.util.spec_from_file_location("soak", ROOT / "benchmarks" / "soak.py")
    soak = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(soak)
    frames = 3000
    assert f'"--frames", type=int, default={frames}' in (ROOT / "benchmarks" / "soak.py").read_text()
    per, warm = soak.schedule(frames, len(techniques.names()))
    assert warm == per * len(techniques.names()) and frames - warm >= warm > 0
    with pytest.raises(SystemExit):
        soak.schedule(len(techniques.names()), len(techniques.names()))


@pytest.mark.parametrize("damage", ["truncate", "fifo"])
def test_a_damaged_head_cache_is_regenerated_with_a_note(tmp_path, damage):
    from skinviewer.scene.head import _cache_path, default_head
    first = default_head(detail=0, cache_dir=tmp_path)
    entry = _cache_path(0, 7, tmp_path)
    assert not first.notes and entry.is_file()
    if damage == "truncate":
        entry.write_bytes(entry.read_bytes()[:1000])
    else:
        entry.unlink()
        os.mkfifo(entry)
    again = default_head(detail=0, cache_dir=tmp_path)
    assert any("did not validate" in n for n in again.notes), again.notes
    np.testing.assert_array_equal(again.positions, first.positions)
    assert not default_head(detail=0, cache_dir=tmp_path).notes  # rebuilt


def test_a_shader_library_reads_its_include_roots_and_nothing_beyond(gl_ctx, tmp_path):
    # a test's programs in a temporary folder may include the product's lib/ (include_roots); the
    # confinement still holds for anything else
    from skinviewer.ground import paths
    from skinviewer.kernel.shaders import ShaderCompileError, ShaderLibrary
    (tmp_path / "a.frag").write_text('#version 330 core\n#pragma vertex_stage "vs/fullscreen.vert"\n'
                                    '#include "lib/color.glsl"\nout vec4 f;\nvoid main() { f = vec4(0.0); }\n')
    (tmp_path / "vs").symlink_to(paths.shaders_dir() / "vs", target_is_directory=True)
    (tmp_path / "lib").symlink_to(paths.shaders_dir() / "lib", target_is_directory=True)
    with pytest.raises(ShaderCompileError, match="outside the shader folder"):
        ShaderLibrary(gl_ctx, tmp_path).get("a")
    assert ShaderLibrary(gl_ctx, tmp_path, include_roots=(paths.shaders_dir(),)).get("a") is not None
    (tmp_path / "b.frag").write_text('#version 330 core\n#include "/etc/hostname"\nout vec4 f;\nvoid main() { f = vec4(0.0); }\n')
    with pytest.raises(ShaderCompileError, match="outside the shader folder"):
        ShaderLibrary(gl_ctx, tmp_path, include_roots=(paths.shaders_dir(),)).get("b")
