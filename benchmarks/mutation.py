"""Mutation testing of the physics, the graph kernel and the settings validation (issue 36): mutmut
(``pip install -e ".[mutation]"``) applies one-line changes to the source and runs only the fast test
files that match the module; a mutant that no test notices "survived". Not part of CI's time budget.

    python benchmarks/mutation.py                       # every group below (long: see notes/mutation.md)
    python benchmarks/mutation.py --groups physics.metrics ground.settings --max-children 2
    python benchmarks/mutation.py --list                # the groups and their test files
    python benchmarks/mutation.py --groups physics.burley --json b0.json   # then, after adding tests:
    python benchmarks/mutation.py --groups physics.burley --rerun b0.json  # only b0's survivors re-run

Each group runs in its own scratch copy of the checkout (skinviewer/, tests/, shaders/, presets/,
pyproject.toml with the group's [tool.mutmut]) so groups never share mutmut's cache; the checkout is
not touched. Prints killed / survived / no tests / timeout per module and the surviving mutants' diffs
(``--show N`` per module); ``--json FILE`` writes the counts and survivor names. The triage (which
survivors are equivalent, which a new test kills) is in notes/mutation.md.

The plain ``mutmut run`` in the checkout uses pyproject's own [tool.mutmut] (every group at once)."""
from __future__ import annotations

import argparse
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# module globs -> the fast test files that exercise them (numpy, or small headless GL graphs)
GROUPS: dict[str, tuple[list[str], list[str]]] = {
    "physics.metrics": (["skinviewer/physics/metrics.py"], ["tests/test_metrics.py"]),
    "physics.burley": (["skinviewer/physics/burley.py"], ["tests/test_burley_physics.py"]),
    # the same module with the GPU tests that compare the shader to its numpy twin (burley.blur): slower
    "physics.burley+gpu": (["skinviewer/physics/burley.py"],
                           ["tests/test_burley_physics.py", "tests/test_burley_gpu.py::test_glsl_matches_the_numpy_reference",
                            "tests/test_burley_gpu.py::test_depth_bilateral_t47"]),
    "physics.transmittance": (["skinviewer/physics/transmittance.py", "skinviewer/physics/separable.py"],
                              ["tests/test_separable_physics.py"]),
    # separable.py alone (physics.transmittance samples both modules: 24 of its 30 were separable's)
    "physics.separable": (["skinviewer/physics/separable.py"], ["tests/test_separable_physics.py"]),
    "physics.poisson": (["skinviewer/physics/poisson.py"], ["tests/test_poisson.py"]),
    "physics.penner": (["skinviewer/physics/penner.py"], ["tests/test_penner.py"]),
    "physics.profiles": (["skinviewer/physics/profiles.py"], ["tests/test_profiles.py"]),
    # test_fitting.py takes ~6 min on a loaded 2-core machine: a group of its own
    "physics.fitting": (["skinviewer/physics/fitting.py"], ["tests/test_fitting.py", "tests/test_fitting_grid.py"]),
    # d'Eon's numpy maths; its GL tests (test_deon, test_rules, test_fidelity: minutes each) are left out
    "physics.diffusion": (["skinviewer/physics/diffusion.py"],
                          ["tests/test_diffusion_physics.py", "tests/test_separable_physics.py"]),
    "physics.specular": (["skinviewer/physics/specular.py"], ["tests/test_specular.py"]),
    # the numpy tests of the three environment files (their renders, the viewer and the bench are left out)
    "physics.environment": (["skinviewer/physics/environment.py"],
                            ["tests/test_environment.py", "tests/test_env_twins.py", "tests/test_env_transfer.py",
                             "tests/test_env_numpy_pins.py",
                             "-k", "not (sphere_shading or every_technique or occlusion_darkens or right_drag or "
                             "bench_sweeps or viewer_refuses or cli_refuses or vertex_stage or background_shows or "
                             "phong_sphere or penner_sphere or texel_path or twins and limits_and_the_shader)"]),
    "physics.surface_gather": (["skinviewer/physics/surface_gather.py"],
                               ["tests/test_tiles.py", "tests/test_surface_gather_physics.py"]),
    # without its 46 s GL test (the renderer's view; it checks the camera, not the integration)
    "physics.ground_truth": (["skinviewer/physics/ground_truth.py"],
                             ["tests/test_reference.py", "tests/test_ground_truth_pins.py",
                              "--deselect=tests/test_reference.py::test_truth_sees_the_view_the_renderer_draws"]),
    "physics.artist": (["skinviewer/physics/artist.py"], ["tests/test_artist.py"]),
    "physics.engines": (["skinviewer/physics/engines.py"], ["tests/test_exchange.py"]),
    "physics.open_border": (["skinviewer/physics/open_border.py"], ["tests/test_open_border.py"]),
    "kernel.graph": (["skinviewer/kernel/graph.py", "skinviewer/kernel/execute.py", "skinviewer/kernel/pass_api.py"],
                   ["tests/test_graph.py", "tests/test_settings_reads.py"]),
    # the techniques' sections (their validators) moved to ground/sections/ (issue 28)
    "ground.settings": (["skinviewer/ground/settings.py", "skinviewer/ground/sections/*.py"],
                        ["tests/test_settings.py", "tests/test_settings_finite.py", "tests/test_settings_io.py",
                         "tests/test_sections.py"]),
}

_SECTION = re.compile(r"^\[tool\.mutmut\]\n(?:(?!\[).*\n?)*", re.MULTILINE)


def toml_list(xs) -> str:
    return "[" + ", ".join(json.dumps(x) for x in xs) + "]"


def mutmut_section(only: list[str], tests: list[str]) -> str:
    return ("[tool.mutmut]\n"
            'source_paths = ["skinviewer/"]\n'
            f"only_mutate = {toml_list(only)}\n"
            'also_copy = ["shaders/", "presets/"]\n'
            f"pytest_add_cli_args_test_selection = {toml_list(tests)}\n"
            'pytest_add_cli_args = ["-p", "no:cacheprovider", "-q"]\n'
            # workers forked from a clean server: forked from mutmut's main process (which ran the suite and
            # holds its GL context) the GL tests could not make a context and skipped, so mutants "survived"
            'process_isolation = "forkserver"\n')


def scratch_copy(dest: Path, only: list[str], tests: list[str], tests_from: str | None = None) -> None:
    ign = shutil.ignore_patterns("__pycache__", "*.pyc", "mutants", ".pytest_cache")
    for d in ("skinviewer", "tests", "shaders", "presets"):
        shutil.copytree(ROOT / d, dest / d, ignore=ign)
    if tests_from:  # the tests of another revision (the "before" column of notes/mutation.md)
        shutil.rmtree(dest / "tests")
        arc = subprocess.run(["git", "-C", str(ROOT), "archive", tests_from, "tests"], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(dest)], input=arc.stdout, check=True)
    text = (ROOT / "pyproject.toml").read_text()
    text = _SECTION.sub("", text).rstrip() + "\n\n" + mutmut_section(only, tests)
    (dest / "pyproject.toml").write_text(text)


STATUS_LINE = re.compile(r"^\s*(\S+__mutmut_\d+):\s*(.+?)\s*$")


def read_results(work: Path, only_names: list[str] | None = None) -> dict[str, dict[str, list[str]]]:
    """{module: {status: [mutant names]}} from mutmut's results in a scratch copy."""
    env = {k: v for k, v in os.environ.items() if k not in ("CI", "PYTHONPATH")}
    res = subprocess.run([sys.executable, "-m", "mutmut", "results", "--all", "true"], cwd=work, env=env,
                         capture_output=True, text=True, check=False)
    keep = set(only_names) if only_names else None
    per: dict[str, dict[str, list[str]]] = {}
    for line in res.stdout.splitlines():
        m = STATUS_LINE.match(line)
        if m and (keep is None or m.group(1) in keep):
            per.setdefault(module_of(m.group(1)), {}).setdefault(m.group(2), []).append(m.group(1))
    return per


def module_of(mutant: str) -> str:
    # skinviewer.physics.metrics.x_rel_rms__mutmut_3 / skinviewer.kernel.graph.xǁRenderGraphǁrun__mutmut_1
    head = mutant.split("__mutmut_")[0]
    parts = head.split(".")
    return ".".join(p for p in parts[:-1]) if len(parts) > 1 else head


def all_mutants(work: Path) -> list[str]:
    names = []
    for meta in sorted((work / "mutants").rglob("*.meta")):
        names += sorted(json.loads(meta.read_text()).get("exit_code_by_key", {}))
    return names


def start_xvfb():
    """A private X server for the whole mutmut run: without one, tests/conftest.py starts an Xvfb per
    pytest session and stops it when that session ends -- the session mutmut's workers are forked from --
    so the workers' GL tests found a dead display, skipped, and every mutant they covered "survived"."""
    exe = shutil.which("Xvfb")
    if exe is None:
        return None, None
    r, w = os.pipe()
    proc = subprocess.Popen([exe, "-displayfd", str(w), "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
                            pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        num = f.readline().strip()
    return proc, (f":{num.decode()}" if num else None)


def run_group(name: str, only: list[str], tests: list[str], max_children: int, show: int, keep: Path | None,
              tests_from: str | None = None, sample: int = 0, seed: int = 36, only_mutants: list[str] | None = None):
    work = Path(tempfile.mkdtemp(prefix=f"mutation-{name}-", dir=keep))
    if tests_from:
        tests = [t for t in tests if subprocess.run(["git", "-C", str(ROOT), "cat-file", "-e", f"{tests_from}:{t}"],
                                                    capture_output=True, check=False).returncode == 0]
    scratch_copy(work, only, tests, tests_from)
    env = {k: v for k, v in os.environ.items() if k not in ("CI", "PYTHONPATH")}
    env.setdefault("SKINVIEWER_CACHE", str(work / "cache"))
    # the scratch copy has no ../shared beside it: point the tests at the checkout's (or they skip)
    env.setdefault("SKINVIEWER_SHARED", str(ROOT.parent / "shared"))
    xvfb, display = (None, os.environ.get("DISPLAY")) if os.environ.get("DISPLAY") else start_xvfb()
    if display:
        env["DISPLAY"] = display
    t0 = time.perf_counter()
    mm = [sys.executable, "-m", "mutmut", "run", "--max-children", str(max_children)]
    chosen = None
    if only_mutants is not None:  # --rerun: just these (a previous run's survivors)
        chosen = sorted(only_mutants)
        mm += chosen or ["__no_such_mutant__"]
    elif sample:
        # generate the mutants and the test mapping (a filter matching nothing stops mutmut right after),
        # then run a seeded random sample of them: the same sample before and after for a given seed
        subprocess.run(mm + ["__no_such_mutant__"], cwd=work, env=env, capture_output=True, text=True, check=False)
        names = all_mutants(work)
        chosen = sorted(random.Random(seed).sample(names, min(sample, len(names))))
        mm += chosen
    try:
        run = subprocess.run(mm, cwd=work, env=env, capture_output=True, text=True, check=False)
    finally:
        if xvfb is not None:
            xvfb.terminate()
            xvfb.wait(5)
    elapsed = time.perf_counter() - t0
    per = read_results(work, chosen)
    if not per:
        print(f"{name}: mutmut produced no results (exit {run.returncode})\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}")
    diffs: dict[str, str] = {}
    for by in per.values():
        for mutant in by.get("survived", [])[:show]:
            d = subprocess.run([sys.executable, "-m", "mutmut", "show", mutant], cwd=work, env=env,
                               capture_output=True, text=True, check=False)
            diffs[mutant] = d.stdout
    if keep is None:
        shutil.rmtree(work, ignore_errors=True)
    return per, diffs, elapsed, tests


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--groups", nargs="*", default=list(GROUPS), help="groups to run (default: all)")
    ap.add_argument("--max-children", type=int, default=2, help="parallel mutmut workers (default 2)")
    ap.add_argument("--show", type=int, default=100, help="surviving mutants' diffs to print per module")
    ap.add_argument("--json", type=Path, help="write counts and survivor names here")
    ap.add_argument("--keep", type=Path, help="keep the scratch copies under this folder (mutmut browse there)")
    ap.add_argument("--tests-from", metavar="REV", help="run the tests/ of git revision REV against today's source "
                    "(e.g. the commit before issue 36's tests: the report's 'before')")
    ap.add_argument("--sample", type=int, default=0, metavar="N",
                    help="run a seeded random sample of N mutants per group (CPU-bound machines; say so)")
    ap.add_argument("--seed", type=int, default=36, help="the sample's seed (same seed: same mutants)")
    ap.add_argument("--rerun", type=Path, metavar="JSON",
                    help="a previous run's --json: run only its survivors and its no-tests mutants and add its killed "
                    "(tests only added since: the quick 'after'; mutants are named alike while the source is unchanged)")
    ap.add_argument("--list", action="store_true", help="list the groups and exit")
    a = ap.parse_args(argv)
    if a.list:
        for g, (only, tests) in GROUPS.items():
            print(f"{g:<24} {' '.join(only)}  <-  {' '.join(tests)}")
        return 0
    unknown = [g for g in a.groups if g not in GROUPS]
    if unknown:
        print(f"unknown group(s): {', '.join(unknown)}; --list shows them", file=sys.stderr)
        return 2
    if a.keep:
        a.keep.mkdir(parents=True, exist_ok=True)
    report = {}
    print(f"{'module':<34} {'killed':>7} {'survived':>9} {'no tests':>9} {'timeout':>8} {'other':>6} {'killed %':>9}")
    for g in a.groups:
        only, tests = GROUPS[g]
        prev = {m: v for m, v in json.loads(a.rerun.read_text()).items() if v.get("group") == g} if a.rerun else {}
        again = [x for v in prev.values() for st in ("survived", "no tests") for x in v.get(st, [])] if a.rerun else None
        per, diffs, elapsed, tests = run_group(g, only, tests, a.max_children, a.show, a.keep, a.tests_from, a.sample,
                                               a.seed, again)
        for mod, v in prev.items():  # the earlier run's killed (and timeouts) stand
            for st in ("killed", "timeout"):
                per.setdefault(mod, {}).setdefault(st, [])[:0] = v.get(st, [])
        for mod, by in sorted(per.items()):
            k, s = len(by.get("killed", [])), len(by.get("survived", []))
            nt, to = len(by.get("no tests", [])), len(by.get("timeout", []))
            other = sum(len(v) for st, v in by.items() if st not in ("killed", "survived", "no tests", "timeout"))
            tot = k + s + nt + to + other
            pct = 100.0 * (k + to) / tot if tot else 0.0
            print(f"{mod:<34} {k:7d} {s:9d} {nt:9d} {to:8d} {other:6d} {pct:8.1f}%")
            report[mod] = {"group": g, "seconds": round(elapsed, 1), **{st: v for st, v in by.items()}}
        for mutant, diff in diffs.items():
            print(f"--- survived: {mutant}\n{diff.strip()}\n")
        print(f"({g}: {elapsed:.0f} s, tests: {' '.join(tests)}" + (f"; a sample of {a.sample}, seed {a.seed}"
              if a.sample else "") + ")")
    if a.json:
        a.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
