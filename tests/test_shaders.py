"""Shader library: #include, error records with file and line, reload, last good program kept."""
from __future__ import annotations

import time

import pytest

from skinviewer.kernel.shaders import ShaderCompileError, ShaderLibrary

VERT = '#version 330 core\n#include "lib/common.glsl"\nin vec2 in_pos;\nvoid main() { gl_Position = vec4(in_pos, 0.0, 1.0); }\n'
FRAG = '#version 330 core\n#include "lib/common.glsl"\nout vec4 f;\nvoid main() { f = vec4(twice(0.5)); }\n'
LIB = "// shared snippet\nfloat twice(float x) { return 2.0 * x; }\n"


@pytest.fixture
def lib_dir(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "common.glsl").write_text(LIB)
    (tmp_path / "prog.vert").write_text(VERT)
    (tmp_path / "prog.frag").write_text(FRAG)
    return tmp_path


def _touch_later(path, text):
    time.sleep(0.01)
    path.write_text(text)


def test_include_and_compile(gl_ctx, lib_dir):
    lib = ShaderLibrary(gl_ctx, lib_dir)
    prog = lib.get("prog")
    assert "in_pos" in prog
    assert lib.errors() == {}


def test_error_in_included_file_reports_file_and_line(gl_ctx, lib_dir):
    lib = ShaderLibrary(gl_ctx, lib_dir)
    good = lib.get("prog")
    _touch_later(lib_dir / "lib" / "common.glsl", "// shared snippet\nfloat twice(float x) { return 2.0 * y; }\n")
    replaced, errors = lib.reload()
    assert replaced == []
    errs = errors["prog"]
    assert any(e.file == "lib/common.glsl" and e.line == 2 for e in errs), errs
    assert lib.get("prog") is good  # the last good program keeps running
    _touch_later(lib_dir / "lib" / "common.glsl", LIB.replace("2.0 * x", "3.0 * x"))
    replaced, errors = lib.reload()
    assert replaced == ["prog"] and errors == {}
    assert lib.get("prog") is not good


def test_error_in_main_file_line(gl_ctx, lib_dir):
    (lib_dir / "bad.vert").write_text(VERT)
    (lib_dir / "bad.frag").write_text('#version 330 core\nout vec4 f;\n\nvoid main() { f = vec4(undefined_thing); }\n')
    lib = ShaderLibrary(gl_ctx, lib_dir)
    with pytest.raises(ShaderCompileError) as exc:
        lib.get("bad")
    assert any(e.file == "bad.frag" and e.line == 4 for e in exc.value.errors), exc.value.errors


def test_missing_include_and_missing_files(gl_ctx, lib_dir):
    (lib_dir / "noinc.vert").write_text(VERT)
    (lib_dir / "noinc.frag").write_text('#version 330 core\n#include "lib/nope.glsl"\nout vec4 f;\nvoid main() { f = vec4(1.0); }\n')
    lib = ShaderLibrary(gl_ctx, lib_dir)
    with pytest.raises(ShaderCompileError) as exc:
        lib.get("noinc")
    assert exc.value.errors[0].file == "noinc.frag" and exc.value.errors[0].line == 2
    with pytest.raises(ShaderCompileError, match="not found"):
        lib.get("does_not_exist")


def test_defines_and_versions(gl_ctx, lib_dir):
    (lib_dir / "def.vert").write_text(VERT)
    (lib_dir / "def.frag").write_text('#version 330 core\nout vec4 f;\nvoid main() { f = vec4(VALUE); }\n')
    lib = ShaderLibrary(gl_ctx, lib_dir)
    a = lib.get("def", {"VALUE": "1.0"})
    b = lib.get("def", {"VALUE": "2.0"})
    assert a is not b
    assert lib.version("def", {"VALUE": "1.0"}) != lib.version("def", {"VALUE": "2.0"})


def test_project_shaders_all_compile(gl_ctx):
    """Every program in shaders/ compiles, generic and specialised to several light setups
    (catches a broken edit before the viewer does)."""
    from skinviewer.ground import paths
    lib = ShaderLibrary(gl_ctx)
    names = sorted({p.stem for p in paths.shaders_dir().glob("*.frag")})
    assert names
    failures = {}
    variants = [None, {"LIGHT_COUNT": 0, "SHADOW_PCF": 0, "SHADOW_MASK": 0, "POINT_MASK": 0, "BEAM_MASK": 0},
                {"LIGHT_COUNT": 4, "SHADOW_PCF": 3, "SHADOW_MASK": 0b1011, "POINT_MASK": 0b0100, "BEAM_MASK": 0b0010}]
    for n in names:
        lit = "lib/lights.glsl" in (paths.shaders_dir() / f"{n}.frag").read_text()
        for defines in variants if lit else variants[:1]:
            try:
                lib.get(n, defines)
            except ShaderCompileError as exc:
                failures[f"{n}{defines or ''}"] = [str(e) for e in exc.errors]
    lib.release()
    assert not failures, failures


def test_shared_vertex_stage_named_by_pragma_and_hot_reloaded(gl_ctx, lib_dir):
    (lib_dir / "vs").mkdir()
    (lib_dir / "vs" / "shared.vert").write_text(VERT)
    for name, value in (("one", "1.0"), ("two", "2.0")):
        (lib_dir / f"{name}.frag").write_text(f'#version 330 core\n#pragma vertex_stage "vs/shared.vert"\n'
                                              f'out vec4 f;\nvoid main() {{ f = vec4({value}); }}\n')
    lib = ShaderLibrary(gl_ctx, lib_dir)
    one, two = lib.get("one"), lib.get("two")
    assert "in_pos" in one and "in_pos" in two
    _touch_later(lib_dir / "vs" / "shared.vert", VERT.replace("in_pos, 0.0", "in_pos * 0.5, 0.0"))
    replaced, errors = lib.reload()
    assert sorted(replaced) == ["one", "two"] and errors == {}  # an edit reaches every user
    (lib_dir / "three.frag").write_text('#version 330 core\n#pragma vertex_stage "vs/missing.vert"\n'
                                        'out vec4 f;\nvoid main() { f = vec4(1.0); }\n')
    with pytest.raises(ShaderCompileError, match="vs/missing.vert not found"):
        lib.get("three")
    (lib_dir / "bad.frag").write_text('#version 330 core\n#pragma vertex_stage "vs/shared.vert"\nout vec4 f;\n'
                                      'void main() { f = vec4(nope); }\n')
    with pytest.raises(ShaderCompileError) as exc:
        lib.get("bad")
    assert any(e.file == "bad.frag" and e.line == 4 for e in exc.value.errors), exc.value.errors
    (lib_dir / "enc.frag").write_bytes(b'#version 330 core\n#pragma vertex_stage "vs/shared.vert"\n// caf\xe9\n')
    with pytest.raises(ShaderCompileError, match="UTF-8"):  # not "vertex stage not found"
        lib.get("enc")


def test_shared_constants_are_injected_and_declared_uniforms_known(gl_ctx, lib_dir):
    from skinviewer.ground.constants import MAX_GAUSSIANS
    (lib_dir / "c.frag").write_text('#version 330 core\n#pragma vertex_stage "prog.vert"\n'
                                    "uniform float u_w[MAX_GAUSSIANS];\nuniform int u_k, u_unused[MAX_LIGHTS];\n"
                                    "out vec4 f;\nvoid main() { f = vec4(float(MAX_LIGHTS) + u_w[MAX_GAUSSIANS - 1]"
                                    " + float(u_k) + HALF_MAX + float(LIGHT_POINT)); }\n")
    lib = ShaderLibrary(gl_ctx, lib_dir)
    prog = lib.get("c")
    assert prog["u_w"].array_length == MAX_GAUSSIANS
    name, declared = lib.describe(prog)
    assert name == "c" and {"u_w", "u_k", "u_unused"} <= declared and "u_unused" not in prog


def test_project_shaders_are_consolidated():
    """Shared vertex stages (no two .vert files with one body), include guards in every lib
    snippet, no copy of a constant that skinviewer.ground.constants injects, no line continuation."""
    import re

    from skinviewer.ground import paths
    from skinviewer.ground.constants import GLSL_DEFINES
    root = paths.shaders_dir()
    bodies = {}
    for v in root.rglob("*.vert"):
        body = "\n".join(ln for ln in v.read_text().splitlines() if not ln.lstrip().startswith("//"))
        assert body not in bodies, f"{v.name} repeats {bodies.get(body)}"
        bodies[body] = v.name
    for f in (root / "lib").glob("*.glsl"):
        text = f.read_text()
        m = re.search(r"^#ifndef (\w+)\s*\n#define (\w+)", text, re.M)
        assert m and m.group(1) == m.group(2) and text.rstrip().endswith("#endif"), f"{f.name}: no include guard"
    for f in list(root.rglob("*.glsl")) + list(root.rglob("*.frag")) + list(root.rglob("*.vert")):
        text = f.read_text()
        for name in GLSL_DEFINES:
            assert not re.search(rf"#define\s+{name}\b", text), f"{f.name} redefines {name}"
        assert not re.search(r"\b65000\.0|\b1e30\b", text), f"{f.name} writes a clamp constant by value"
        # GLSL 3.30 has no line continuation (4.20 added it): Mesa and NVIDIA read one, a strict compiler not
        assert not re.search(r"\\\n", text), f"{f.name} continues a line with a backslash"


def test_file_in_another_encoding_is_a_shader_error(gl_ctx, lib_dir):
    lib = ShaderLibrary(gl_ctx, lib_dir)
    good = lib.get("prog")
    _touch_later(lib_dir / "lib" / "common.glsl", "")
    (lib_dir / "lib" / "common.glsl").write_bytes(b"// caf\xe9\nfloat twice(float x) { return 2.0 * x; }\n")
    replaced, errors = lib.reload()
    assert replaced == [] and lib.get("prog") is good
    assert any(e.file == "lib/common.glsl" and e.line == 1 and "UTF-8" in e.message for e in errors["prog"])


def test_no_assembled_source_ends_with_a_line_directive(gl_ctx, lib_dir):
    """An include on a file's last line leaves no #line after it: NVIDIA's compiler refuses a #line that
    ends the source (C0115 "#line source-string number invalid": every d'Eon program on the H200 once),
    while the line numbers of what follows an include elsewhere still map to their files."""
    from skinviewer.ground import paths
    (lib_dir / "tail.vert").write_text(VERT)
    (lib_dir / "tail.frag").write_text('#version 330 core\nout vec4 f;\nvoid main() { f = vec4(twice(0.5)); }\n'
                                       '#include "lib/common.glsl"\n\n')
    (lib_dir / "lib" / "common.glsl").write_text(LIB + '#include "lib/leaf.glsl"\n')
    (lib_dir / "lib" / "leaf.glsl").write_text("// leaf\n")
    lib = ShaderLibrary(gl_ctx, lib_dir)
    for name in ("tail", "prog"):
        sources, _ = lib._assemble(name, ())
        for src in sources.values():
            last = [ln for ln in src.splitlines() if ln.strip()][-1]
            assert not last.startswith("#line"), (name, last)
    assert "#line 3 0" in lib._assemble("prog", ())[0]["fragment_shader"]  # after a mid-file include
    lib.release()
    project = ShaderLibrary(gl_ctx)
    for p in sorted(paths.shaders_dir().glob("*.frag")):
        sources, _ = project._assemble(p.stem, ())
        for src in sources.values():
            last = [ln for ln in src.splitlines() if ln.strip()][-1]
            assert not last.startswith("#line"), (p.name, last)
    project.release()


def test_included_extension_moves_after_version(gl_ctx, lib_dir):
    """An included file's #extension (lib/lights.glsl's GL_ARB_texture_gather) goes right after #version,
    where GLSL wants it (Mesa refuses one after code: 'not allowed in the middle of a shader'); its own
    line stays a comment, so an error in the file still reports its line."""
    gather = ("// shared snippet\nfloat twice(float x) { return 2.0 * x; }\n"
              "#extension GL_ARB_texture_gather : enable\n"
              "#if defined(GL_ARB_texture_gather) || __VERSION__ >= 400\n"
              "float first(sampler2D s) { return textureGather(s, vec2(0.5)).w; }\n#endif\n")
    (lib_dir / "lib" / "common.glsl").write_text(gather)
    lib = ShaderLibrary(gl_ctx, lib_dir)
    assert "in_pos" in lib.get("prog")
    src = lib._assemble("prog", ())[0]["fragment_shader"].splitlines()
    assert src[0].startswith("#version") and src[1] == "#extension GL_ARB_texture_gather : enable"
    assert sum(ln.lstrip().startswith("#extension") for ln in src) == 1
    _touch_later(lib_dir / "lib" / "common.glsl", gather.replace("textureGather(s, vec2(0.5)).w", "undefined_thing"))
    _, errors = lib.reload()
    assert any(e.file == "lib/common.glsl" and e.line == 5 for e in errors["prog"]), errors
