"""``skinviewer turntable``: an orbit of the camera (or, ``--light-orbit``, of the lights) rendered
headless to an MP4 (imageio-ffmpeg's own encoder), a GIF (Pillow) or a folder of PNGs; progress bar,
Ctrl-C cancels and leaves nothing behind."""
from __future__ import annotations

import argparse
import io
import math
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from skinviewer.cli.args import add_scene_args, check_outputs, settings_from_args
from skinviewer.ground.files import atomic_path, atomic_write_bytes, save_png
from skinviewer.ground.settings import Settings, with_values

MAX_FRAMES = 3600


class Cancelled(Exception):
    pass


def orbit(s: Settings, frames: int, light_orbit: bool = False, degrees: float = 360.0) -> list[Settings]:
    """``frames`` settings evenly around the orbit: the camera's yaw, or every light turned about +Y
    (directions; point/beam positions about the Y axis through the origin; an environment's yaw)."""
    out = []
    for i in range(frames):
        a = degrees * i / frames
        if not light_orbit:
            out.append(with_values(s, {"camera.yaw": s.camera.yaw + a}))
            continue
        c, sn = math.cos(math.radians(a)), math.sin(math.radians(a))
        vals: dict[str, float | list[float]] = {}
        for j, L in enumerate(s.lights):
            x, y, z = L.direction
            vals[f"lights.{j}.direction"] = [c * x + sn * z, y, -sn * x + c * z]
            x, y, z = L.position
            vals[f"lights.{j}.position"] = [c * x + sn * z, y, -sn * x + c * z]
            if L.kind == "environment":  # the environment turns with the lights (its yaw: the same sense)
                vals[f"lights.{j}.yaw"] = L.yaw + a
        out.append(with_values(s, vals))
    return out


def render_frames(first: Settings, settings: Iterable[Settings],
                  progress: Callable[[int], None] | None = None,
                  cancel: Callable[[], bool] | None = None) -> Iterator[tuple[np.ndarray, float]]:
    """Rendered sRGB frames (uint8, top row first) with each frame's wall-clock ms (sync timing:
    GL timer queries are not trusted on llvmpipe)."""
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    ctx = headless_context()
    r = Renderer(ctx)
    try:
        r.ensure_scene(first)
        for i, s in enumerate(settings):
            if cancel is not None and cancel():
                raise Cancelled()
            t0 = time.perf_counter()
            r.render_settled(s, timing="sync")
            img = r.image(s)
            ms = 1000.0 * (time.perf_counter() - t0)
            if progress is not None:
                progress(i + 1)
            yield img, ms
    finally:
        r.release()
        ctx.release()


def _even(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    return np.pad(img, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge") if (h % 2 or w % 2) else img


def kind_of(out: str) -> str:
    low = out.lower()
    if low.endswith(".mp4"):
        return "mp4"
    if low.endswith(".gif"):
        return "gif"
    if out.endswith(("/", os.sep)) or not Path(out).suffix:
        return "frames"
    raise ValueError(f"--out must end in .mp4, .gif or / (a folder of PNGs), got {out!r}")


def write_turntable(out: str, frames: Iterable[np.ndarray], fps: float) -> Path:
    """Writes every frame; the result appears only when complete (temporary file/folder renamed)."""
    kind = kind_of(out)
    target = Path(out.rstrip("/" + os.sep)) if kind == "frames" else Path(out)
    if kind == "mp4":
        import imageio_ffmpeg
        with atomic_path(target, suffix=".mp4") as tmp:
            writer = None
            try:
                for img in frames:
                    img = _even(np.ascontiguousarray(img[..., :3]))
                    if writer is None:
                        writer = imageio_ffmpeg.write_frames(str(tmp), (img.shape[1], img.shape[0]), fps=fps,
                                                             quality=8, macro_block_size=1,
                                                             ffmpeg_log_level="error")
                        writer.send(None)
                    writer.send(img)
            finally:
                if writer is not None:
                    writer.close()
            if writer is None:
                raise ValueError("no frames")
        return target
    if kind == "gif":
        from PIL import Image
        imgs = [Image.fromarray(np.ascontiguousarray(f[..., :3])) for f in frames]
        if not imgs:
            raise ValueError("no frames")
        buf = io.BytesIO()
        imgs[0].save(buf, format="GIF", save_all=True, append_images=imgs[1:], duration=round(1000 / fps),
                     loop=0, optimize=False)
        atomic_write_bytes(target, buf.getvalue())
        return target
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise ValueError(f"{target} exists and is not an empty folder")
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.{os.getpid()}-", suffix=".tmp", dir=str(target.parent)))
    try:
        n = 0
        for n, img in enumerate(frames, 1):
            save_png(tmp / f"frame_{n - 1:04d}.png", img)
        if n == 0:
            raise ValueError("no frames")
        if target.exists():
            target.rmdir()
        os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return target


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser("turntable", help="render an orbit headless to MP4, GIF or PNG frames",
                       description="The camera (or with --light-orbit the lights) turns 360 degrees about +Y.")
    add_scene_args(p)
    p.add_argument("--frames", type=int, default=72, help="frames per turn (default 72)")
    p.add_argument("--fps", type=float, default=24.0, help="frames per second of the MP4/GIF (default 24)")
    p.add_argument("--light-orbit", action="store_true", help="turn the lights instead of the camera")
    p.add_argument("--out", required=True, help="spin.mp4, spin.gif, or frames/ (a folder of PNGs)")
    p.add_argument("--progress-lines", action="store_true",
                   help="print 'progress N TOTAL' lines instead of a bar (for the viewer, which runs this)")
    p.set_defaults(func=cmd_turntable)
    return p


def cmd_turntable(args) -> int:
    def fail(msg: str) -> int:
        print(f"skinviewer turntable: error: {msg}", file=sys.stderr)
        return 2
    if not (1 <= args.frames <= MAX_FRAMES):
        return fail(f"--frames must be between 1 and {MAX_FRAMES}")
    if not (math.isfinite(args.fps) and 0 < args.fps <= 240):
        return fail("--fps must be in (0, 240]")
    try:
        kind_of(args.out)
    except ValueError as exc:
        return fail(str(exc))
    s = settings_from_args(args)
    check_outputs({"--out/" if kind_of(args.out) == "frames" else "--out": args.out}, {"--preset": args.preset}, s)
    views = orbit(s, args.frames, args.light_orbit)
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
    )
    times: list[float] = []
    with Progress(TextColumn("{task.description:<12}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  transient=False, disable=args.progress_lines) as bar:
        task = bar.add_task("turntable", total=len(views))

        def step(n: int) -> None:
            bar.update(task, completed=n)
            if args.progress_lines:
                print(f"progress {n} {len(views)}", flush=True)

        def frames() -> Iterator[np.ndarray]:
            for img, ms in render_frames(s, views, progress=step):
                times.append(ms)
                yield img
        try:
            out = write_turntable(args.out, frames(), args.fps)
        except KeyboardInterrupt:
            print("skinviewer turntable: cancelled, nothing written", file=sys.stderr)
            return 130
        except ValueError as exc:
            return fail(str(exc))
    print(f"wrote {out} ({len(times)} frames, {s.render.width}x{s.render.height}, {s.technique}, "
          f"{'lights' if args.light_orbit else 'camera'} orbit, median {float(np.median(times)):.0f} ms/frame)")
    return 0
