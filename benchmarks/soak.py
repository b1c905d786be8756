"""Soak: render N frames as the viewer would (the camera orbits every frame, a setting changes
every few frames, the technique switches now and then, the pool is trimmed like on a resize) and
report the process's RSS and the live GL objects over time. A healthy run is flat after warm-up.

    python benchmarks/soak.py --frames 3000 --size 96 --maps 256

Each technique runs for --frames / (2 x techniques) frames, twice over: the first round is the
warm-up, the drift is measured over the second (the same frames again).

Live GL objects: moderngl objects reachable from Python that were not released, by type. (GL
object names are no leak measure on Mesa: it hands out ever-increasing names even when objects
are freed.) RSS covers everything else, including GL objects lost without a release."""
from __future__ import annotations

import argparse
import gc
import os
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import moderngl  # noqa: E402

from skinviewer import techniques  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import Settings, with_values  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402

_GL_TYPES = (moderngl.Texture, moderngl.Framebuffer, moderngl.Buffer, moderngl.VertexArray, moderngl.Program,
             moderngl.Renderbuffer, moderngl.Query)


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def live_gl() -> Counter:
    gc.collect()
    out = Counter()
    for o in gc.get_objects():
        if isinstance(o, _GL_TYPES) and type(getattr(o, "mglo", None)).__name__ != "InvalidObject":
            out[type(o).__name__] += 1
    return out


def schedule(frames: int, n_techniques: int, switch_every: int | None = None) -> tuple[int, int]:
    """(frames per technique turn, warm-up frames). Every technique gets a turn in the warm-up and
    again after it, so the drift is measured over as many frames as the warm-up, at any --frames
    (a fixed 500-frame turn made 8 techniques warm up for 4,000 frames: "drift over 0 frames" at the
    3,000-frame default)."""
    per = switch_every or frames // (2 * n_techniques)
    if per < 1 or 2 * per * n_techniques > frames:
        raise SystemExit(f"soak: --frames {frames} is too few for {n_techniques} techniques twice over "
                         f"({2 * n_techniques * max(per, 1)} needed)")
    return per, per * n_techniques


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=3000)
    ap.add_argument("--size", type=int, default=96, help="image size (square)")
    ap.add_argument("--maps", type=int, default=256, help="texture-space map size")
    ap.add_argument("--every", type=int, default=250, help="report every N frames")
    ap.add_argument("--switch-every", type=int, default=None,
                    help="frames per technique turn (default: --frames / (2 x techniques): each technique "
                         "runs once in the warm-up and once after it)")
    args = ap.parse_args()
    names = techniques.names()
    per, warm_frames = schedule(args.frames, len(names), args.switch_every)
    ctx = headless_context()
    r = Renderer(ctx)
    base = with_values(Settings(), {
        "render.width": args.size, "render.height": args.size, "scene.head_detail": 0,
        "shadow.map_size": args.maps, "gosselin.light_map_size": max(args.maps, 256),
        "deon.irradiance_size": max(args.maps, 256), "deon.tsm_size": args.maps})
    print(f"{len(names)} techniques, {per} frames each; warm-up: frames 0-{warm_frames} (each technique once), "
          f"then {args.frames - warm_frames} frames measured (each technique again)", flush=True)
    rows = []
    turn_end: dict[tuple[str, int], float] = {}  # (technique, round) -> RSS at the end of its turn
    t0 = time.perf_counter()
    warm = None
    for i in range(args.frames + 1):
        s = base
        tech = names[(i // per) % len(names)]
        edits = {"technique": tech, "camera.yaw": 25.0 + (i % 360)}
        if i % 7 == 0:  # a slider drag: a setting every 7th frame
            edits["lights.0.intensity"] = 1.0 + (i % 13) * 0.1
            edits["deon.mix"] = (i % 11) / 10.0
        if i % 97 == 0:  # a resize now and then
            edits["render.width"] = args.size + (i // 97) % 3 * 8
        s = with_values(s, edits)
        r.render(s)
        if i % 97 == 0:
            r.trim()
        if (i + 1) % per == 0 and i // per < 2 * len(names):
            ctx.finish()
            turn_end[(tech, i // (per * len(names)))] = rss_mb()
        if i % args.every == 0 or i == warm_frames:
            ctx.finish()
            gl = live_gl()
            row = (i, rss_mb(), sum(gl.values()), dict(gl), time.perf_counter() - t0)
            rows.append(row)
            if i == warm_frames:  # every technique ran once
                warm = row
            print(f"frame {i:6d}  RSS {row[1]:8.1f} MB  live GL objects {row[2]:4d}  {row[4]:7.1f} s  {tech}",
                  flush=True)
    r.release()
    gl_after = live_gl()
    first = warm
    last = rows[-1]
    print()
    print("| | frame | RSS MB | live GL objects |")
    print("| --- | --- | --- | --- |")
    for label, row in (("after warm-up", first), ("end", last)):
        print(f"| {label} | {row[0]} | {row[1]:.1f} | {row[2]} |")
    print(f"\nRSS drift after warm-up: {last[1] - first[1]:+.1f} MB over {last[0] - first[0]} frames; "
          f"live GL objects {first[2]} -> {last[2]}; after Renderer.release(): {sum(gl_after.values())} "
          f"{dict(gl_after)}")
    measured = [v for (t, rnd), v in turn_end.items() if rnd == 1]
    if measured:
        print(f"RSS at the end of each technique's measured turn: {min(measured):.1f} to {max(measured):.1f} MB "
              f"(spread {max(measured) - min(measured):.1f} MB; the warm-up's turns grew as each technique first "
              "ran, so they are no baseline)")
    print(f"live objects by type at the end: {last[3]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
