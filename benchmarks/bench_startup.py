"""The viewer's cold start (issue 34): how long after launching ``python3 -m skinviewer`` the window
shows the start-up screen, the first frame with the panel is drawn, and the first complete image is
in the view. Each run is a new process (cold: nothing imported; the operating system's file cache
and the skinviewer cache folder as the previous run left them), timed from just before the process
is started to the viewer's own marks (``SKINVIEWER_STARTUP_TRACE``, ui/startup.py); the median of
``--runs`` runs is printed beside each run's figures. Needs a display: run it under Xvfb,

    xvfb-run -a -s "-screen 0 1280x800x24" python3 benchmarks/bench_startup.py [--runs 3]
        [--technique deon] [--size 1280x800] [--first-start] [--shots DIR --shot-at 1,2] [--compare TREE]

``--first-start``: an empty cache folder for every run (the default head is generated, no governor
calibration: what a fresh install meets); ``--no-calibration``: the cache folder in use without its
governor calibration (links to everything else: the head, texel tables and environment are read from
it; the cold start's first image without a calibration, issue 34); otherwise the cache folder in use
(``SKINVIEWER_CACHE`` or ~/.cache/skinviewer), so the head is read from it. ``--shots DIR``: grab the X screen at each
``--shot-at`` second of the first run (``DIR/startup-<s>s.png``).

Wall clock on a shared machine: compare figures of one run of this script, not across runs. Each run
also prints the load average as it started and the viewer process's CPU seconds at the window and
panel marks (its own work, all threads: about the wall time on a quiet machine, where the start runs
mostly one thread at a time)."""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EVENTS = ("window", "ui", "image", "final")  # final: the first image at the user's own settings
# besides the events: "frozen", the longest frame (s) between the panel and the first image -- the
# longest the panel did not answer input (older trees do not report it: "-")
FIGURES = EVENTS + ("frozen",)
ROOT = Path(__file__).resolve().parents[1]


def read_trace(path: Path) -> dict[str, float]:
    out: dict[str, float] = {}
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        return out
    for line in text.splitlines():
        try:
            d = json.loads(line)
        except ValueError:
            continue  # a line being written
        out.setdefault(d["event"], float(d["t"]))
        if "cpu" in d:  # the process's CPU seconds at the mark (older trees: none)
            out.setdefault(f"cpu_{d['event']}", float(d["cpu"]))
        if d["event"] == "image" and "preview" not in d:
            out.setdefault("old", 1.0)  # a tree that does not say whether its first image is a preview
        if d["event"] == "image" and "longest_frame_ms" in d:  # the longest frame from the panel to the image
            out.setdefault("frozen", float(d["longest_frame_ms"]) / 1000.0)
    return out


def one_run(argv: list[str], env: dict[str, str], timeout: float, shots: Path | None = None,
            shot_at: tuple[float, ...] = (), root: Path = ROOT, tag: str = "") -> dict[str, float]:
    """Seconds from the process start to each event of one viewer start (missing: not reached)."""
    with tempfile.TemporaryDirectory(prefix="sv-startup-") as tmp:
        trace = Path(tmp) / "trace.jsonl"
        env = {**env, "SKINVIEWER_STARTUP_TRACE": str(trace)}
        t0 = time.time()
        proc = subprocess.Popen([sys.executable, "-m", "skinviewer", *argv], cwd=root, env={**env, "PYTHONPATH": str(root)},
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        pending = sorted(shot_at) if shots is not None else []  # (no grabs: a run ends at its last mark, not at the timeout)
        try:
            while time.time() - t0 < timeout:
                marks = read_trace(trace)
                if pending and shots is not None and time.time() - t0 >= pending[0]:
                    from PIL import ImageGrab
                    s = pending.pop(0)
                    try:
                        ImageGrab.grab(xdisplay=os.environ.get("DISPLAY")).save(shots / f"startup{tag}-{s:g}s.png")
                    except Exception as exc:  # no X screen to grab: the figures still count
                        print(f"screen grab at {s:g} s failed: {exc}", file=sys.stderr)
                if ("final" in marks or ("image" in marks and "old" in marks)) and not pending:
                    break
                if proc.poll() is not None:
                    break
                time.sleep(0.02)
        finally:
            if proc.poll() is None:
                proc.terminate()
            try:
                _, err = proc.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                _, err = proc.communicate()
        marks = read_trace(trace)
        if "image" not in marks:
            print(f"run did not reach the first image (exit {proc.returncode}): {err.strip()[-400:]}", file=sys.stderr)
        out = {e: marks[e] - t0 for e in EVENTS if e in marks}
        out.update({k: v for k, v in marks.items() if k.startswith("cpu_") or k == "frozen"})
        return out


def link_cache(into: Path) -> None:
    """``into``: links to every entry of the cache folder in use but its calibration."""
    src = Path(os.environ.get("SKINVIEWER_CACHE") or Path.home() / ".cache" / "skinviewer")
    if src.is_dir():
        for entry in src.iterdir():
            if entry.name != "calibration":
                (into / entry.name).symlink_to(entry.resolve())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--technique", default="deon")
    ap.add_argument("--size", default="1280x800")
    ap.add_argument("--first-start", action="store_true", help="an empty cache folder for every run")
    ap.add_argument("--no-calibration", action="store_true",
                    help="the cache folder in use without its governor calibration (a cold start's first image)")
    ap.add_argument("--timeout", type=float, default=300.0)
    ap.add_argument("--shots", type=Path, help="grab the X screen into this folder (first run)")
    ap.add_argument("--shot-at", default="1,2", help="seconds after the start of the grabs, e.g. 0.5,1,2")
    ap.add_argument("--compare", type=Path, metavar="CHECKOUT",
                    help="another source tree (with ui/startup.py's marks), run alternately with this one: "
                         "before/after figures in one run")
    a = ap.parse_args(argv)
    if not os.environ.get("DISPLAY"):
        print("no DISPLAY: run it under xvfb-run", file=sys.stderr)
        return 2
    viewer = ["--technique", a.technique, "--size", a.size]
    env = dict(os.environ)
    env.setdefault("SKINVIEWER_CALIBRATE", "0")  # no background calibration competing for the CPU
    if a.shots:
        a.shots.mkdir(parents=True, exist_ok=True)
    shot_at = tuple(float(x) for x in a.shot_at.split(",") if x) if a.shots else ()
    trees = [("this checkout", ROOT)] + ([("compared", a.compare.resolve())] if a.compare else [])
    rows: dict[str, list[dict[str, float]]] = {name: [] for name, _ in trees}
    for k in range(a.runs):
        for name, root in trees:
            with tempfile.TemporaryDirectory(prefix="sv-cache-") as cache:
                if a.no_calibration and not a.first_start:
                    link_cache(Path(cache))
                run_env = {**env, "SKINVIEWER_CACHE": cache} if a.first_start or a.no_calibration else env
                tag = "" if root == ROOT else "-compared"
                run_load = os.getloadavg()[0]
                r = one_run(viewer, run_env, a.timeout, a.shots if k == 0 else None, shot_at, root, tag)
            rows[name].append(r)
            cpu = "  ".join(f"{e} {r['cpu_' + e]:.2f} s" for e in ("window", "ui", "image") if "cpu_" + e in r)
            print(f"run {k + 1} {name}: " + "  ".join(f"{e} {r[e]:.2f} s" if e in r else f"{e} -" for e in FIGURES)
                  + (f"   CPU to {cpu}" if cpu else "") + f"   (load {run_load:.1f})", flush=True)
    load = os.getloadavg()[0]
    for name, root in trees:
        print(f"\nviewer start, {name} ({root}; {a.technique}, {a.size}, "
              f"{'empty cache' if a.first_start else 'no calibration' if a.no_calibration else 'cache as is'}; "
              f"{os.cpu_count()} CPUs, load {load:.1f}): "
              f"median of {a.runs}")
        for e in FIGURES:
            xs = [r[e] for r in rows[name] if e in r]
            print(f"  to {e:6s} {statistics.median(xs):6.2f} s  (runs: {', '.join(f'{x:.2f}' for x in xs)})" if xs
                  else f"  to {e:6s}   not reached")
        cpu = [r["cpu_ui"] for r in rows[name] if "cpu_ui" in r]
        if cpu:  # the quiet machine's estimate: the start is one process, mostly one thread at a time
            print(f"  CPU to the panel {statistics.median(cpu):.2f} s (runs: {', '.join(f'{x:.2f}' for x in cpu)}): "
                  "about the wall time to the panel on a quiet machine (the process's CPU seconds, all threads)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
