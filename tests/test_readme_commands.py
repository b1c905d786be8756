"""The README's commands are CI's (issue 29): .ci/readme_commands.py finds every command of the
README's shell blocks, each one has a plan for how CI runs it, and .ci/run runs both groups and the
test command verbatim. And the modules meant to be mypy-strict are: their effective options, as mypy
reads pyproject.toml, are every flag `mypy --strict` sets."""
from __future__ import annotations

import importlib.util
import io
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("readme_commands", ROOT / ".ci" / "readme_commands.py")
assert _spec is not None and _spec.loader is not None
rc = importlib.util.module_from_spec(_spec)
sys.modules["readme_commands"] = rc
_spec.loader.exec_module(rc)

SAMPLE = '''# Title

Inline `skinviewer --nope` is prose, not a command.

```sh
pip install -e . && skinviewer          # the viewer
# a whole-line comment
skinviewer render --scene backlit-ear --technique deon \\
    --size 512x512 --out ear.png   # one command over two lines

skinviewer render --set 'look.note=#1 red' --out a.png
```

```python
print("not a shell block")
```

```bash
$ ruff check && mypy
```
'''


def test_extractor_finds_every_fenced_command():
    assert rc.commands(SAMPLE) == [
        "pip install -e . && skinviewer",
        "skinviewer render --scene backlit-ear --technique deon --size 512x512 --out ear.png",
        "skinviewer render --set 'look.note=#1 red' --out a.png",  # a '#' inside quotes is not a comment
        "ruff check && mypy",
    ]


def test_every_readme_command_has_a_plan_and_no_plan_is_stale():
    found = rc.commands(rc.README.read_text(encoding="utf-8"))
    assert len(found) >= 20  # the README's blocks: the two commands, the tool, the command line, docs, development
    assert rc.check_plans(found) == []
    assert rc.check_plans(found + ["skinviewer frobnicate"]) == [
        "README command with no plan in .ci/readme_commands.py PLANS: 'skinviewer frobnicate'"]


def test_the_two_commands_stay_and_ci_runs_everything():
    found = rc.commands(rc.README.read_text(encoding="utf-8"))
    assert found[:2] == ["pip install -e . && skinviewer",
                         'pip install -e ".[test]" && xvfb-run -a python -m pytest -q -n auto --dist loadfile']
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert 'pip install -e ".[test]" && xvfb-run -a python -m pytest -q -n auto --dist loadfile' in ci  # verbatim, its own line
    assert any("readme_commands.py wheel" in line for line in ci)
    assert any("readme_commands.py checkout" in line for line in ci)
    not_run = [c for c in found if rc.PLANS[c].where == "ci"]
    assert not_run == ['pip install -e ".[test]" && xvfb-run -a python -m pytest -q -n auto --dist loadfile', ".ci/run"]


def test_a_failing_command_fails_the_group(tmp_path, monkeypatch):
    monkeypatch.setattr(rc, "README", tmp_path / "README.md")
    (tmp_path / "README.md").write_text("```sh\nfalse\ntrue\n```\n", encoding="utf-8")
    monkeypatch.setattr(rc, "PLANS", {"false": rc.Plan("checkout"), "true": rc.Plan("checkout")})
    monkeypatch.setattr(rc, "ROOT", tmp_path)
    assert rc.main(["checkout"]) == 1
    monkeypatch.setattr(rc, "PLANS", {"false": rc.Plan("ci", why="x"), "true": rc.Plan("checkout")})
    assert rc.main(["checkout"]) == 0


STRICT = ["skinviewer.physics.profiles", "skinviewer.physics.ground_truth", "skinviewer.ground.settings",
          "skinviewer.kernel.graph", "skinviewer.engine.reference"]


@pytest.mark.parametrize("module", STRICT)
def test_strict_modules_get_every_strict_flag(module):
    mypy_main = pytest.importorskip("mypy.main")  # the [lint] extra; CI installs it before the tests
    from mypy.config_parser import parse_config_file
    from mypy.options import Options
    opts = Options()
    parse_config_file(opts, lambda: None, str(ROOT / "pyproject.toml"), io.StringIO(), io.StringIO())
    flags = mypy_main.define_options()[2]  # (option, value) of each flag --strict sets
    assert len(flags) >= 10
    m = opts.clone_for_module(module)
    assert [name for name, value in flags if getattr(m, name) != value] == []
    # and not the whole package (what `strict = true` in an override would have done)
    ui = opts.clone_for_module("skinviewer.ui.app")
    assert [name for name, value in flags if getattr(ui, name) != value]
