"""The layout is the architecture: no import cycles between modules (not even through imports
inside functions), and the layers only import downwards (core and physics never import the UI).
Imports under ``if TYPE_CHECKING:`` (annotations only, never run) count for the layers but not as
cycles: ``Pass.execute(ec: ExecuteContext)`` names the context the graph hands it."""
from __future__ import annotations

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "skinviewer"

# layer -> the layers it may import (besides itself)
ALLOWED = {
    "core": {"core", "physics", "scene", "techniques", "passes"},  # the renderer builds technique graphs
    "physics": {"physics"},
    "scene": {"scene", "core", "physics"},
    "passes": {"passes", "core", "physics", "scene"},
    "techniques": {"techniques", "passes", "core", "physics", "scene"},
    "ui": {"ui", "core", "physics", "scene", "passes", "techniques"},  # the command line parses; the viewer gets Settings
    "cli": {"cli", "core", "physics", "scene", "passes", "techniques", "ui"},
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _type_only(tree: ast.AST) -> set[int]:
    """ids of the nodes inside ``if TYPE_CHECKING:`` blocks."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            out.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    return out


def _imports(runtime_only: bool = False) -> dict[str, set[str]]:
    mods = {_module_name(p): p for p in PKG.rglob("*.py") if "__pycache__" not in p.parts}
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for mod, path in mods.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        skip = _type_only(tree) if runtime_only else set()
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            targets = []
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            for t in targets:
                if t in mods and t != mod:
                    graph[mod].add(t)
    return graph


def test_no_relative_imports():
    for p in PKG.rglob("*.py"):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            assert not (isinstance(node, ast.ImportFrom) and node.level), f"{p}: use absolute imports"


def test_type_only_imports_are_told_apart():
    """The pass API names the execute context for its annotations only: a layer edge, not a cycle."""
    assert "skinviewer.kernel.execute" in _imports()["skinviewer.kernel.pass_api"]
    assert "skinviewer.kernel.execute" not in _imports(runtime_only=True)["skinviewer.kernel.pass_api"]
    assert "skinviewer.kernel.pass_api" in _imports(runtime_only=True)["skinviewer.kernel.execute"]


def test_no_import_cycles():
    graph = _imports(runtime_only=True)
    # packages import their own submodules in __init__; a submodule importing its own package's
    # __init__ is not a cycle of logic, so edges into a package from inside it are left out
    def deps(m):
        return {d for d in graph[m] if not m.startswith(d + ".")}
    state: dict[str, int] = {}

    def visit(m, chain):
        if state.get(m) == 2:
            return
        assert state.get(m) != 1, "import cycle: " + " -> ".join(chain + [m])
        state[m] = 1
        for d in sorted(deps(m)):
            visit(d, chain + [m])
        state[m] = 2

    for m in sorted(graph):
        visit(m, [])


def test_layers_import_downwards():
    for mod, deps in _imports().items():
        parts = mod.split(".")
        if len(parts) < 2 or parts[1] not in ALLOWED:
            continue
        for d in deps:
            dl = d.split(".")
            if len(dl) >= 2 and dl[1] in ALLOWED:
                assert dl[1] in ALLOWED[parts[1]], f"{mod} imports {d}: layer {parts[1]} may not import {dl[1]}"


def test_viewer_programs_come_from_the_shader_library():
    """The viewer compiles no inline GLSL (issue 28): its programs are files under shaders/ served by
    the ShaderLibrary (hot reload, defines, one error format). The start-up screen is the exception:
    it is drawn before the library (and the rest of the viewer) is loaded."""
    import re
    from pathlib import Path
    ui = Path(__file__).resolve().parents[1] / "skinviewer" / "ui"
    inline = [p.name for p in ui.rglob("*.py") if p.name != "splash.py"
              and re.search(r"\.program\(\s*vertex_shader", p.read_text(encoding="utf-8"))]
    assert not inline, f"inline GLSL in {inline}"


def test_passes_and_techniques_use_the_pass_api_not_the_graph():
    """A pass module sees the pass API (kernel/pass_api.py: Pass, Reflection, TexSpec), never the graph
    that runs it (issue 28): what a pass may rely on is the API, not the executor's internals."""
    offenders = sorted(m for m, deps in _imports().items()
                       if m.split(".")[1:2] in (["passes"], ["techniques"]) and "skinviewer.kernel.graph" in deps)
    assert not offenders, offenders
