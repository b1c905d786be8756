"""Arguments shared by the commands that take a scene and settings (render, the viewer, and more)."""
from __future__ import annotations

import argparse

from skinviewer import techniques
from skinviewer.core.look import apply_look
from skinviewer.core.look import resolve as resolve_look
from skinviewer.core.settings import (
    Settings,
    load_preset,
    parse_assignments,
    with_values,
)
from skinviewer.scene.scenes import SCENES, scene_overrides


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
    d = Settings()
    g = p.add_argument_group("scene and settings (defaults come from the settings model: `skinviewer settings --list`)")
    g.add_argument("--scene", choices=SCENES, help=f"built-in scene (brings its own lights and camera); default: {d.scene.name}")
    g.add_argument("--mesh", help="glTF/GLB/OBJ/PLY mesh to render instead of a built-in scene")
    g.add_argument("--technique", help=f"one of {', '.join(techniques.names())}; default: {d.technique}")
    g.add_argument("--preset", help="preset JSON (a partial preset overrides the defaults)")
    g.add_argument("--set", dest="assign", action="append", default=[], metavar="KEY=VALUE",
                   help="set any setting by dotted path, e.g. --set lights.0.intensity=4 (repeatable)")
    g.add_argument("--size", type=_size, help=f"image size WxH; default: {d.render.width}x{d.render.height}")
    g.add_argument("--camera", type=_camera, help=f"yaw,pitch[,distance] in degrees and mesh units; default: {d.camera.yaw:g},{d.camera.pitch:g} at a distance that frames the mesh")


def _note_technique_conflict(preset: str, technique: str) -> None:
    """--technique X --preset Y where Y names another technique: say which one wins (the option)."""
    import json
    import sys
    try:
        with open(preset, encoding="utf-8-sig") as f:
            named = json.load(f).get("technique")
    except (OSError, ValueError, AttributeError):
        return
    if isinstance(named, str) and named != technique:
        print(f"skinviewer: note: --technique {technique} overrides the technique of preset {preset} ({named}); "
              f"its {named} settings are kept but unused", file=sys.stderr)


def settings_from_args(args) -> Settings:
    """Defaults <- scene's own lights/camera <- preset <- --mesh/--technique/--size/--camera <- --set."""
    s = Settings()
    if args.preset:
        s = apply_look(load_preset(args.preset))
    if args.scene:
        s = with_values(s, {"scene.name": args.scene, "scene.mesh": None, **scene_overrides(args.scene)})
    direct: dict = {}
    if args.mesh:
        direct["scene.mesh"] = args.mesh
    if args.technique:
        direct["technique"] = args.technique
        if args.preset:
            _note_technique_conflict(args.preset, args.technique)
    if args.size:
        direct["render.width"], direct["render.height"] = args.size
    if args.camera:
        direct["camera.yaw"], direct["camera.pitch"] = args.camera[:2]
        if len(args.camera) == 3:
            direct["camera.distance"] = args.camera[2]
    direct.update(parse_assignments(args.assign))
    # the artist model (core/look.py): --set look.* re-derives the profile, a hand edit of a derived table
    # hands it back to the table
    return resolve_look(with_values(s, direct), direct) if direct else apply_look(s)


