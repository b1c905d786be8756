"""The ``skinviewer`` command's entry point: the viewer's window first, everything else after.

``skinviewer`` / ``python3 -m skinviewer`` with no command (or ``view``), interactively (no
``--frames``/``--screenshot``/``--help``, a display present): the window opens and shows its start-up
screen within about a second (moderngl-window and glfw only), then the command line, the settings,
the techniques' graphs, imgui and the rest are imported in a worker thread while the screen ticks,
and the viewer takes the window over (ui/startup.py). Anything else goes to ``skinviewer.cli.main``
as before. Standard library only at import."""
from __future__ import annotations

import os
import re
import sys

_NOT_INTERACTIVE = {"-h", "--help", "--version", "--frames", "--screenshot"}


def early_window_size(argv: list[str]) -> tuple[int, int] | None:
    """The window size of an interactive viewer launch (``--size WxH`` or the default), None when
    ``argv`` is not one (another command, a batch run, help) or there is no display."""
    if argv and argv[0] != "view" and not argv[0].startswith("-"):
        return None
    if any(a.split("=")[0] in _NOT_INTERACTIVE for a in argv):
        return None
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) and sys.platform.startswith("linux"):
        return None
    from skinviewer.ui.startup import DEFAULT_WINDOW
    size = DEFAULT_WINDOW
    for i, a in enumerate(argv):
        text = a.split("=", 1)[1] if a.startswith("--size=") else argv[i + 1] if a == "--size" and i + 1 < len(argv) else None
        m = re.fullmatch(r"(\d+)[xX](\d+)", text or "")
        if m and 0 < int(m.group(1)) <= 16384 and 0 < int(m.group(2)) <= 16384:
            size = (int(m.group(1)), int(m.group(2)))
    return size


def _import_viewer() -> None:
    import skinviewer.cli  # noqa: F401  (the command line: settings, techniques, scenes)
    try:
        import skinviewer.ui.app  # noqa: F401  (the viewer: renderer, imgui, windows)
    except ImportError:
        pass  # the command line says in one line that the viewer is not available


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    size = early_window_size(argv)
    if size is None:
        from skinviewer.cli import main as cli_main
        return cli_main(argv)
    from skinviewer.ui import startup
    sp = startup.open_early(size)
    try:
        if sp is not None:
            sp.run("loading the viewer (settings, techniques, imgui)", _import_viewer)
        from skinviewer.cli import main as cli_main
        return cli_main(argv)
    except KeyboardInterrupt:  # Ctrl-C while the modules load
        print("skinviewer: interrupted (Ctrl-C)", file=sys.stderr)
        return 130
    finally:
        startup.close_early()  # not taken (bad arguments: their one line is printed)


if __name__ == "__main__":
    sys.exit(main())
