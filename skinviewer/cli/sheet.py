"""``skinviewer sheet``: techniques side by side over views, each tile labelled with its technique,
the settings that differ from the defaults, the frame time and (when the ground truth of that view is
cached) its error against the truth -- the comparison artists post in review."""
from __future__ import annotations

import argparse
import io
import sys
import time

import numpy as np

from skinviewer import techniques
from skinviewer.cli.args import add_scene_args, check_outputs, settings_from_args
from skinviewer.ground.files import atomic_write_bytes
from skinviewer.ground.settings import Settings, to_dict, with_values

VIEWS = {"front": 0.0, "34": 45.0, "side": 90.0, "back": 180.0}  # camera yaw, degrees about +Y
VIEW_LABEL = {"front": "front", "34": "3/4", "side": "side", "back": "back"}
TIMED_RUNS = 3


def differing(s: Settings, limit: int = 3) -> list[str]:
    """Dotted paths of ``s`` that differ from the defaults, within the technique's own section, the
    specular and the profile sections (camera, size and scene are the sheet's own)."""
    base, cur = to_dict(Settings()), to_dict(s)
    sections = {s.technique, "specular", "screen", "transmittance"}
    if s.technique in ("ssss", "separable", "gosselin"):
        sections.add("deon")
    out: list[str] = []

    def walk(a, b, path: str) -> None:
        if isinstance(a, dict) and isinstance(b, dict):
            for k in b:
                walk(a.get(k), b[k], f"{path}.{k}" if path else k)
        elif a != b:
            val = b if not isinstance(b, (list, dict)) else ("..." if isinstance(b, dict) or len(b) > 3 else b)
            out.append(f"{path}={val}")
    for sec in sorted(sections):
        walk(base.get(sec), cur.get(sec), sec)
    if len(out) > limit:
        out = out[:limit] + [f"+{len(out) - limit} more"]
    return out


def _font(size: int):
    from PIL import ImageFont
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1
        return ImageFont.load_default()


def render_sheet(s: Settings, names: list[str], views: list[str], truth: bool = True,
                 progress=None) -> tuple[np.ndarray, list[dict]]:
    """The sheet image (uint8 RGB) and one record per tile (technique, view, ms, error)."""
    from PIL import Image, ImageDraw

    from skinviewer.engine.bench import compare_mask, linear_image
    from skinviewer.engine.reference import load_cached
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    from skinviewer.physics.metrics import image_error
    W, H = s.render.width, s.render.height
    label_h = max(40, H // 5)
    fs = max(10, min(16, W // 22))
    sheet = Image.new("RGB", (W * len(names), (H + label_h) * len(views)), (24, 24, 24))
    draw = ImageDraw.Draw(sheet)
    font, small = _font(fs), _font(max(9, fs - 3))
    records: list[dict] = []
    ctx = headless_context()
    r = Renderer(ctx)
    try:
        r.ensure_scene(s)
        n = 0
        for row, view in enumerate(views):
            for col, name in enumerate(names):
                t = with_values(s, {"technique": name, "camera.yaw": VIEWS[view]})
                r.render_settled(t, timing="sync")  # compile and settle first: the timed runs are warm
                ms = []
                for _ in range(TIMED_RUNS):
                    t0 = time.perf_counter()
                    r.render(t, timing="sync", force=True)
                    r.read(t, "image")  # wait for the GPU (sync timing)
                    ms.append(1000.0 * (time.perf_counter() - t0))
                img = r.image(t)
                err = None
                cache_notes: list[str] = []
                ref = load_cached(t, notes=cache_notes) if truth else None
                for note in cache_notes:  # a damaged entry: discarded, the tile says "not cached"
                    print(f"note: {note}", file=sys.stderr)
                if ref is not None and ref.lit.shape[:2] == img.shape[:2]:
                    lit, cov = linear_image(r, t)
                    err = image_error(lit, ref.lit, compare_mask(ref.mask, cov))
                x, y = col * W, row * (H + label_h)
                sheet.paste(Image.fromarray(img), (x, y))
                lines = [f"{name}  {VIEW_LABEL[view]}  {float(np.median(ms)):.0f} ms"]
                lines.append(f"truth RMS {100 * err.rms_mean:.1f}%" if err is not None else "truth: not cached")
                lines += differing(t, 2)
                ty = y + H + 3
                for i, line in enumerate(lines):
                    draw.text((x + 4, ty), line, fill=(235, 235, 235) if i == 0 else (170, 170, 170),
                              font=font if i == 0 else small)
                    ty += (fs if i == 0 else fs - 3) + 3
                records.append({"technique": name, "view": view, "ms": float(np.median(ms)),
                                "truth_rms": None if err is None else err.rms_mean, "differs": differing(t, 99)})
                n += 1
                if progress is not None:
                    progress(n)
    finally:
        r.release()
        ctx.release()
    return np.asarray(sheet), records


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser("sheet", help="a labelled comparison sheet of techniques and views (PNG)")
    add_scene_args(p)
    p.add_argument("--techniques", default="deon,burley2,ssss", help="comma-separated (default deon,burley2,ssss)")
    p.add_argument("--views", default="front,34,back", help=f"comma-separated of {', '.join(VIEWS)}")
    p.add_argument("--no-truth", action="store_true", help="do not look for cached ground truths")
    p.add_argument("--out", required=True, help="sheet PNG")
    p.set_defaults(func=cmd_sheet)
    return p


def cmd_sheet(args) -> int:
    names = [t.strip() for t in args.techniques.split(",") if t.strip()]
    views = [v.strip() for v in args.views.split(",") if v.strip()]
    bad = [t for t in names if t not in techniques.names()]
    badv = [v for v in views if v not in VIEWS]
    if not names or bad or not views or badv or not args.out.lower().endswith(".png"):
        msg = (f"unknown technique(s) {', '.join(bad)} (have: {', '.join(techniques.names())})" if bad else
               f"unknown view(s) {', '.join(badv)} (have: {', '.join(VIEWS)})" if badv else
               "--out must be a .png" if names and views else "give at least one technique and one view")
        print(f"skinviewer sheet: error: {msg}", file=sys.stderr)
        return 2
    s = settings_from_args(args)
    check_outputs({"--out": args.out}, {"--preset": args.preset}, s)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn
    with Progress(TextColumn("sheet"), BarColumn(), MofNCompleteColumn()) as bar:
        task = bar.add_task("sheet", total=len(names) * len(views))
        img, recs = render_sheet(s, names, views, not args.no_truth, lambda n: bar.update(task, completed=n))
    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="PNG")
    atomic_write_bytes(args.out, buf.getvalue())
    for rec in recs:
        tr = "-" if rec["truth_rms"] is None else f"{100 * rec['truth_rms']:.2f}%"
        print(f"{rec['technique']:>10} {rec['view']:>6} {rec['ms']:8.1f} ms  truth RMS {tr}")
    print(f"wrote {args.out} ({len(names)} x {len(views)} tiles of {s.render.width}x{s.render.height}; "
          "ms: median of 3 warm sync-timed frames)")
    return 0
