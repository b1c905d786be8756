"""Issue 27: a pass shared between the user's graph and a governor preview's graph (RenderGraph.share_passes).

After a light drag the user's graph re-rendered the key light's shadow map that the preview's graph had
just made at the same light. A pass that reads no texture computes from its cache key alone, so an equal
key in the other graph of the same technique holds the same outputs: they are copied, not re-run. These
tests check that the copy is the pass's own result bit for bit, that it is never stale after a settings
change on either side, and that a pass reading a texture, or part-way through its bands, is never copied."""
from __future__ import annotations

import numpy as np
import pytest

from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import with_values
from tests.helpers import small_settings

PREVIEW = "preview share-test"
SHADOW = "shadow_map_0"


def status(rep, name):
    return next(p for p in rep.passes if p.name == name)


def fresh(gl_ctx, s, name):
    """``name`` as a renderer that never saw another graph makes it for ``s``."""
    r = Renderer(gl_ctx)
    try:
        r.render(s)
        return r.graph(s.technique).read(name).copy(), r.image(s)
    finally:
        r.release()


@pytest.fixture
def rig():
    user = small_settings("head", "separable", size=64)
    # a preview: a smaller view and fewer taps (a graph of its own), the same lights and shadow maps
    preview = with_values(user, {"render.width": 32, "render.height": 32, "separable.taps": 7})
    return user, preview


def test_a_shadow_map_the_preview_made_is_copied_not_rerun_and_equals_the_pass_s_own(renderer, gl_ctx, rig):
    user, preview = rig
    renderer.render(preview, variant=PREVIEW, interactive=True)  # the drag's last preview, light where it ends
    rep = renderer.render(user)  # the refinement's final frame in the user's graph
    rec = status(rep, SHADOW)
    assert rec.status == "ran" and "copied" in rec.reason, rec.reason
    assert rec.draws == 0  # nothing drawn: a copy
    assert not any("copied" in p.reason for p in rep.passes if p.inputs)  # a pass reading a texture runs
    want_map, want_img = fresh(gl_ctx, user, SHADOW)
    assert np.array_equal(renderer.graph("separable").read(SHADOW), want_map)
    assert np.array_equal(renderer.image(user), want_img)  # the final image is the ungoverned render's, bit for bit
    # and back: a preview at the same light copies the user's map (an orbit after the refinement)
    rep = renderer.render(with_values(preview, {"camera.yaw": 12.0}), variant=PREVIEW, interactive=True)
    assert status(rep, SHADOW).status == "cached"  # its own cache still holds it: nothing to copy


def test_a_shared_pass_is_never_stale_after_a_settings_change(renderer, gl_ctx, rig):
    user, preview = rig
    moved = {"lights.0.direction": (0.7, 0.2, 0.6)}
    renderer.render(user)
    renderer.render(preview, variant=PREVIEW, interactive=True)  # copied from the user's graph
    # the user's graph moves the light: the preview's graph holds the old key, so the user's runs its own
    rep = renderer.render(with_values(user, moved))
    assert status(rep, SHADOW).status == "ran" and "copied" not in status(rep, SHADOW).reason
    # the preview at the old light keeps its own copy untouched by the user's re-render
    rep = renderer.render(with_values(preview, {"camera.yaw": 5.0}), variant=PREVIEW, interactive=True)
    assert status(rep, SHADOW).status == "cached"
    old_map, _ = fresh(gl_ctx, user, SHADOW)
    assert np.array_equal(renderer.graph("separable", PREVIEW).read(SHADOW), old_map)
    # the preview moves too: copied from the user's graph, now at the new light
    rep = renderer.render(with_values(preview, moved), variant=PREVIEW, interactive=True)
    assert "copied" in status(rep, SHADOW).reason
    new_map, _ = fresh(gl_ctx, with_values(user, moved), SHADOW)
    assert not np.array_equal(new_map, old_map)
    assert np.array_equal(renderer.graph("separable", PREVIEW).read(SHADOW), new_map)
    # the user goes back to the old light: no graph holds that key any more, it runs, and is the old map
    rep = renderer.render(user)
    assert status(rep, SHADOW).status == "ran" and "copied" not in status(rep, SHADOW).reason
    assert np.array_equal(renderer.graph("separable").read(SHADOW), old_map)
    # a change the map does not read (the exposure) keeps it cached on both sides
    rep = renderer.render(with_values(user, {"render.exposure": 0.5}))
    assert status(rep, SHADOW).status == "cached"


def test_a_pass_part_way_through_its_bands_is_not_copied(renderer, rig):
    """A peer whose map is part-way (its bands across frames) holds it under no key: nothing to copy."""
    user, preview = rig
    moved = with_values(user, {"lights.0.direction": (0.1, 0.8, 0.5)})
    renderer.render(user)  # timed once: the budget below bands it
    rep = renderer.render(moved, budget_ms=1e-6)
    g = renderer.graph("separable")
    assert SHADOW in g._progress or status(rep, SHADOW).status == "deferred"
    rep = renderer.render(with_values(preview, {"lights.0.direction": (0.1, 0.8, 0.5)}), variant=PREVIEW,
                          interactive=True)
    assert "copied" not in status(rep, SHADOW).reason


def test_only_graphs_of_one_technique_share_and_release_unlinks(renderer, rig):
    user, _ = rig
    g = renderer.graph("separable")
    p = renderer.graph("separable", PREVIEW)
    assert p in g.peers and g in p.peers
    assert renderer.graph("phong") not in g.peers and not renderer.graph("phong").peers
    p.release()
    assert p not in g.peers
    del renderer.graphs[f"separable|{PREVIEW}"]


def test_an_rgb_float_table_is_run_not_blitted(renderer, gl_ctx):
    """Penner's tables are RGB32F, a format GL 3.3 core need not render to: never copied (the pass runs in
    each graph), while the shadow map beside it is, and the preview's image is still its own render's."""
    user = small_settings("head", "penner", size=48)
    renderer.render(user)
    preview = with_values(user, {"render.width": 24, "render.height": 24})
    rep = renderer.render(preview, variant=PREVIEW, interactive=True)
    luts = status(rep, "penner_luts")
    assert luts.status == "ran" and "copied" not in luts.reason and not luts.inputs
    assert "copied" in status(rep, SHADOW).reason
    r = Renderer(gl_ctx)
    try:
        r.render(preview)
        assert np.array_equal(renderer.graph("penner", PREVIEW).read("image"), r.graph("penner").read("image"))
    finally:
        r.release()
