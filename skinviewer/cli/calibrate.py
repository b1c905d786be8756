"""``skinviewer calibrate``: time every technique's preview ladder on this machine for the viewer's
quality governor (engine/calibration.py), cached per GL renderer string and mesh size class."""
from __future__ import annotations

import sys

from skinviewer import techniques
from skinviewer.cli.args import CliError, add_scene_args, settings_from_args


def add_parser(sub) -> None:
    p = sub.add_parser("calibrate", help="time each technique's preview configurations on this machine "
                                         "(the viewer's quality governor)")
    add_scene_args(p)
    p.add_argument("--techniques", help="comma-separated subset of the registry (default: all; others kept)")
    p.add_argument("--runs", type=int, default=2, help="timed frames per configuration and move (median)")
    p.set_defaults(func=cmd_calibrate)


def cmd_calibrate(args) -> int:
    from skinviewer.engine import calibration
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    s = settings_from_args(args)
    names = [n.strip() for n in args.techniques.split(",")] if args.techniques else None
    bad = [n for n in names or [] if n not in techniques.names()]
    if bad:
        raise CliError(f"unknown technique(s) {', '.join(bad)} (have: {', '.join(techniques.names())})")
    if args.runs < 1:
        raise CliError("--runs must be at least 1")
    ctx = headless_context()
    r = Renderer(ctx)
    try:
        scene = r.ensure_scene(s)
        mclass = calibration.mesh_class(len(scene.gpu.mesh.indices))
        old, why = calibration.load(calibration.renderer_name(ctx), mclass)
        if why:
            print(why, file=sys.stderr)
        cal = calibration.calibrate(r, s, names, args.runs, into=old if names else None,
                                    progress=lambda what, i, n: print(f"[{i + 1}/{n}] {what}", file=sys.stderr))
        path = calibration.save(cal)
        old_truth = calibration.stale_truth(cal)
        if old_truth:
            print(old_truth, file=sys.stderr)
    finally:
        r.release()
        ctx.release()
    print(f"# {cal.renderer}, {cal.mesh_class} meshes, view {cal.size[0]}x{cal.size[1]}; sync timing, medians")
    print(f"{'technique':<10} {'configuration':<48} {'light ms':>9} {'camera ms':>9} {'error':>7}")
    for t, es in cal.entries.items():
        for e in es:
            err = "" if e.error is None else f"{e.error:.1%}"
            print(f"{t:<10} {e.label:<48} {e.light_ms:9.1f} {e.camera_ms:9.1f} {err:>7}")
    print(f"wrote {path}")
    return 0
