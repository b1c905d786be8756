"""Shared fixtures: one headless GL context per test session (llvmpipe through EGL)."""
from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest
from skip_guard import configure as _skip_guard_configure
from skip_guard import (  # noqa: F401
    pytest_runtest_logreport,
    pytest_sessionfinish,
    pytest_terminal_summary,
)

# CI clones the project with shared/ beside the checkout: ../shared from the project root
SHARED = Path(os.environ.get("SKINVIEWER_SHARED") or Path(__file__).resolve().parents[2] / "shared")
LPS_GLB = SHARED / "assets" / "lee-perry-smith" / "LeePerrySmith.glb"
NEEDS_SCAN = pytest.mark.skipif(
    not LPS_GLB.is_file(),
    reason=f"needs the shared Lee Perry-Smith scan at {LPS_GLB} (../shared beside the checkout, or SKINVIEWER_SHARED)")


_XVFB = None


def _start_xvfb() -> str | None:
    """Start a private Xvfb (when installed) and return its display name."""
    global _XVFB
    exe = shutil.which("Xvfb")
    if exe is None:
        return None
    r, w = os.pipe()
    proc = subprocess.Popen([exe, "-displayfd", str(w), "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
                            pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(w)
    num = b""
    deadline = time.monotonic() + 10
    with os.fdopen(r, "rb") as f:
        while time.monotonic() < deadline:
            ch = f.read(1)
            if not ch or ch == b"\n":
                break
            num += ch
    if not num:
        proc.kill()
        return None
    _XVFB = proc
    return f":{num.decode().strip()}"


def pytest_configure(config):
    _skip_guard_configure(config)
    # One GL platform per test process: with a display (xvfb-run, or a private Xvfb started here)
    # the in-process headless context is GLX, so the viewer tests' GLX window can coexist with it.
    if not os.environ.get("DISPLAY"):
        disp = _start_xvfb()
        if disp:
            os.environ["DISPLAY"] = disp


def pytest_unconfigure(config):
    if _XVFB is not None:
        _XVFB.terminate()
        _XVFB.wait(5)


@pytest.fixture(scope="session", autouse=True)
def _cache_dir(tmp_path_factory):
    # generated assets (the default head) cached per test session unless the caller chose a folder
    if "SKINVIEWER_CACHE" not in os.environ:
        os.environ["SKINVIEWER_CACHE"] = str(tmp_path_factory.mktemp("cache"))


@pytest.fixture(scope="session")
def gl_ctx():
    from skinviewer.kernel.gl import GLUnavailableError, headless_context
    try:
        ctx = headless_context(backend="x11" if os.environ.get("DISPLAY") else None)
    except GLUnavailableError as exc:
        pytest.skip(str(exc))
    yield ctx
    ctx.release()


@pytest.fixture(autouse=True)
def _current_gl(request):
    """A test that uses the session context gets it made current again (a viewer test's window
    context may be current on this thread), and a test of a module's ``viewer`` its window's context (its
    frame buffers are that context's objects: drawn with another current, they are incomplete)."""
    if "gl_ctx" in request.fixturenames:
        request.getfixturevalue("gl_ctx").__enter__()
    elif "viewer" in request.fixturenames:  # a module's viewer, after a test made the session context current
        native = request.getfixturevalue("viewer").wnd._window
        if hasattr(native, "switch_to"):  # pyglet
            native.switch_to()
        else:
            import glfw
            glfw.make_context_current(native)
    yield


@pytest.fixture
def renderer(gl_ctx):
    from skinviewer.engine.renderer import Renderer
    r = Renderer(gl_ctx)
    yield r
    r.release()


@pytest.fixture(scope="module")
def generic(gl_ctx):
    """A renderer whose shaders are the generic, uniform-driven ones (GENERIC_SHADERS): what every
    specialised variant must equal."""
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.shaders import ShaderLibrary
    r = Renderer(gl_ctx, ShaderLibrary(gl_ctx, defines={"GENERIC_SHADERS": 1}))
    yield r
    r.release()
    r.shaders.release()


@pytest.fixture
def shader_dir(tmp_path):
    """A shader folder with the graph tests' fill and add programs (helpers.graph_test_shaders)."""
    from helpers import graph_test_shaders
    return graph_test_shaders(tmp_path)
