"""Every command of the README's code blocks, run the way a user runs it (issue 29).

    python3 .ci/readme_commands.py --list                       # each command and how CI runs it
    python3 .ci/readme_commands.py wheel --venv V --work DIR     # the installed-wheel commands, from DIR
    python3 .ci/readme_commands.py checkout                      # the checkout's (editable install) ones

``.ci/run`` calls ``wheel`` in its clean venv from a folder outside the checkout, then ``checkout``
after its editable install. Every command found in a fenced ``sh`` block of README.md must have a
plan in PLANS (tests/test_readme_commands.py fails otherwise), so a README command nobody runs
cannot land. A plan says where the command runs and how it is judged:

- ``wheel``: in the clean venv (its ``bin`` first on PATH), from a folder outside the checkout, as
  written; ``pip install .`` runs in the checkout (``.`` is the checkout there).
- ``checkout``: in the checkout, with the interpreter that runs this script (CI's editable install).
- the viewer (``viewer=True``): the command as written plus ``--frames N --screenshot PATH``, the
  viewer's own batch flags: it opens its window (under Xvfb when there is no display), draws, saves
  the first complete frame and exits; accepted when that image is not blank.
- ``serve=True`` (``mkdocs serve``): accepted when the server answers at its address; then stopped.
- ``ci``: not run here, with the reason: ``.ci/run`` itself, and the test command, which ``.ci/run``
  runs verbatim as its last step (the test checks that line is there).

Each command prints its wall time (the figures in docs/dev/checks.md come from here); any failure
fails the run after the rest have run. Nothing is left behind in the checkout.
"""
from __future__ import annotations

import argparse
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
VIEWER_FRAMES = 3
VIEWER_TIMEOUT_S = 600
SERVE_URL = "http://127.0.0.1:8000/"
XVFB = ["xvfb-run", "-a", "-s", "-screen 0 1280x800x24"]
SCAN = ROOT.parent / "shared" / "assets" / "lee-perry-smith" / "LeePerrySmith.glb"


@dataclass(frozen=True)
class Plan:
    where: str  # "wheel", "checkout" or "ci"
    viewer: bool = False
    serve: bool = False
    why: str = ""  # for "ci": why this script does not run it


# Every command of the README, exactly as extracted (see commands()), and how CI runs it.
PLANS: dict[str, Plan] = {
    # The two commands
    "pip install -e . && skinviewer": Plan("checkout", viewer=True),
    'pip install -e ".[test]" && xvfb-run -a python -m pytest -q -n auto --dist loadfile':
        Plan("ci", why=".ci/run's last step runs it exactly as written"),
    # Installing it as a tool
    "pip install .": Plan("wheel"),
    "skinviewer --version": Plan("wheel"),
    "skinviewer render --technique deon --out head.png": Plan("wheel"),
    # Command line
    "skinviewer": Plan("wheel", viewer=True),
    "skinviewer --technique gosselin --preset presets/gosselin.json": Plan("wheel", viewer=True),
    "skinviewer --mesh head.glb --set scene.mm_per_unit=48": Plan("wheel", viewer=True),
    "skinviewer render --out head.png": Plan("wheel"),
    "skinviewer render --scene backlit-ear --technique deon --size 512x512 --out ear.png --exr ear.exr "
    "--dump-passes passes/ --timings t.json -v": Plan("wheel"),
    "skinviewer settings --list": Plan("wheel"),
    "skinviewer reference --size 256x256 --out ref.png --exr ref.exr": Plan("wheel"),
    "skinviewer bench --quick --size 160x160 --out bench/ --budget-ms 2000 --preset-out best.json": Plan("wheel"),
    "skinviewer calibrate --techniques deon": Plan("wheel"),
    "skinviewer profile --model dipole --material Skin1 --fit 6 --plot skin1.png --preset-out skin1.json":
        Plan("wheel"),
    "skinviewer export --to materialx --out skin.mtlx": Plan("wheel"),
    "skinviewer turntable --frames 36 --out turn.mp4": Plan("wheel"),
    "skinviewer sheet --techniques deon,ssss --views front,34 --out sheet.png": Plan("wheel"),
    # Read more
    'pip install -e ".[docs]" && mkdocs serve': Plan("checkout", serve=True),
    # Development
    'pip install -e ".[dev]" && pre-commit install': Plan("checkout"),
    "ruff check && mypy && mkdocs build --strict": Plan("checkout"),
    ".ci/run": Plan("ci", why="this is CI itself"),
}


def fenced_blocks(text: str) -> list[tuple[str, str]]:
    """(language, body) of every fenced code block."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"^```([\w-]*)[^\n]*\n(.*?)^```", text, re.M | re.S)]


def _strip_comment(line: str) -> str:
    """The line without a shell comment: a ``#`` at the start or after a blank, outside quotes."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip()
    return line.rstrip()


def commands(text: str) -> list[str]:
    """Every command of the README's shell blocks (```sh, ```bash, ```console), in order: backslash
    continuations joined, comments dropped, spaces collapsed."""
    out: list[str] = []
    for lang, body in fenced_blocks(text):
        if lang not in ("sh", "bash", "shell", "console"):
            continue
        pending = ""
        for raw in body.splitlines():
            line = _strip_comment(raw)
            if line.endswith("\\"):
                pending += line[:-1] + " "
                continue
            line = " ".join((pending + line).split())
            pending = ""
            if line.startswith("$ "):
                line = line[2:]
            if line:
                out.append(line)
    return out


def check_plans(found: list[str]) -> list[str]:
    """Problems: a README command without a plan, a plan for a command the README no longer has."""
    problems = [f"README command with no plan in .ci/readme_commands.py PLANS: {c!r}" for c in found if c not in PLANS]
    problems += [f"plan for a command the README no longer shows: {c!r}" for c in PLANS if c not in found]
    return problems


def _not_blank(path: Path) -> str | None:
    """None for a drawn image, else why not."""
    if not path.is_file():
        return f"no screenshot at {path}"
    import numpy as np
    from PIL import Image
    a = np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)
    return None if a.std() > 2.0 else f"blank screenshot {path} (std {a.std():.2f})"


def _shell(cmd: str, cwd: Path, env: dict[str, str], timeout: float | None = None) -> int:
    return subprocess.run(["bash", "-c", f"set -e; {cmd}"], cwd=cwd, env=env, timeout=timeout).returncode


def _serve(cmd: str, cwd: Path, env: dict[str, str]) -> str | None:
    """Run a command ending in a server until it answers at SERVE_URL; None when it did."""
    proc = subprocess.Popen(["bash", "-c", cmd], cwd=cwd, env=env, start_new_session=True)
    try:
        t0 = time.monotonic()
        while time.monotonic() - t0 < VIEWER_TIMEOUT_S:
            if proc.poll() is not None:
                return f"exited with {proc.returncode} before serving"
            try:
                with urllib.request.urlopen(SERVE_URL, timeout=5) as r:  # noqa: S310 - our own local server
                    if r.status == 200:
                        return None
            except OSError:
                time.sleep(1.0)
        return f"nothing at {SERVE_URL} after {VIEWER_TIMEOUT_S} s"
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, 15)
            proc.wait(timeout=30)


def run_one(cmd: str, plan: Plan, cwd: Path, env: dict[str, str], shots: Path, n: int) -> str | None:
    """Run one README command by its plan; None when it passed, else why not."""
    if plan.viewer:
        shot = shots / f"readme-viewer-{n}.png"
        cmd = f"{cmd} --frames {VIEWER_FRAMES} --screenshot {shlex.quote(str(shot))}"
        head, sep, last = cmd.rpartition(" && ")
        if not env.get("DISPLAY") and shutil.which("xvfb-run"):
            last = " ".join(shlex.quote(a) for a in XVFB) + " " + last
        rc = _shell(f"{head}{sep}{last}", cwd, env, VIEWER_TIMEOUT_S)
        return f"exit status {rc}" if rc else _not_blank(shot)
    if plan.serve:
        return _serve(cmd, cwd, env)
    rc = _shell(cmd, cwd, env)
    return f"exit status {rc}" if rc else None


def _head_glb(work: Path, python: str) -> None:
    """The README's ``--mesh head.glb`` is the user's own head: the Lee Perry-Smith scan where
    ../shared has it, else the default head written out as a GLB."""
    if SCAN.is_file():
        shutil.copyfile(SCAN, work / "head.glb")
        return
    code = ("import trimesh; from skinviewer.scene.scenes import build_scene; m = build_scene('head').mesh; "
            "trimesh.Trimesh(m.positions, m.indices, process=False).export('head.glb')")
    subprocess.run([python, "-c", code], cwd=work, check=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("group", nargs="?", choices=["wheel", "checkout"], help="which commands to run")
    ap.add_argument("--list", action="store_true", help="print every README command and its plan")
    ap.add_argument("--venv", type=Path, help="wheel: the clean venv with the wheel installed")
    ap.add_argument("--work", type=Path, help="wheel: the folder outside the checkout to run from")
    a = ap.parse_args(argv)
    found = commands(README.read_text(encoding="utf-8"))
    problems = check_plans(found)
    if a.list or not a.group:
        for c in found:
            p = PLANS.get(c)
            print(f"{'?' if p is None else p.where:9s} {c}" + (f"   ({p.why})" if p and p.why else ""))
        for msg in problems:
            print(msg, file=sys.stderr)
        return 1 if problems else 0
    if problems:
        for msg in problems:
            print(msg, file=sys.stderr)
        return 1

    env = dict(os.environ)
    if a.group == "wheel":
        if a.venv is None or a.work is None:
            ap.error("wheel needs --venv and --work")
        venv, work = a.venv.resolve(), a.work.resolve()
        if work == ROOT or ROOT in work.parents:
            ap.error("--work must be outside the checkout")
        work.mkdir(parents=True, exist_ok=True)
        env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
        env["VIRTUAL_ENV"] = str(venv)
        env.pop("PYTHONPATH", None)
        _head_glb(work, str(venv / "bin" / "python"))
    else:
        work = ROOT
    artefacts = [ROOT / "site", ROOT / "build", ROOT / "skinviewer.egg-info"]  # mkdocs build, pip's builds
    existed = {p for p in artefacts if p.exists()}
    shots = Path(tempfile.mkdtemp(prefix="readme-viewer-"))
    failed: list[str] = []
    t_all = time.monotonic()
    for n, cmd in enumerate(found):
        plan = PLANS[cmd]
        if plan.where != a.group:
            continue
        cwd = ROOT if cmd.startswith("pip install") and " && " not in cmd else work
        if cmd.endswith("pre-commit install") and (ROOT / ".git").is_file():
            print(f"-- skipped here (a git worktree shares its hooks with the main checkout): {cmd}", flush=True)
            continue
        print(f"-- {cmd}", flush=True)
        t0 = time.monotonic()
        try:
            why = run_one(cmd, plan, cwd, env, shots, n)
        except subprocess.TimeoutExpired:
            why = f"timed out after {VIEWER_TIMEOUT_S} s"
        dt = time.monotonic() - t0
        print(f"   {'ok' if why is None else 'FAILED: ' + why} in {dt:.1f} s", flush=True)
        if why is not None:
            failed.append(cmd)
    for p in artefacts:  # leave nothing behind in the checkout
        if p not in existed and p.exists():
            shutil.rmtree(p)
    shutil.rmtree(shots, ignore_errors=True)
    print(f"== README commands ({a.group}): {len(failed)} failed, {time.monotonic() - t_all:.0f} s", flush=True)
    for c in failed:
        print(f"   failed: {c}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
