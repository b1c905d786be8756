"""Arguments shared by the commands that take a scene and settings (render, the viewer, and more)."""
from __future__ import annotations

import argparse
import math
import os

from skinviewer import techniques
from skinviewer.engine.look import apply_look
from skinviewer.engine.look import resolve as resolve_look
from skinviewer.ground.settings import (
    Settings,
    load_preset,
    parse_assignments,
    with_values,
)
from skinviewer.scene.scenes import SCENES, scene_overrides


class CliError(Exception):
    """One clear line for the user; exit code 2."""


def _preset(text: str) -> str:
    """A preset file; failing that, a shipped preset by name (``burley2_beyond``, or as the README
    writes it, ``presets/burley2_beyond.json``), which an installed wheel carries inside the package.
    A name that is neither stays as given, for load_preset's one-line error."""
    if os.path.exists(text):
        return text
    from skinviewer.ground.paths import presets_dir
    try:
        shipped = presets_dir()
    except FileNotFoundError:
        return text
    name = os.path.basename(text)
    for candidate in (shipped / name, shipped / f"{name}.json"):
        if candidate.is_file():
            return str(candidate)
    return text


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
    if not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(f"yaw, pitch and distance must be finite numbers (got '{text}')")
    if len(vals) == 3 and not vals[2] > 0:
        raise argparse.ArgumentTypeError(f"the distance must be > 0 (got '{text}')")
    return vals


def number(lo: float | None = None, hi: float | None = None, *, integer: bool = False, above: bool = False,
           allow_inf: bool = False):
    """An argparse ``type`` for a numeric argument checked up front: an integer or a finite number
    (``allow_inf``: +inf too) within [lo, hi] (``above``: strictly above lo). NaN is never a value."""
    def parse(text: str):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if integer else 'a number'}, got {text!r}") \
                from None
        if math.isnan(v) or (math.isinf(v) and not (allow_inf and v > 0)):
            raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
        if lo is not None and (v < lo or (above and v == lo)):
            raise argparse.ArgumentTypeError(f"must be {'>' if above else '>='} {lo:g}, got {text!r}")
        if hi is not None and v > hi:
            raise argparse.ArgumentTypeError(f"must be <= {hi:g}, got {text!r}")
        return v
    parse.__name__ = "integer" if integer else "number"  # argparse names the type in its messages
    return parse


def _same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
        return os.path.realpath(a) == os.path.realpath(b)
    except (OSError, ValueError):
        return False


def check_outputs(outputs: dict[str, str | os.PathLike | None], inputs: dict[str, str | os.PathLike | None],
                  settings: Settings | None = None) -> None:
    """CliError (one line, before anything is computed) when an output would replace one of the
    command's inputs (its preset, mesh, maps, or a file another output writes), or is a folder.
    ``settings``: its scene.mesh and maps count as inputs too."""
    from skinviewer.ground.settings import PATH_FIELDS
    ins = {k: v for k, v in inputs.items() if v}
    if settings is not None:
        for f in PATH_FIELDS:
            v = getattr(settings.scene, f, None)
            if v:
                ins.setdefault(f"scene.{f}", v)
    seen: dict[str, str | os.PathLike] = {}
    for flag, out in outputs.items():
        if not out:
            continue
        if os.path.isdir(out) and not flag.endswith("/"):
            raise CliError(f"{flag} {_shown(out)} is a folder; name a file")
        for what, path in list(ins.items()) + list(seen.items()):
            if _same_file(out, path):
                raise CliError(f"{flag} {_shown(out)} would overwrite {what} (the same file): "
                               "choose another output name")
        seen[flag] = out


def _shown(p: str | os.PathLike) -> str:
    return os.fsdecode(p).encode("utf-8", "backslashreplace").decode("utf-8")


def image_output(path: str | os.PathLike | None, flag: str, linear: bool = True, display: bool = True) -> None:
    """CliError unless ``path``'s extension names a format this writes (files.output_kind)."""
    from skinviewer.ground.files import OutputPathError, output_kind
    if path:
        try:
            output_kind(path, flag, linear=linear, display=display)
        except OutputPathError as exc:
            raise CliError(str(exc)) from None



def add_scene_args(p: argparse.ArgumentParser) -> None:
    d = Settings()
    g = p.add_argument_group("scene and settings (defaults come from the settings model: `skinviewer settings --list`)")
    g.add_argument("--scene", choices=SCENES, help=f"built-in scene (brings its own lights and camera); default: {d.scene.name}")
    g.add_argument("--mesh", help="glTF/GLB/OBJ/PLY mesh to render instead of a built-in scene")
    g.add_argument("--technique", help=f"one of {', '.join(techniques.names())}; default: {d.technique}")
    g.add_argument("--preset", type=_preset, help="preset JSON (a partial preset overrides the defaults), or the "
                   "name of a shipped preset (e.g. burley2_beyond)")
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
    # the artist model (engine/look.py): --set look.* re-derives the profile, a hand edit of a derived table
    # hands it back to the table
    return resolve_look(with_values(s, direct), direct) if direct else apply_look(s)


