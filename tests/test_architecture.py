"""The layout is the architecture: no import cycles between modules (not even through imports
inside functions), and the layers only import downwards: a module may import its own layer and the
layers below it, never one above, with no exception. Imports under ``if TYPE_CHECKING:`` (annotations
only, never run) count for the layers but not as cycles: ``Pass.execute(ec: ExecuteContext)`` names the
context the graph hands it."""
from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "skinviewer"

# the layers, bottom first (issue 28). Each folder skinviewer/<layer>/ may import the layers before it
# in this list and nothing after it. README.md's layer line and docs/dev/architecture.md's diagram are
# checked against this list (test_the_documented_layers_are_the_checked_ones).
LAYERS = [
    "ground",      # settings model, files, paths, constants shared with GLSL
    "physics",     # plain numpy: profiles, fitting, diffusion, specular, colour, metrics, ground truth
    "scene",       # meshes, the generated head, built-in scenes, camera
    "kernel",      # the graph kernel: pass API, graph, execute context, GL services, shaders, GpuScene
    "passes",      # one module per pass
    "techniques",  # a technique = passes + targets + bench sweep
    "engine",      # renderer, ground-truth reference, bench, memory, calibration, exchange, look
    "ui",          # the viewer
    "cli",         # the command line (opens the viewer)
]
# the package root holds only __version__ (below everything); the launcher and ``python -m`` start the
# command line or the viewer (above everything)
BOTTOM = {"skinviewer"}
TOP = {"skinviewer.launch", "skinviewer.__main__"}


def _rank(mod: str) -> int:
    if mod in BOTTOM:
        return -1
    if mod in TOP:
        return len(LAYERS)
    return LAYERS.index(mod.split(".")[1])


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


def test_every_module_is_in_a_layer():
    """A new folder under skinviewer/ must be placed in LAYERS before it can import anything."""
    loose = sorted(m for m in _imports() if m not in BOTTOM | TOP and (len(m.split(".")) < 2
                                                                     or m.split(".")[1] not in LAYERS))
    assert not loose, f"modules in no layer (add their folder to LAYERS): {loose}"


def _backward_arrows(graph: dict[str, set[str]]) -> list[str]:
    return sorted(f"{m} -> {d}" for m, deps in graph.items() for d in deps if _rank(d) > _rank(m))


def test_layers_import_downwards():
    """Every import, type-only ones included, goes to the module's own layer or one below it."""
    bad = _backward_arrows(_imports())
    assert not bad, "imports that go up a layer:\n" + "\n".join(bad)


def test_an_upward_import_is_caught():
    """The check above flags the kinds of arrow issue 28 removed (core -> passes/techniques, scene -> core,
    ui -> cli): a kernel module importing the engine (as execute.py once did for GpuScene, type-only:
    the layer check reads those too, see test_type_only_imports_are_told_apart), a pass importing a
    technique, the viewer importing the command line; a downward import is not flagged."""
    graph = {"skinviewer.kernel.execute": {"skinviewer.engine.renderer"},
             "skinviewer.passes.output": {"skinviewer.techniques.deon"},
             "skinviewer.scene.mesh": {"skinviewer.ground.files"}, "skinviewer.ui.app": {"skinviewer.cli.args"}}
    assert _backward_arrows(graph) == ["skinviewer.kernel.execute -> skinviewer.engine.renderer",
                                       "skinviewer.passes.output -> skinviewer.techniques.deon",
                                       "skinviewer.ui.app -> skinviewer.cli.args"]


def _documented_layers(text: str) -> list[str]:
    return re.findall(r"`(\w+)`", text)


def test_the_documented_layers_are_the_checked_ones():
    """README.md's layer line (bottom first) and docs/dev/architecture.md's diagram (top first) name the
    layers of LAYERS in the same order: the diagram is what this file checks."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    line = re.search(r"The layers \((.*?)\) only import", readme, re.S)
    assert line, "README.md: no 'The layers (...) only import' sentence"
    assert _documented_layers(line.group(1)) == LAYERS
    doc = (ROOT / "docs" / "dev" / "architecture.md").read_text(encoding="utf-8")
    diagram = re.search(r"```\n(.*?)```", doc, re.S)
    assert diagram, "docs/dev/architecture.md: no diagram"
    drawn = [m for m in re.findall(r"skinviewer/(\w+)/", diagram.group(1)) if m in LAYERS or m == "core"]
    assert list(reversed(drawn)) == LAYERS


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
