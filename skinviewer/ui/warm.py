"""The start's CPU work off the main thread (issue 34: the panel within 2 s, never frozen).

A technique's first frame spends most of its time not on the GPU but in numpy on the mesh, inside the
passes' ``reflect``: d'Eon's open-border test and the back-face culling's closed-mesh test
(``scene.mesh.border_half_edges``: a sort of every edge),
the TSM rule's rays towards each light (``passes.rules.thickness_toward``: Embree), and in the rho_dt
table's integrals (``physics.specular``). Each is cached on the scene (or in an lru_cache) once made.
``start_warm(renderer, settings)`` makes them in a worker thread while the main thread keeps drawing the
panel; the first render then finds them cached. The worker reflects each pass with a throwaway shape
state (the graph's own hysteresis is untouched) and makes no GL call; a failure there is silent (the
render makes the same call on the main thread and reports it)."""
from __future__ import annotations

import threading

from skinviewer.kernel.pass_api import Reflection


def warm_scene(renderer, settings) -> list[str]:
    """Reflect every pass of ``settings.technique`` on the loaded scene (filling the scene's caches)
    and make the rho_dt table; returns what failed (pass names), for tests."""
    failed: list[str] = []
    try:
        from skinviewer.passes.rho_dt import RHO_DT_SIZE
        from skinviewer.physics.specular import rho_dt_table
        rho_dt_table(settings.specular.f0, settings.specular.rho_s, n_cos=RHO_DT_SIZE[0], n_m=RHO_DT_SIZE[1])
    except Exception:
        failed.append("rho_dt_lut")
    loaded = renderer.scene
    if loaded is None:
        return failed
    try:
        loaded.gpu.closed  # noqa: B018  (cached: the passes' back-face culling asks it; a sort of every edge)
    except Exception:
        failed.append("closed")
    from skinviewer import techniques
    try:
        passes, _ = techniques.build(settings.technique)
    except Exception:
        return failed + ["build"]
    view = renderer.build_frame_view(settings, loaded.gpu)  # the camera the render will draw
    for p in passes:
        try:
            p.reflect(Reflection(settings, loaded.gpu if p.uses_scene else None, {},
                                 view=view if p.uses_scene else None))
        except Exception:
            failed.append(p.name)
    return failed


def start_warm(renderer, settings) -> threading.Thread:
    """``warm_scene`` in a daemon thread, started; join it (or poll ``is_alive``) before rendering."""
    t = threading.Thread(target=warm_scene, args=(renderer, settings), name="skinviewer-warm", daemon=True)
    t.start()
    return t
