"""Issue 28, "plan once": reflect records what it decided (``Reflection.plan``), the graph keeps it
with the reflection, keys the pass's cache on it and hands it to execute as ``ec.plan`` (read-only);
a converted pass module never takes a planning decision again in execute (an AST check)."""
from __future__ import annotations

import ast
import collections
from pathlib import Path

import numpy as np
import pytest
from test_graph import FS_VERT, frame  # noqa: F401  (the fixtures' shaders)

from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.graph import GraphError, Pass, Reflection, RenderGraph, TexSpec
from skinviewer.kernel.pass_api import Plan
from skinviewer.kernel.shaders import ShaderLibrary

PASSES = Path(__file__).resolve().parents[1] / "skinviewer" / "passes"


@pytest.fixture
def shader_dir(tmp_path):
    (tmp_path / "fill.vert").write_text(FS_VERT)
    (tmp_path / "fill.frag").write_text("#version 330 core\nuniform float u_value;\nout vec4 f;\n"
                                        "void main() { f = vec4(u_value); }\n")
    return tmp_path


class Planned(Pass):
    """Fills its output with a value decided in reflect from a peeked (undeclared) setting."""
    name = "planned"
    uses_scene = False

    def __init__(self):
        self.seen: list[Plan] = []

    def reflect(self, r: Reflection) -> None:
        side = 4
        r.plan(side=side, value=1.0 if r.peek("phong.ambient") < 0.5 else 2.0)  # from a peek: not declared
        r.program("fill")
        r.output("out", TexSpec((side, side), 4, "f4"))

    def execute(self, ec) -> None:
        self.seen.append(ec.plan)
        prog = ec.program("fill")
        ec.set(prog, "u_value", ec.plan.value)
        ec.draw_fullscreen(prog, "out")


def test_execute_reads_what_reflect_planned_and_the_cache_is_keyed_on_it(gl_ctx, shader_dir):
    p = Planned()
    g = RenderGraph(gl_ctx, ShaderLibrary(gl_ctx, shader_dir), [p], ["out"])
    s = with_values(Settings(), {"phong.ambient": 0.1})
    assert g.run(frame(s)).ran == ["planned"]
    assert dict(p.seen[-1]) == {"side": 4, "value": 1.0}
    assert np.allclose(g.read("out"), 1.0) and g.read("out").shape[:2] == (4, 4)
    assert g.run(frame(s)).ran == []  # same plan: cached
    rep = g.run(frame(with_values(s, {"phong.ambient": 0.9})))  # the peek is not declared: the plan reruns it
    assert rep.ran == ["planned"]
    assert next(r.reason for r in rep.passes if r.name == "planned") == "plan value"
    assert np.allclose(g.read("out"), 2.0)


def test_a_plan_is_read_only_and_decided_once():
    r = Reflection(Settings())
    r.plan(size=(4, 4))
    r.plan(size=(4, 4))  # the same decision again is allowed
    with pytest.raises(GraphError, match="decided twice"):
        r.plan(size=(8, 8))
    plan = r.planned
    with pytest.raises(AttributeError, match="read-only"):
        plan.size = (8, 8)  # type: ignore[misc]
    with pytest.raises(AttributeError, match="reflect planned"):
        plan.missing  # noqa: B018
    with pytest.raises(TypeError):
        plan["size"] = 1  # type: ignore[index]
    assert plan["size"] == plan.size == (4, 4) and list(plan) == ["size"]


# -- plan once: no decision taken in both reflect and execute -------------------------------------
# names that are not planning decisions (builtins, and the settings reads each side declares/reads)
NOT_DECISIONS = {"setting", "section", "program", "len", "int", "float", "range", "tuple", "get", "enumerate",
                 "max", "min", "bool", "set", "list", "str", "isinstance", "zip", "sum", "any", "all", "sorted",
                 "dict", "abs", "round"}
# the pass modules converted to plan once: none of their passes may call a helper in both reflect and
# execute. This list only grows.
CONVERTED = [
    "screen_space/blur.py", "screen_space/jimenez2009.py", "screen_space/lighting.py", "screen_space/separable.py",
    "screen_space/combine.py", "burley.py", "gosselin.py", "shadow_map.py", "output.py", "environment.py", "luts.py", "rho_dt.py", "penner.py", "texture_space.py", "deon.py",
]
# the helpers called in both reflect and execute over every pass module (twice.py's reading less the
# kernel API's own calls on r / ec; 38 names by twice.py before issue 28's plan): may only shrink
MAX_TWICE = 38


def decided_twice(path: Path) -> dict[str, set[str]]:
    """Pass class -> the names its reflect and its execute both call (twice.py's reading)."""
    tree = ast.parse(path.read_text())
    out = {}
    for cls in (n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)):
        meths = {m.name: m for m in cls.body if isinstance(m, ast.FunctionDef)}
        if "reflect" not in meths or "execute" not in meths:
            continue

        def calls(fn):
            ctx = fn.args.args[1].arg if len(fn.args.args) > 1 else None  # r / ec: the kernel's API
            names = set()
            for n in ast.walk(fn):
                if isinstance(n, ast.Call):
                    f = n.func
                    if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == ctx:
                        continue  # r.output(...) declares, ec.output(...) uses: not a decision
                    name = f.id if isinstance(f, ast.Name) else (f.attr if isinstance(f, ast.Attribute) else None)
                    if name:
                        names.add(name)
            return names
        both = (calls(meths["reflect"]) & calls(meths["execute"])) - NOT_DECISIONS
        if both:
            out[cls.name] = both
    return out


def test_the_check_sees_a_decision_taken_twice(tmp_path):
    f = tmp_path / "p.py"
    f.write_text("class P:\n    def reflect(self, r):\n        r.output('x', size_of(r))\n"
                 "    def execute(self, ec):\n        ec.draw(size_of(ec))\n")
    assert decided_twice(f) == {"P": {"size_of"}}
    f.write_text("class P:\n    def reflect(self, r):\n        r.plan(size=size_of(r))\n"
                 "    def execute(self, ec):\n        ec.draw(ec.plan.size)\n")
    assert decided_twice(f) == {}


@pytest.mark.parametrize("module", CONVERTED)
def test_a_converted_pass_module_plans_once(module):
    assert decided_twice(PASSES / module) == {}, f"{module}: execute takes again a decision reflect took"


def test_decisions_taken_twice_only_go_down():
    total = collections.Counter()
    for f in sorted(PASSES.rglob("*.py")):
        for names in decided_twice(f).values():
            total.update(names)
    assert len(total) <= MAX_TWICE, sorted(total)
