"""Shader library: #include, error records with file and line, reload, last good program kept."""
from __future__ import annotations

import time

import pytest

from skinviewer.core.shaders import ShaderCompileError, ShaderLibrary

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
    """Every program in shaders/ compiles (catches a broken edit before the viewer does)."""
    from skinviewer.core import paths
    lib = ShaderLibrary(gl_ctx)
    names = sorted({p.stem for p in paths.shaders_dir().glob("*.frag")})
    assert names
    failures = {}
    for n in names:
        try:
            lib.get(n)
        except ShaderCompileError as exc:
            failures[n] = [str(e) for e in exc.errors]
    assert not failures, failures


def test_file_in_another_encoding_is_a_shader_error(gl_ctx, lib_dir):
    lib = ShaderLibrary(gl_ctx, lib_dir)
    good = lib.get("prog")
    _touch_later(lib_dir / "lib" / "common.glsl", "")
    (lib_dir / "lib" / "common.glsl").write_bytes(b"// caf\xe9\nfloat twice(float x) { return 2.0 * x; }\n")
    replaced, errors = lib.reload()
    assert replaced == [] and lib.get("prog") is good
    assert any(e.file == "lib/common.glsl" and e.line == 1 and "UTF-8" in e.message for e in errors["prog"])
