"""What a frame was made of and what it did: ``FrameInputs`` and the ``FrameReport`` of every pass
(ran / cached / pruned / deferred, why, milliseconds and the timing mode)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from skinviewer.ground.settings import Settings


@dataclass
class FrameInputs:
    settings: Settings
    scene: Any  # GpuScene
    scene_version: int
    view: Any  # View (camera) or None
    view_key: str
    mesh_lod: int = 0  # the mesh's level of detail this frame (passes/rules.mesh_lod)
    lod_note: str = ""  # why, for the frame report of passes that draw the mesh
    # a governed preview while the user drags or edits (issue 27): scene rules may answer from a
    # coarser, cached estimate (Reflection.interactive) and outputs are not checked for NaN/Inf
    # until a frame that is not a preview finds them cached (RenderGraph.run)
    interactive: bool = False
    # the frame's view of the scene and camera (kernel/frame_view.FrameView, built once by the renderer):
    # ``view`` is its camera; the scene rules read it in reflect (Reflection.view)
    frame_view: Any = None

    def __post_init__(self) -> None:
        if self.frame_view is not None:
            if self.view is None:
                self.view = self.frame_view.camera
            elif self.view is not self.frame_view.camera:
                raise ValueError("FrameInputs.view must be frame_view.camera (one camera per frame)")


@dataclass
class PassRecord:
    name: str
    status: str  # ran | cached | pruned | deferred (the frame's time budget ran out first)
    ms: float | None = None
    reason: str = ""
    inputs: list[str] = field(default_factory=list)
    outputs: dict[str, dict[str, Any]] = field(default_factory=dict)
    note: str = ""  # what the pass measured when it last ran (ExecuteContext.note)
    figures: dict[str, Any] = field(default_factory=dict)
    nonfinite: list[str] = field(default_factory=list)  # outputs holding NaN/Inf (render.check_finite)
    draws: int = 0  # draw calls the pass made when it ran


@dataclass
class FrameReport:
    frame: int
    timing_mode: str  # sync | gpu
    passes: list[PassRecord]

    def names(self, status: str) -> list[str]:
        return [p.name for p in self.passes if p.status == status]

    @property
    def ran(self) -> list[str]:
        return self.names("ran")

    @property
    def cached(self) -> list[str]:
        return self.names("cached")

    @property
    def pruned(self) -> list[str]:
        return self.names("pruned")

    @property
    def deferred(self) -> list[str]:
        return self.names("deferred")

    @property
    def complete(self) -> bool:
        """False when the time budget deferred passes to the next frame (outputs not yet updated)."""
        return not self.deferred

    @property
    def nonfinite(self) -> dict[str, list[str]]:
        """Passes whose outputs hold NaN or Inf (when render.check_finite): pass -> outputs."""
        return {p.name: list(p.nonfinite) for p in self.passes if p.nonfinite}

    @property
    def total_ms(self) -> float:
        return float(sum(p.ms or 0.0 for p in self.passes if p.status == "ran"))

    def to_json(self) -> dict[str, Any]:
        return {
            "frame": self.frame,
            "timing_mode": self.timing_mode,
            "timing_note": TIMING_NOTES[self.timing_mode],
            "total_ms": round(self.total_ms, 4),
            "passes": [
                {"name": p.name, "status": p.status, "gpu_ms": None if p.ms is None else round(p.ms, 4),
                 "reason": p.reason, "inputs": p.inputs, "outputs": p.outputs, "nonfinite": p.nonfinite,
                 **({"note": p.note, "figures": p.figures} if p.note else {})}
                for p in self.passes
            ],
            "nonfinite": self.nonfinite,
        }

    def table(self) -> str:
        rows = [f"{'pass':<24} {'status':<7} {'ms':>9}  reason"]
        for p in self.passes:
            ms = "" if p.ms is None else f"{p.ms:9.3f}"
            bad = f"  NON-FINITE: {', '.join(p.nonfinite)}" if p.nonfinite else ""
            rows.append(f"{p.name:<24} {p.status:<7} {ms:>9}  {p.reason}{bad}" + (f" [{p.note}]" if p.note else ""))
        rows.append(f"{'total (' + self.timing_mode + ' timing)':<32} {self.total_ms:9.3f}")
        return "\n".join(rows)


TIMING_NOTES = {
    "sync": "glFinish before and after each pass, wall clock: true cost on lazy rasterizers such as llvmpipe",
    "gpu": "GL_TIME_ELAPSED timer queries: accurate on real GPUs, far too low on llvmpipe (lazy rasterization)",
}


