"""Command line: ``skinviewer`` (the viewer), ``skinviewer render`` (headless), ``skinviewer profile``,
``skinviewer reference`` (the ground truth) and ``skinviewer bench`` (accuracy vs time)."""
from __future__ import annotations

import argparse
import sys

from skinviewer import __version__, techniques
from skinviewer.cli import settings_list
from skinviewer.cli.args import (
    CliError,
    add_scene_args,
    check_outputs,
    image_output,
    number,
    settings_from_args,
)
from skinviewer.cli.render import cmd_render
from skinviewer.ground.settings import SettingsError


class OneLineParser(argparse.ArgumentParser):
    """argparse with errors in one line (no usage block), a "did you mean" where a close name exists,
    and a pointer to --help; exit status 2 as before. Sub-commands inherit it (add_subparsers)."""

    def error(self, message: str):
        import difflib
        import re
        hint = ""
        m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if m:
            choices = re.findall(r"'([^']*)'", m.group(2))
            close = difflib.get_close_matches(m.group(1), choices, n=1, cutoff=0.5)
            if close:
                hint = f"; did you mean '{close[0]}'?"
        m = re.search(r"unrecognized arguments: (\S+)", message)
        if m:
            parsers = [self] + [sp for a in self._actions if isinstance(a, argparse._SubParsersAction)
                                for sp in a.choices.values()]
            opts = sorted({o for sp in parsers for a in sp._actions for o in a.option_strings})
            close = difflib.get_close_matches(m.group(1).split("=")[0], opts, n=1, cutoff=0.6)
            if close:
                hint = f"; did you mean {close[0]}?"
        if "required: --out" in message:
            hint = "; e.g. --out head.png"
        self.exit(2, f"{self.prog}: {message}{hint} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="skinviewer", description="Interactive tuning of real-time skin shaders.")
    p.add_argument("--version", action="version", version=f"skinviewer {__version__}")
    sub = p.add_subparsers(dest="command")

    pr = sub.add_parser("render", help="render one frame headless to a PNG")
    add_scene_args(pr)
    pr.add_argument("--out", required=True, help="output image: .png, .jpg, .tif or .bmp (display-encoded), or .exr "
                    "(the linear HDR image as OpenEXR)")
    pr.add_argument("--exr", metavar="FILE.exr", help="also write the linear HDR image (before exposure and tone map) "
                    "as OpenEXR, for compositing and comparison tools")
    pr.add_argument("--dump-passes", metavar="DIR", help="write every intermediate texture (.npy + .png) and graph.json")
    pr.add_argument("--timings", metavar="FILE.json", help="write per-pass times of the frame")
    pr.add_argument("-v", "--verbose", action="store_true", help="print the pass table")
    pr.set_defaults(func=cmd_render)

    from skinviewer.cli import reference as reference_cli
    reference_cli.add_parsers(sub)

    try:
        from skinviewer.cli import profile as profile_cli
        profile_cli.add_parser(sub)
    except ImportError:
        pass

    settings_list.add_parser(sub)

    from skinviewer.cli import export as export_cli
    from skinviewer.cli import import_ as import_cli
    from skinviewer.cli import sheet as sheet_cli
    from skinviewer.cli import turntable as turntable_cli
    export_cli.add_parser(sub)
    import_cli.add_parser(sub)
    turntable_cli.add_parser(sub)
    sheet_cli.add_parser(sub)
    from skinviewer.cli import calibrate as calibrate_cli
    calibrate_cli.add_parser(sub)

    pv = sub.add_parser("view", help="open the viewer (the default command)")
    _add_view_args(pv)
    pv.set_defaults(func=cmd_view)
    return p


def _add_view_args(p: argparse.ArgumentParser) -> None:
    add_scene_args(p)
    p.add_argument("--frames", type=number(0, 10**7, integer=True),
                   help="render N frames, then exit (with --screenshot: save it)")
    p.add_argument("--screenshot", help="image to write after --frames: .png, .jpg, .tif, .bmp, or .exr (the "
                   "linear HDR image)")


def cmd_view(args) -> int:
    try:
        from skinviewer.ui.app import WindowUnavailableError, run_viewer
    except ImportError as exc:
        raise CliError(f"the viewer is not available: {exc}") from None
    s = settings_from_args(args)
    if args.screenshot:
        image_output(args.screenshot, "--screenshot")
        check_outputs({"--screenshot": args.screenshot}, {"--preset": args.preset}, s)
    if getattr(args, "technique", None) and args.technique not in techniques.names():
        raise CliError(f"technique '{args.technique}' is not available (have: {', '.join(techniques.names())})")
    try:
        return run_viewer(s, technique_given=bool(getattr(args, "technique", None)), frames=args.frames or 0,
                          screenshot=args.screenshot, size=tuple(args.size) if args.size else None,
                          preset_path=args.preset, debug=bool(getattr(args, "debug", False)))
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
    commands = {"render", "profile", "view", "settings", "reference", "bench", "export", "import", "turntable", "sheet",
                "calibrate", "-h", "--help", "--version"}
    if argv and argv[0] not in commands and not argv[0].startswith("-"):
        import difflib
        close = difflib.get_close_matches(argv[0], sorted(commands - {"calibrate", "-h", "--help", "--version"}), n=1, cutoff=0.6)
        print(f"skinviewer: unknown command '{argv[0]}'" + (f"; did you mean '{close[0]}'?" if close else "")
              + " (see skinviewer --help)", file=sys.stderr)
        return 2
    if not argv or argv[0] not in commands:
        argv = ["view"] + argv  # `skinviewer --mesh X` opens the viewer
    try:
        args = parser.parse_args(argv)
        return int(args.func(args) or 0)
    except KeyboardInterrupt:  # Ctrl-C: writers remove their temporaries on the way out
        print("skinviewer: interrupted (Ctrl-C)", file=sys.stderr)
        return 130
    except SettingsError as exc:
        where = f"{exc.source}: " if exc.source else ""
        print(f"skinviewer: invalid settings: {where}" + "; ".join(f"{p}: {m}" for p, m in exc.errors), file=sys.stderr)
    except BrokenPipeError:  # `skinviewer settings --list | head`
        return 0
    except CliError as exc:
        print(f"skinviewer: {exc}", file=sys.stderr)
    except KeyError as exc:
        print(f"skinviewer: {exc.args[0] if exc.args else exc}", file=sys.stderr)
    except Exception as exc:  # a clear line, not a traceback, for anything the user can cause
        from skinviewer.ground.files import OutputPathError
        from skinviewer.kernel.gl import GLUnavailableError
        from skinviewer.kernel.graph import ResourceLimitError
        from skinviewer.kernel.shaders import ShaderCompileError
        from skinviewer.scene.mesh import MeshError
        if isinstance(exc, (GLUnavailableError, MeshError, ShaderCompileError, OSError, ResourceLimitError,
                            OutputPathError)):
            print(f"skinviewer: {exc}", file=sys.stderr)
        else:
            raise
    return 2


if __name__ == "__main__":
    sys.exit(main())
