"""Issue 28: passes read typed settings (``r.settings.deon.mix``), never a dotted path in a string.
Each attribute read through ``r.settings`` declares the same dotted path ``r.setting("deon.mix")``
declared, so the graph's cache keys, pruning and "what an edit re-runs" are what they were; an AST
check keeps string paths out of every pass module (with a planted violation it must see)."""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from test_graph import frame

from skinviewer.ground.settings import Settings, get_path, with_values
from skinviewer.kernel.graph import GraphError, Pass, Reflection, RenderGraph, TexSpec
from skinviewer.kernel.pass_api import declare, whole
from skinviewer.kernel.shaders import ShaderLibrary

PASSES = Path(__file__).resolve().parents[1] / "skinviewer" / "passes"
MODULES = sorted(str(f.relative_to(PASSES)) for f in PASSES.rglob("*.py"))
STRING_READS = {"setting", "peek", "section", "get_path", "value_key"}  # the kernel's string-path API
SECTIONS = set(Settings.model_fields)


def _names_a_setting(text: str) -> bool:
    """Whether ``text`` is a dotted settings path (``deon.mix``, ``lights.0.kind``, ``lights.{i}``)."""
    parts = text.split(".")
    if len(parts) < 2 or parts[0] not in SECTIONS or " " in text:
        return False
    try:
        get_path(Settings(), ".".join("0" if p.startswith("{") or p == "#" else p for p in parts))
    except (KeyError, IndexError, AttributeError, TypeError):
        return parts[1].startswith("{")  # lights.{i}.enabled
    return True


def string_reads(source: str) -> list[tuple[int, str]]:
    """(line, what) for each settings read by a string in ``source``: a call of the string API
    (``r.setting("deon.mix")``, ``ec.section(...)``, ``get_path(...)``) or a string constant, f-string
    included, that is a dotted settings path (``SIZE = "deon.irradiance_size"``)."""
    out = []
    for n in ast.walk(ast.parse(source)):
        if isinstance(n, ast.Call):
            f = n.func
            name = f.attr if isinstance(f, ast.Attribute) else (f.id if isinstance(f, ast.Name) else None)
            if name in STRING_READS:
                out.append((n.lineno, f"{name}(...)"))
        elif isinstance(n, ast.JoinedStr):
            text = "".join(v.value if isinstance(v, ast.Constant) else "{x}" for v in n.values)
            if _names_a_setting(text):
                out.append((n.lineno, text))
        elif isinstance(n, ast.Constant) and isinstance(n.value, str) and _names_a_setting(n.value):
            out.append((n.lineno, n.value))
    return out


def test_the_check_sees_a_string_read():
    planted = ("SIZE = 'deon.irradiance_size'\n"
               "def reflect(self, r):\n"
               "    r.setting('deon.mix')\n"
               "    r.peek(f'lights.{self.i}.enabled')\n"
               "    r.section('phong', ('ambient',))\n"
               "    r.skip('deon.tsm is off')\n"  # words, not a path: allowed
               "    declare(r.settings.deon.mix)\n")
    assert sorted(string_reads(planted)) == [(1, "deon.irradiance_size"), (3, "deon.mix"), (3, "setting(...)"),
                                             (4, "lights.{x}.enabled"), (4, "peek(...)"), (5, "section(...)")]


def test_every_pass_module_is_checked():
    assert {"deon.py", "burley.py", "screen_space/lighting.py", "rules.py", "common.py"} <= set(MODULES)


@pytest.mark.parametrize("module", MODULES)
def test_no_pass_module_reads_a_setting_by_a_string_path(module):
    found = string_reads((PASSES / module).read_text())
    assert not found, f"{module}: read r.settings.<section>.<field> instead of a string path: {found}"


# -- the typed reads declare exactly what the string reads declared --------------------------------

def test_attribute_reads_declare_the_dotted_paths():
    s = Settings()
    r = Reflection(s)
    assert r.settings.deon.mix == s.deon.mix
    assert len(r.settings.lights) == len(s.lights)
    assert r.settings.lights[1].kind == s.lights[1].kind
    assert [g.variance for g in r.settings.deon.gaussians] == [g.variance for g in s.deon.gaussians]
    assert whole(r.settings.lights[0]) is s.lights[0]
    assert r.settings.lights[:1] == s.lights[:1]
    assert r.settings.gosselin.regions is s.gosselin.regions  # a dict of sections is one value
    declare(r.settings.shadow.tol, r.settings.burley2)
    old = Reflection(s)
    for p in ("deon.mix", "lights.#", "lights.1.kind", "deon.gaussians", "lights.0", "lights", "gosselin.regions",
              "shadow.tol", "burley2"):
        old.setting(p)
    assert r.declared == old.declared


def test_peeked_reads_declare_nothing_and_sections_are_not_values():
    r = Reflection(Settings())
    assert r.peeked.deon.tsm_gather == 16 and len(r.peeked.lights) == 2 and whole(r.peeked.lights[0]).kind
    assert r.declared == []
    with pytest.raises(TypeError, match="whole"):
        bool(r.settings.deon)  # a section is not a value: `if r.settings.deon:` is a bug
    with pytest.raises(AttributeError, match="no field 'mixx'"):
        r.settings.deon.mixx  # noqa: B018
    with pytest.raises(IndexError):
        r.settings.lights[7]  # noqa: B018
    with pytest.raises(AttributeError, match="read-only"):
        r.settings.deon.mix = 1.0  # type: ignore[misc]
    assert r.declared == []


class Typed(Pass):
    """Fills its output with phong.ambient (+ the first light's intensity), read by attribute."""
    name = "typed"
    uses_scene = False

    def __init__(self, undeclared: bool = False):
        self.undeclared = undeclared

    def reflect(self, r: Reflection) -> None:
        declare(r.settings.phong.ambient, r.settings.lights[0].intensity)
        r.program("fill")
        r.output("out", TexSpec((4, 4), 4, "f4"))

    def execute(self, ec) -> None:
        prog = ec.program("fill")
        s = ec.settings
        if self.undeclared:
            s.phong.shininess  # noqa: B018
        ec.set(prog, "u_value", float(s.phong.ambient + s.lights[0].intensity))
        ec.draw_fullscreen(prog, "out")


def test_the_graph_keys_the_cache_on_attribute_reads(gl_ctx, shader_dir):
    g = RenderGraph(gl_ctx, ShaderLibrary(gl_ctx, shader_dir), [Typed()], ["out"])
    s = with_values(Settings(), {"phong.ambient": 0.25, "lights.0.intensity": 1.0})
    assert g.run(frame(s)).ran == ["typed"] and np.allclose(g.read("out"), 1.25)
    assert g.run(frame(with_values(s, {"phong.shininess": 8.0, "lights.0.color": [1, 0, 0]}))).ran == []
    rep = g.run(frame(with_values(s, {"lights.0.intensity": 2.0})))
    assert rep.ran == ["typed"] and rep.passes[0].reason == "setting lights.0.intensity"
    assert np.allclose(g.read("out"), 2.25)
    assert g.affected(["phong.ambient"]) == ["typed"] and g.affected(["phong.shininess"]) == []


def test_execute_may_read_only_what_reflect_declared(gl_ctx, shader_dir):
    g = RenderGraph(gl_ctx, ShaderLibrary(gl_ctx, shader_dir), [Typed(undeclared=True)], ["out"])
    with pytest.raises(GraphError, match="phong.shininess"):
        g.run(frame(Settings()))
