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


# -- priming: the preview variants the next drag renders, drawn while the view is still (issue 27) --
PRIME_ENV = "SKINVIEWER_PRIME"  # 0: no priming (the A/B of benchmarks/bench_interaction.py --prime)


def preview_variant(rung) -> str:
    """The renderer graph a governed frame of ``rung`` renders in: "" (the user's graph) for a rung
    that changes no setting (a smaller view of your settings), else one graph per set of changes."""
    import json
    return "" if not rung.changes else "preview " + json.dumps(sorted((k, repr(v)) for k, v in rung.changes.items()))


def rung_frame_settings(s, rung, view_size: tuple[int, int]):
    """The settings a governed frame of ``rung`` renders at a view of ``view_size`` (full size): its
    changes, and the view scaled as the frame controller sizes it (ui/frame.py ``_sync_size``)."""
    from skinviewer.engine.calibration import rung_settings
    from skinviewer.ground.settings import with_values
    from skinviewer.techniques.preview import Rung
    out = rung_settings(s, Rung(rung.label, rung.changes))
    vw, vh = view_size
    if rung.scale < 1.0:
        vw, vh = max(16, int(vw * rung.scale)), max(16, int(vh * rung.scale))
    if (out.render.width, out.render.height) != (vw, vh):
        out = with_values(out, {"render.width": vw, "render.height": vh})
    return out


class Primer:
    """Draws, while the view is still and final, the preview rungs the next interaction will render
    (the governor's pick for a light drag or an edit, and its refinement's intermediate rung), in
    their own graphs, as the drag will. A driver finishes a program at its first draw, not at link
    (llvmpipe JIT-compiles it there: d'Eon's final pass ~0.6 s, its transmitted light ~1.4 s without
    Mesa's shader cache), which made the first frame of a d'Eon light drag a 440-590 ms stall; the
    compile-only warm-up (ShaderLibrary.warm) never paid it. Each idle frame renders one slice of a
    priming frame under the graph's budget (it resumes in the next idle frame; a new input takes
    over), so priming costs idle frames of about the budget each, one program's first draw at most
    beyond it. A rung of the user's own graph (a smaller view of your settings) needs none."""

    def __init__(self, renderer):
        import os
        self.renderer = renderer
        self.enabled = os.environ.get(PRIME_ENV, "1").strip() != "0"
        self.primed: set[tuple] = set()  # Primer._key of each priming done: its programs have been drawn
        self.frames = 0  # idle frames that rendered a priming slice
        self.slice_ms: list[float] = []  # each slice's wall ms (sync timing where the renderer's timing is)
        self.error = ""

    def targets(self, governor, s) -> list[tuple]:
        """What to prime for ``s`` now, in order, as (rung, extra changes): the light-drag pick, then
        its refinement's intermediate step (the steps that are not your settings' own graph); each
        also with the variants a light pose toggles (d'Eon: the TSM, which ``deon.tsm_auto`` turns on
        or off by pose and a preview keeps on while its pose's bin is not known yet)."""
        if governor.calibration is None or s.technique not in governor.calibration.entries:
            return []
        pick = governor.pick(s, camera=False).rung
        rungs = [] if pick.final else [pick]
        rungs += [r for r in governor._refinement(s, pick) if not r.final and r not in rungs]
        toggles: list[dict] = [{}]
        if s.technique == "deon" and s.deon.tsm and s.deon.tsm_auto:
            toggles.append({"deon.tsm_auto": False})  # the TSM drawn whatever this pose decides
        return [(r, t) for r in rungs if r.changes for t in toggles]

    def _key(self, s, rung, extra: dict) -> tuple:
        """What a priming holds for: the scene, the rung's graph, and the variants your settings' own
        graph last drew (an edit that changes a shader variant there -- a Gaussian's weight to 0,
        another tone map -- changes the preview's too: primed again)."""
        scene = self.renderer.scene
        g = self.renderer.graphs.get(s.technique)
        return (scene.key if scene is not None else None, s.technique, preview_variant(rung), tuple(sorted(extra)),
                hash(g.programs()) if g is not None else 0)

    def pending(self, governor, s) -> list[tuple]:
        return [(r, t) for r, t in self.targets(governor, s) if self._key(s, r, t) not in self.primed]

    def step(self, governor, s, view_size: tuple[int, int], budget_ms: float | None) -> bool:
        """One idle frame's slice: render the first rung still to prime (under ``budget_ms``, resumed
        next call); True if it rendered anything (the caller then skips other idle work this frame)."""
        import time
        if not self.enabled or self.error:
            return False
        todo = self.pending(governor, s)
        if not todo:
            return False
        rung, extra = todo[0]
        variant = preview_variant(rung)
        target = rung_frame_settings(s, rung, view_size)
        if extra:
            from skinviewer.ground.settings import with_values
            target = with_values(target, extra)
        t0 = time.perf_counter()
        try:
            report = self.renderer.render(target, budget_ms=budget_ms, variant=variant, interactive=True)
        except Exception as exc:  # the drag renders the same frame and reports it; priming stops
            self.error = f"priming {rung.label}: {type(exc).__name__}: {exc}"
            return False
        self.slice_ms.append((time.perf_counter() - t0) * 1000.0)
        self.frames += 1
        if report.complete:
            if len(self.primed) > 64:
                self.primed.clear()
            self.primed.add(self._key(s, rung, extra))
        return True
