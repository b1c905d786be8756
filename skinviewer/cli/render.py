"""``skinviewer render``: one headless frame to PNG, with optional pass dumps and timings."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from skinviewer.cli.args import check_outputs, image_output, settings_from_args
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.files import (
    atomic_write_text,
    save_exr,
    save_image,
    save_npy,
    save_png,
)
from skinviewer.ground.settings import Settings
from skinviewer.kernel.gl import headless_context


def _preview(arr: np.ndarray) -> np.ndarray:
    """A PNG preview of a float texture: RGB (or gray), scaled to its 99.5th percentile."""
    a = np.nan_to_num(arr.astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    rgb = a[..., :3] if a.shape[-1] >= 3 else np.repeat(a[..., :1], 3, axis=-1)
    if rgb.shape[-1] == 2:
        rgb = np.concatenate([rgb, np.zeros_like(rgb[..., :1])], axis=-1)
    hi = float(np.percentile(np.abs(rgb), 99.5)) or 1.0
    return (np.clip(rgb / hi, 0, 1) * 255 + 0.5).astype(np.uint8)[::-1]


def cmd_render(args) -> int:
    s = settings_from_args(args)
    # outputs checked before anything renders: the format their extension names, no input replaced
    image_output(args.out, "--out")
    image_output(getattr(args, "exr", None), "--exr", display=False)
    check_outputs({"--out": args.out, "--exr": getattr(args, "exr", None), "--timings": args.timings},
                  {"--preset": args.preset}, s)
    ctx = headless_context()
    r = Renderer(ctx)
    try:
        scene = r.ensure_scene(s)
        for note in scene.notes:
            print(f"note: {note}", file=sys.stderr)
        report, frames = r.render_settled(s)  # a progressive pass (burley2.temporal) refines first
        if frames > 1:
            print(f"refined over {frames} frames (burley2.temporal); figures are the last frame's")
        out = Path(args.out)
        if out.suffix.lower() == ".exr":  # the linear image, not PNG bytes under an .exr name
            save_exr(out, r.read(s, "lit")[::-1])
        else:  # PNG, JPEG, TIFF or BMP, as the extension says
            save_image(out, r.image(s))
        if getattr(args, "exr", None):  # linear HDR radiance, before exposure and tone map
            save_exr(args.exr, r.read(s, "lit")[::-1])
            print(f"wrote {args.exr} (linear RGBA float32, alpha = coverage)")
        print(f"wrote {out} ({s.render.width}x{s.render.height}, {s.technique}, "
              f"{report.total_ms:.1f} ms {report.timing_mode})")
        if args.timings:
            atomic_write_text(args.timings, json.dumps(report.to_json(), indent=2) + "\n")
        if args.dump_passes:
            dump_passes(r, s, report, Path(args.dump_passes))
            print(f"dumped {len(r.graph(s.technique).resources())} textures to {args.dump_passes}")
        if args.verbose:
            print(report.table())
            from skinviewer.engine.memory import renderer_memory
            held = renderer_memory(r)  # what the renderer holds on the GPU, counted from each object's format
            print(f"GPU memory held: {sum(held.values()) / 2**20:.1f} MiB ("
                  + ", ".join(f"{k} {v / 2**20:.1f}" for k, v in held.items()) + ")")
    finally:
        r.release()
        ctx.release()
    return 0


def dump_passes(r, s: Settings, report, folder: Path) -> None:
    """Every intermediate texture as float32 .npy + PNG preview, and graph.json."""
    g = r.graph(s.technique)
    for res in g.resources():
        arr = g.read(res)
        save_npy(folder / f"{res}.npy", arr)
        save_png(folder / f"{res}.png", _preview(arr))
    data = report.to_json()
    data["technique"] = s.technique
    data["order"] = [p.name for p in g.order]
    atomic_write_text(folder / "graph.json", json.dumps(data, indent=2) + "\n")


