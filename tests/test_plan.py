"""Issue 28, "plan once": reflect records what it decided (``Reflection.plan``), the graph keeps it
with the reflection, keys the pass's cache on it and hands it to execute as ``ec.plan`` (read-only);
a converted pass module never takes a planning decision again in execute (an AST check)."""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from test_graph import frame

from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.graph import GraphError, Pass, Reflection, RenderGraph, TexSpec
from skinviewer.kernel.pass_api import Plan
from skinviewer.kernel.shaders import ShaderLibrary

PASSES = Path(__file__).resolve().parents[1] / "skinviewer" / "passes"


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
NOT_DECISIONS = {"setting", "section", "whole", "declare", "program", "len", "int", "float", "range", "tuple", "get", "enumerate",
                 "max", "min", "bool", "set", "list", "str", "isinstance", "zip", "sum", "any", "all", "sorted",
                 "dict", "abs", "round"}
# pass modules still allowed to take a decision in both reflect and execute: module -> {pass class:
# helper names}. Empty since issue 28 converted every pass module (twice.py counted 38 names over 27
# passes before); entries may only be removed.
EXCEPTIONS: dict[str, dict[str, set[str]]] = {}
MODULES = sorted(str(f.relative_to(PASSES)) for f in PASSES.rglob("*.py"))


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


def test_every_pass_module_is_checked():
    assert {"deon.py", "burley.py", "screen_space/lighting.py", "texture_space.py"} <= set(MODULES)
    assert set(EXCEPTIONS) <= set(MODULES), "an exception for a module that is gone: remove it"


@pytest.mark.parametrize("module", MODULES)
def test_a_pass_module_plans_once(module):
    """Execute reads ec.plan; a helper called in both reflect and execute takes the decision twice."""
    got = decided_twice(PASSES / module)
    allowed = EXCEPTIONS.get(module, {})
    extra = {cls: names - allowed.get(cls, set()) for cls, names in got.items()}
    assert not any(extra.values()), f"{module}: execute takes again a decision reflect took: {extra}"


# the helpers that take a planning decision (sizes, resources, lights, paths, program variants): reflect
# calls them and plans the result; no function of the execute side (one taking ``ec``: execute, set_*,
# bind_*, shade_dilated...) may call them again
PLANNING_HELPERS = {
    "texel_shading", "shading_program", "map_size", "coverage_size", "light_map_size", "tsm_light_index", "env_index",
    "env_defines", "shadow_map_size", "transmittance_slots", "gathered", "gather_used", "island_tiles", "_plan",
    "plan_of", "blur_spec", "screen_size", "kernel_under_pixel", "texture_shadows", "used_mask", "combined",
    "open_border", "_background_env", "gutter_spec", "transmitted_size", "stretch_defines", "table_defines", "_step",
    "_narrow", "_open_border", "_stretch_input", "gather_reach", "ring_sigma", "golubev_plan", "two_level_plan",
    "_burley_model", "_env_vis_defines", "focal_px", "gaussian_count",
}


def execute_side_calls(path: Path) -> list[tuple[str, int, str]]:
    """(function, line, helper) for each planning helper a function taking ``ec`` calls."""
    out = []
    for fn in ast.walk(ast.parse(path.read_text())):
        if isinstance(fn, ast.FunctionDef) and any(a.arg == "ec" for a in fn.args.args):
            for n in ast.walk(fn):
                if isinstance(n, ast.Call):
                    f = n.func
                    name = f.id if isinstance(f, ast.Name) else (f.attr if isinstance(f, ast.Attribute) else None)
                    if name in PLANNING_HELPERS:
                        out.append((fn.name, n.lineno, name))
    return out


def test_the_execute_side_check_sees_a_helper(tmp_path):
    f = tmp_path / "p.py"
    f.write_text("def bind_x(ec, prog):\n    ec.bind(prog, 'x', map_size(ec))\n")
    assert execute_side_calls(f) == [("bind_x", 2, "map_size")]


@pytest.mark.parametrize("module", MODULES)
def test_no_execute_side_function_decides_again(module):
    assert execute_side_calls(PASSES / module) == [], f"{module}: read ec.plan instead"
