"""Shared fixtures: one headless GL context per test session (llvmpipe through EGL)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[2] / "shared"
LPS_GLB = SHARED / "assets" / "lee-perry-smith" / "LeePerrySmith.glb"


@pytest.fixture(scope="session", autouse=True)
def _cache_dir(tmp_path_factory):
    # generated assets (the default head) cached per test session unless the caller chose a folder
    if "SKINVIEWER_CACHE" not in os.environ:
        os.environ["SKINVIEWER_CACHE"] = str(tmp_path_factory.mktemp("cache"))


@pytest.fixture(scope="session")
def gl_ctx():
    from skinviewer.gl import GLUnavailableError, headless_context
    try:
        ctx = headless_context()
    except GLUnavailableError as exc:
        pytest.skip(str(exc))
    yield ctx
    ctx.release()


@pytest.fixture
def renderer(gl_ctx):
    from skinviewer.renderer import Renderer
    r = Renderer(gl_ctx)
    yield r
    r.release()
