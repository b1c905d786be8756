"""Command line: ``skinviewer`` (the viewer), ``skinviewer render`` (headless), ``skinviewer profile``."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from .files import atomic_write_text, save_npy, save_png
from .settings import Settings, SettingsError, load_preset, parse_assignments, with_values


class CliError(Exception):
    """One clear line for the user; exit code 2."""


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size expects WxH, e.g. 640x640 (got '{text}')") from None
    return w, h


def _camera(text: str) -> list[float]:
    try:
        vals = [float(x) for x in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in (2, 3):
        raise argparse.ArgumentTypeError(f"--camera expects yaw,pitch[,distance] in degrees/mesh units (got '{text}')")
    return vals


def add_scene_args(p: argparse.ArgumentParser) -> None:
    from .scenes import SCENES
    g = p.add_argument_group("scene and settings")
    g.add_argument("--scene", choices=SCENES, help="built-in scene (brings its own lights and camera)")
    g.add_argument("--mesh", help="glTF/GLB/OBJ/PLY mesh to render instead of a built-in scene")
    g.add_argument("--technique", help="phong, gosselin or deon")
    g.add_argument("--preset", help="preset JSON (a partial preset overrides the defaults)")
    g.add_argument("--set", dest="assign", action="append", default=[], metavar="KEY=VALUE",
                   help="set any setting by dotted path, e.g. --set lights.0.intensity=4 (repeatable)")
    g.add_argument("--size", type=_size, help="image size WxH")
    g.add_argument("--camera", type=_camera, help="yaw,pitch[,distance]")


def settings_from_args(args) -> Settings:
    """Defaults <- scene's own lights/camera <- preset <- --mesh/--technique/--size/--camera <- --set."""
    from .scenes import scene_overrides
    s = Settings()
    if args.preset:
        s = load_preset(args.preset)
    if args.scene:
        s = with_values(s, {"scene.name": args.scene, "scene.mesh": None, **scene_overrides(args.scene)})
    direct: dict = {}
    if args.mesh:
        direct["scene.mesh"] = args.mesh
    if args.technique:
        direct["technique"] = args.technique
    if args.size:
        direct["render.width"], direct["render.height"] = args.size
    if args.camera:
        direct["camera.yaw"], direct["camera.pitch"] = args.camera[:2]
        if len(args.camera) == 3:
            direct["camera.distance"] = args.camera[2]
    direct.update(parse_assignments(args.assign))
    return with_values(s, direct) if direct else s


def _preview(arr: np.ndarray) -> np.ndarray:
    """A PNG preview of a float texture: RGB (or gray), scaled to its 99.5th percentile."""
    a = np.nan_to_num(arr.astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    rgb = a[..., :3] if a.shape[-1] >= 3 else np.repeat(a[..., :1], 3, axis=-1)
    if rgb.shape[-1] == 2:
        rgb = np.concatenate([rgb, np.zeros_like(rgb[..., :1])], axis=-1)
    hi = float(np.percentile(np.abs(rgb), 99.5)) or 1.0
    return (np.clip(rgb / hi, 0, 1) * 255 + 0.5).astype(np.uint8)[::-1]


def cmd_render(args) -> int:
    from .gl import headless_context
    from .renderer import Renderer

    s = settings_from_args(args)
    ctx = headless_context()
    r = Renderer(ctx)
    try:
        scene = r.ensure_scene(s)
        for note in scene.notes:
            print(f"note: {note}", file=sys.stderr)
        report = r.render(s)
        out = Path(args.out)
        save_png(out, r.image(s))
        print(f"wrote {out} ({s.render.width}x{s.render.height}, {s.technique}, "
              f"{report.total_ms:.1f} ms {report.timing_mode})")
        if args.timings:
            atomic_write_text(args.timings, json.dumps(report.to_json(), indent=2) + "\n")
        if args.dump_passes:
            dump_passes(r, s, report, Path(args.dump_passes))
            print(f"dumped {len(r.graph(s.technique).resources())} textures to {args.dump_passes}")
        if args.verbose:
            print(report.table())
    finally:
        r.release()
        ctx.release()
    return 0


def dump_passes(r, s: Settings, report, folder: Path) -> None:
    """Every intermediate texture as float32 .npy + PNG preview, and graph.json."""
    g = r.graph(s.technique)
    for res in g.resources():
        arr = g.read(res)
        save_npy(folder / f"{res}.npy", arr)
        save_png(folder / f"{res}.png", _preview(arr))
    data = report.to_json()
    data["technique"] = s.technique
    data["order"] = [p.name for p in g.order]
    atomic_write_text(folder / "graph.json", json.dumps(data, indent=2) + "\n")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="skinviewer", description="Interactive tuning of real-time skin shaders.")
    sub = p.add_subparsers(dest="command")

    pr = sub.add_parser("render", help="render one frame headless to a PNG")
    add_scene_args(pr)
    pr.add_argument("--out", required=True, help="output PNG")
    pr.add_argument("--dump-passes", metavar="DIR", help="write every intermediate texture (.npy + .png) and graph.json")
    pr.add_argument("--timings", metavar="FILE.json", help="write per-pass times of the frame")
    pr.add_argument("-v", "--verbose", action="store_true", help="print the pass table")
    pr.set_defaults(func=cmd_render)

    try:
        from . import profile_cli
        profile_cli.add_parser(sub)
    except ImportError:
        pass

    pv = sub.add_parser("view", help="open the viewer (the default command)")
    _add_view_args(pv)
    pv.set_defaults(func=cmd_view)
    return p


def _add_view_args(p: argparse.ArgumentParser) -> None:
    add_scene_args(p)
    p.add_argument("--frames", type=int, help="render N frames, then exit (with --screenshot: save it)")
    p.add_argument("--screenshot", help="PNG to write after --frames")


def cmd_view(args) -> int:
    try:
        from .app import WindowUnavailableError, run_viewer
    except ImportError as exc:
        raise CliError(f"the viewer is not available: {exc}") from None
    try:
        return run_viewer(args)
    except WindowUnavailableError as exc:
        raise CliError(str(exc)) from None


def _join_negative_values(argv: list[str]) -> list[str]:
    """``--camera -75,5`` would read as an unknown option to argparse: bind such values to their flag."""
    out: list[str] = []
    it = iter(range(len(argv)))
    for i in it:
        a = argv[i]
        if a in ("--camera", "--size") and i + 1 < len(argv) and argv[i + 1][:1] == "-" \
                and argv[i + 1][1:2].isdigit():
            out.append(f"{a}={argv[i + 1]}")
            next(it, None)
        else:
            out.append(a)
    return out


def main(argv: list[str] | None = None) -> int:
    argv = _join_negative_values(list(sys.argv[1:] if argv is None else argv))
    parser = build_parser()
    commands = {"render", "profile", "view", "-h", "--help"}
    if not argv or argv[0] not in commands:
        argv = ["view"] + argv  # `skinviewer --mesh X` opens the viewer
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SettingsError as exc:
        where = f"{exc.source}: " if exc.source else ""
        print(f"skinviewer: invalid settings: {where}" + "; ".join(f"{p}: {m}" for p, m in exc.errors), file=sys.stderr)
    except CliError as exc:
        print(f"skinviewer: {exc}", file=sys.stderr)
    except KeyError as exc:
        print(f"skinviewer: {exc.args[0] if exc.args else exc}", file=sys.stderr)
    except Exception as exc:  # a clear line, not a traceback, for anything the user can cause
        from .gl import GLUnavailableError
        from .mesh import MeshError
        from .shaders import ShaderCompileError
        if isinstance(exc, (GLUnavailableError, MeshError, ShaderCompileError, OSError)):
            print(f"skinviewer: {exc}", file=sys.stderr)
        else:
            raise
    return 2


if __name__ == "__main__":
    sys.exit(main())
