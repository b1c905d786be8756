"""No skip that hides a failure (issue 36): every run prints how many tests skipped and why; on CI
(environment CI=true: Xvfb, ../shared and the GL drivers are there) any skip fails the run, unless the
test is marked ``allow_skip_on_ci`` with its reason. Tests skip only for a missing capability they name
(no display, no ../shared scan, no GL), never on an arbitrary exception. Imported by conftest.py."""
from __future__ import annotations

import os

import pytest

_SKIPPED: list = []  # (nodeid, reason, allowed on CI)


def on_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")


def configure(config) -> None:
    config.addinivalue_line("markers", "allow_skip_on_ci(reason): this test may skip on CI too (say why)")


def pytest_runtest_logreport(report):
    if report.skipped and not hasattr(report, "wasxfail"):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        reason = reason.removeprefix("Skipped: ")
        _SKIPPED.append((report.nodeid, reason, "allow_skip_on_ci" in report.keywords))


def _blocking():
    return [s for s in _SKIPPED if not s[2]]


def pytest_sessionfinish(session, exitstatus):
    if on_ci() and _blocking() and session.exitstatus == 0:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    tr = terminalreporter
    reasons: dict[str, int] = {}
    for _, reason, _ in _SKIPPED:
        reasons[reason] = reasons.get(reason, 0) + 1
    tr.write_line(f"skipped: {len(_SKIPPED)} test(s)" + "".join(f"\n  {n} x {r}" for r, n in sorted(reasons.items())))
    if on_ci() and _blocking():
        tr.write_line(f"CI: {len(_blocking())} test(s) that must run on CI skipped -> the run fails:", red=True)
        for nodeid, reason, _ in _blocking():
            tr.write_line(f"  {nodeid}: {reason}", red=True)
