"""The skip guard (tests/skip_guard.py): a run prints its skip count; on CI a skip fails the run unless
the test is marked allow_skip_on_ci."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parent


def _run(tmp_path, body: str, ci: bool, workers: int = 0):
    (tmp_path / "conftest.py").write_text(f"import sys\nsys.path.insert(0, {str(TESTS)!r})\n"
                                          "from skip_guard import *  # noqa\n"
                                          "def pytest_configure(config):\n    configure(config)\n")
    (tmp_path / "test_x.py").write_text("import pytest\n" + body)
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    if ci:
        env["CI"] = "true"
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", str(workers), str(tmp_path)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120, check=False)


SKIPS = ("def test_ok():\n    pass\n"
         "def test_skips():\n    pytest.skip('no frobnicator')\n"
         "@pytest.mark.xfail(reason='known')\ndef test_xf():\n    assert False\n")


def test_skip_count_printed_and_ci_fails_on_a_skip(tmp_path):
    r = _run(tmp_path, SKIPS, ci=False)
    assert r.returncode == 0, r.stdout
    assert "skipped: 1 test(s)" in r.stdout and "1 x no frobnicator" in r.stdout
    r = _run(tmp_path, SKIPS, ci=True)
    assert r.returncode == 1, r.stdout
    assert "test_x.py::test_skips: no frobnicator" in r.stdout and "must run on CI" in r.stdout


def test_a_marked_skip_is_allowed_on_ci(tmp_path):
    body = "@pytest.mark.allow_skip_on_ci('needs two GPUs')\ndef test_skips():\n    pytest.skip('one GPU')\n"
    r = _run(tmp_path, body, ci=True)
    assert r.returncode == 0 and "skipped: 1 test(s)" in r.stdout, r.stdout


def test_the_guard_holds_in_the_readmes_workers(tmp_path):
    """The README's command runs the suite in pytest-xdist workers (-n auto): the skips reported by the
    workers reach the controller, which prints them and fails the run on CI; a marked skip passes."""
    r = _run(tmp_path, SKIPS, ci=True, workers=2)
    assert r.returncode == 1, r.stdout
    assert "skipped: 1 test(s)" in r.stdout and "test_x.py::test_skips: no frobnicator" in r.stdout, r.stdout
    body = "@pytest.mark.allow_skip_on_ci('needs two GPUs')\ndef test_skips():\n    pytest.skip('one GPU')\n"
    r = _run(tmp_path, body, ci=True, workers=2)
    assert r.returncode == 0 and "skipped: 1 test(s)" in r.stdout, r.stdout
