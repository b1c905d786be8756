"""The GPU check (issue 31): one process per step, each writing into the results folder.

    python benchmarks/gpu/gpu_check.py info    --out DIR
    python benchmarks/gpu/gpu_check.py renders --out DIR [--size 256] [--ref DIR/renders.npz]
    python benchmarks/gpu/gpu_check.py frames  --out DIR [--width 1920 --height 1080] [--repeats 5]
    python benchmarks/gpu/gpu_check.py report  --out DIR

`benchmarks/gpu/run.sh` calls them in order; each runs as well against Mesa llvmpipe (with lighter
sizes, which its output then names), so the GPU's minutes go to measuring, not debugging.

* renders: every technique on the default head, the shared scan, `laser` and `backlit-ear`; the
  linear image (`lit`, before exposure and tone map) saved as float32 in one .npz, with each
  image's pixel classes (NaN/Inf, black inside the skin mask, magenta in the displayed image).
  With --ref (the same renders made on another GL), the relative RMS per channel over the skin
  mask, goal <= 0.5 %, and any pixel class one side has and the other lacks.
* frames: each technique's full, light-move and camera-only frame with the defaults and with 2048^2
  maps, in sync timing (glFinish + wall clock) and with GL timer queries (render.timing = gpu), side
  by side; the "simulate only what the scene calls for" ratios; one d'Eon blur direction vs a plain
  copy; d'Eon's surface-sum step; memory each technique holds (engine/memory.py) and what the driver
  reports (GL_NVX_gpu_memory_info).
"""
from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # the checkout's skinviewer before any installed one
sys.path.insert(0, str(HERE.parent))      # benchmarks/ (bench_frames' helpers)

from skinviewer import techniques  # noqa: E402
from skinviewer.engine.memory import renderer_memory  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import Settings, with_values  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402
from skinviewer.scene.scenes import scene_overrides  # noqa: E402

GOAL_RMS = 0.005  # relative RMS per channel, GPU vs llvmpipe (issue 31)
MAGENTA = (255, 0, 255)


def shared_dir() -> Path:
    env = os.environ.get("SKINVIEWER_SHARED")
    return Path(env) if env else HERE.parents[2] / "shared"


def scan_path() -> Path:
    return shared_dir() / "assets" / "lee-perry-smith" / "LeePerrySmith.glb"


def scene_values(scene: str) -> dict:
    if scene == "scan":
        return {"scene.mesh": str(scan_path())}
    return {"scene.name": scene, **scene_overrides(scene)}


def write_json(path: Path, data) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=1, default=float) + "\n")
    os.replace(tmp, path)


def load_json(path: Path) -> dict:
    return json.loads(path.read_text()) if path.is_file() else {}


# -- info --------------------------------------------------------------------------------------------

GL_GPU_MEMORY_TOTAL_AVAILABLE_MEMORY_NVX = 0x9048
GL_GPU_MEMORY_CURRENT_AVAILABLE_VIDMEM_NVX = 0x9049


def _gl_get_integer(pname: int) -> int | None:
    """glGetIntegerv through the GLVND dispatch of the current context (moderngl exposes no
    generic query); None where no GL library answers."""
    for name in ("OpenGL", "GL"):
        path = ctypes.util.find_library(name)
        if not path:
            continue
        try:
            lib = ctypes.CDLL(path)
            fn = lib.glGetIntegerv
        except (OSError, AttributeError):
            continue
        fn.argtypes = [ctypes.c_uint, ctypes.POINTER(ctypes.c_int)]
        v = ctypes.c_int(-1)
        fn(pname, ctypes.byref(v))
        return v.value if v.value >= 0 else None
    return None


def driver_memory(ctx) -> dict:
    """GL_NVX_gpu_memory_info (KiB) where the driver has it."""
    if "GL_NVX_gpu_memory_info" not in ctx.extensions:
        return {}
    total = _gl_get_integer(GL_GPU_MEMORY_TOTAL_AVAILABLE_MEMORY_NVX)
    free = _gl_get_integer(GL_GPU_MEMORY_CURRENT_AVAILABLE_VIDMEM_NVX)
    return {"total_kib": total, "free_kib": free}


def cmd_info(args) -> int:
    ctx = headless_context()
    info = {k: ctx.info.get(k) for k in ("GL_RENDERER", "GL_VERSION", "GL_VENDOR")}
    info["nvx_gpu_memory_info"] = "GL_NVX_gpu_memory_info" in ctx.extensions
    info["timer_query"] = "GL_ARB_timer_query" in ctx.extensions or ctx.version_code >= 330
    info["date"] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    info["driver_memory"] = driver_memory(ctx)
    ctx.release()
    print(f"GL_RENDERER = {info['GL_RENDERER']}\nGL_VERSION  = {info['GL_VERSION']}\nGL_VENDOR   = {info['GL_VENDOR']}")
    out = Path(args.out)
    data = load_json(out / "results.json")
    data["info"] = info
    write_json(out / "results.json", data)
    return 0


def is_gpu(info: dict) -> bool:
    return "llvmpipe" not in (info.get("GL_RENDERER") or "").lower()


# -- renders and parity ------------------------------------------------------------------------------

SCENES = ("head", "scan", "laser", "backlit-ear")


def pixel_classes(lit: np.ndarray, shown: np.ndarray) -> dict:
    rgb, alpha = lit[..., :3], lit[..., 3] if lit.shape[-1] > 3 else np.ones(lit.shape[:2], np.float32)
    mask = alpha > 0.5
    finite = np.isfinite(rgb).all(axis=-1)
    return {"nonfinite": int((~finite).sum()),
            "black_in_mask": int((mask & finite & (rgb.max(axis=-1) <= 0.0)).sum()),
            "magenta": int((shown[..., :3] == MAGENTA).all(axis=-1).sum()),
            "mask": int(mask.sum())}


def cmd_renders(args) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ctx = headless_context()
    r = Renderer(ctx)
    images: dict[str, np.ndarray] = {}
    classes: dict[str, dict] = {}
    failures: list[str] = []
    scenes = [s for s in SCENES if s != "scan" or scan_path().is_file()]
    if "scan" not in scenes:
        print(f"note: no shared scan at {scan_path()}: the scan is left out")
    t0 = time.perf_counter()
    for scene in scenes:
        for tech in techniques.names():
            key = f"{scene}/{tech}"
            s = with_values(Settings(), {**scene_values(scene), "technique": tech,
                                         "render.width": args.size, "render.height": args.size})
            try:
                r.render_settled(s)
                lit = np.asarray(r.read(s, "lit"), np.float32)
                shown = np.asarray(r.image(s))
            except Exception as exc:  # one technique failing must not hide the others' results
                failures.append(f"{key}: {type(exc).__name__}: {exc}")
                print(f"FAIL {key}: {exc}")
                continue
            images[key] = lit
            classes[key] = pixel_classes(lit, shown)
            c = classes[key]
            bad = c["nonfinite"] or c["magenta"]
            print(f"{'BAD ' if bad else 'ok  '}{key:<24} mask {c['mask']:>6}  nonfinite {c['nonfinite']}  "
                  f"black {c['black_in_mask']}  magenta {c['magenta']}")
            if bad:
                failures.append(f"{key}: {c['nonfinite']} non-finite, {c['magenta']} magenta pixels")
    r.release()
    ctx.release()
    np.savez_compressed(out / "renders.npz", **{k.replace("/", "__"): v.astype(np.float32) for k, v in images.items()})
    print(f"{len(images)} renders at {args.size}^2 in {time.perf_counter() - t0:.1f} s -> {out / 'renders.npz'}")
    data = load_json(out / "results.json")
    data["renders"] = {"size": args.size, "classes": classes, "failures": failures}
    if args.ref and Path(args.ref).is_file():
        data["parity"] = parity(images, classes, Path(args.ref))
    elif args.ref:
        print(f"note: no reference renders at {args.ref}: parity not checked")
    write_json(out / "results.json", data)
    return 1 if failures else 0


def parity(images: dict, classes: dict, ref_path: Path) -> dict:
    """Relative RMS per channel over both skin masks, and pixel classes one side lacks."""
    ref = np.load(ref_path)
    rows = {}
    for key, a in images.items():
        name = key.replace("/", "__")
        if name not in ref.files:
            rows[key] = {"missing": True}
            continue
        b = ref[name]
        if b.shape != a.shape:
            rows[key] = {"shape": [list(a.shape), list(b.shape)]}
            continue
        mask = (a[..., 3] > 0.5) & (b[..., 3] > 0.5) if a.shape[-1] > 3 else np.ones(a.shape[:2], bool)
        fa, fb = np.nan_to_num(a[mask][:, :3]), np.nan_to_num(b[mask][:, :3])
        rel = np.sqrt(((fa - fb) ** 2).mean(axis=0)) / np.maximum(np.sqrt((fb ** 2).mean(axis=0)), 1e-12)
        ref_classes = pixel_classes(b, np.zeros(b.shape[:2] + (3,), np.uint8))
        own = classes[key]
        lacks = [k for k in ("nonfinite", "black_in_mask") if bool(own[k]) != bool(ref_classes[k])]
        mask_diff = int(((a[..., 3] > 0.5) != (b[..., 3] > 0.5)).sum()) if a.shape[-1] > 3 else 0
        rows[key] = {"rel_rms": [float(x) for x in rel], "class_mismatch": lacks, "mask_diff": mask_diff,
                     "ok": bool((rel <= GOAL_RMS).all() and not lacks)}
        flag = "ok " if rows[key]["ok"] else "OFF"
        print(f"parity {flag} {key:<24} rel RMS R/G/B {rel[0] * 100:6.3f} {rel[1] * 100:6.3f} {rel[2] * 100:6.3f} %"
              f"  mask px differing {mask_diff}" + (f"  classes only on one side: {lacks}" if lacks else ""))
    return rows


# -- frames, ratios and memory ---------------------------------------------------------------------

def settings_for(tech: str, width: int, height: int, maps: int | None, timing: str, **extra) -> Settings:
    values = {"scene.name": "head", **scene_overrides("head"), "technique": tech, "render.width": width,
              "render.height": height, "render.timing": timing}
    if maps:  # None: the defaults' map sizes
        values.update({"shadow.map_size": maps, "gosselin.light_map_size": maps, "deon.irradiance_size": maps,
                       "deon.tsm_size": maps})
    values.update(extra)
    return with_values(Settings(), values)


def _timed(r: Renderer, s: Settings, **kw) -> tuple[float, float | None]:
    """(wall ms with glFinish, sum of the report's per-pass ms in the settings' timing mode)."""
    r.ctx.finish()
    t0 = time.perf_counter()
    rep = r.render(s, **kw)
    r.ctx.finish()
    wall = (time.perf_counter() - t0) * 1000.0
    passes = [p.ms for p in rep.passes if p.ms is not None]
    return wall, (sum(passes) if passes else None)


def frame_kinds(r: Renderer, s: Settings, repeats: int) -> dict:
    """Medians of the full (forced), light-move and camera-only frames, wall and per-pass sums."""
    got: dict[str, list[tuple[float, float | None]]] = {"full": [], "light": [], "camera": []}
    d = s.lights[0].direction
    for k in range(repeats):
        got["full"].append(_timed(r, s, force=True))
        s_light = with_values(s, {"lights.0.direction": (d[0] + 0.02 * (k + 1), d[1], d[2])})
        got["light"].append(_timed(r, s_light))
        r.render(s)
        s_cam = with_values(s, {"camera.yaw": s.camera.yaw + 5.0 * (k + 1)})
        got["camera"].append(_timed(r, s_cam))
        r.render(s)
    out = {}
    for kind, vals in got.items():
        out[kind] = statistics.median(v[0] for v in vals)
        sums = [v[1] for v in vals if v[1] is not None]
        out[kind + "_passes"] = statistics.median(sums) if sums else None
    return out


def cmd_frames(args) -> int:
    from bench_frames import blur_draw_ms, close_distance, copy_draw_ms  # benchmarks/bench_frames.py

    out = Path(args.out)
    ctx = headless_context()
    W, H, reps = args.width, args.height, args.repeats
    names = args.techniques.split(",") if args.techniques else techniques.names()
    rows: dict[str, dict] = {}
    memory: dict[str, dict] = {}
    t_start = time.perf_counter()
    small = args.small_maps  # a dry run on llvmpipe: lighter maps, named in the rows
    for maps_label, maps in ((("defaults", None), ("2048", 2048)) if not small else
                             ((str(small), small), (str(2 * small), 2 * small))):
        for tech in names:
            r = Renderer(ctx)
            row = {}
            for timing in ("sync", "gpu"):
                s = settings_for(tech, W, H, maps, timing)
                r.render(s, force=True)  # warm-up: compile, build the scene, allocate
                row[timing] = frame_kinds(r, s, reps)
            rep = r.render(settings_for(tech, W, H, maps, "sync"), force=True)
            # d'Eon's narrow steps summed over the surface run inside their blur pass (its note says so)
            surface = [p.ms for p in rep.passes if p.ms is not None and p.status == "ran"
                       and ("surface_gather" in p.name or "surface" in (p.note or "").lower())
                       and p.name.startswith("deon_blur")]
            row["surface_sum_ms"] = sum(surface) if surface else None
            mem = renderer_memory(r)
            memory[f"{tech}@{maps_label}"] = {k: v / 2**20 for k, v in mem.items()} | {"total": sum(mem.values()) / 2**20}
            row["passes"] = [(p.name, p.status, p.ms) for p in rep.passes]
            rows[f"{tech}@{maps_label}"] = row
            r.release()
            r.shaders.release()
            f = row["sync"]
            print(f"{tech:<10} maps {maps_label:<8} full {f['full']:8.2f}  light {f['light']:8.2f}  camera "
                  f"{f['camera']:8.2f} ms (sync) | gpu-query full {row['gpu']['full_passes'] or float('nan'):8.2f} ms"
                  f" | {memory[f'{tech}@{maps_label}']['total']:7.1f} MiB", flush=True)
    # the "simulate only what the scene calls for" ratios (bench_frames' definitions), defaults, sync
    r = Renderer(ctx)
    small_maps = args.small_maps or None
    base = settings_for("deon", W, H, small_maps, "sync")
    phong = settings_for("phong", W, H, small_maps, "sync")
    auto = {"deon.irradiance_size_mode": "auto", "shadow.map_size_mode": "auto"}
    dark = settings_for("deon", W, H, small_maps, "sync",
                        **{f"lights.{i}.intensity": 0.0 for i in range(len(base.lights))})
    close = settings_for("deon", W, H, small_maps, "sync", **auto)
    far = with_values(close, {"camera.distance": close_distance(r, close) * 12.0})
    for s in (base, phong, dark, close, far):
        r.render(s, force=True)

    def med(s):
        return statistics.median(_timed(r, s, force=True)[0] for _ in range(reps))
    m = {"deon": med(base), "phong": med(phong), "dark": med(dark), "close": med(close), "far": med(far)}
    def cam_ms(s, k):  # from the base frame (not timed), so only the view-dependent passes re-run
        r.render(s)
        return _timed(r, with_values(s, {"camera.yaw": s.camera.yaw + 3.0 * (k + 1)}))[0]
    cam = {t: statistics.median(cam_ms(s, k) for k in range(reps)) for t, s in (("deon", base), ("phong", phong))}
    rep = r.render(base, force=True)
    # the widest blur: always separable taps (the narrow ones may be summed over the surface)
    blur_name = [p.name for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran" and p.draws][-1]
    blur, draws = blur_draw_ms(rep, blur_name, base.scene.seam_aware)
    copy = copy_draw_ms(r, base.deon.irradiance_size, reps)
    ratios = {
        "d'Eon full / Phong full": (m["deon"] / m["phong"], "<= 3.0"),
        "d'Eon camera-only / Phong camera-only": (cam["deon"] / cam["phong"], "<= 1.2"),
        "head under 1 % of the screen / close-up (d'Eon, auto)": (m["far"] / m["close"], "<= 0.1"),
        "every light at zero / lit frame (d'Eon)": (m["dark"] / m["deon"], "<= 0.05"),
        f"one d'Eon blur direction / plain copy ({blur_name}, {draws} directions)": ((blur or 0.0) / copy, "<= 2.0"),
    }
    for k, (v, goal) in ratios.items():
        print(f"{k:<66} {v:7.3f}  goal {goal}")
    r.release()
    drv = driver_memory(ctx)
    ctx.release()
    data = load_json(out / "results.json")
    data["frames"] = {"width": W, "height": H, "repeats": reps, "rows": rows, "memory": memory,
                      "ratios": {k: [v, g] for k, (v, g) in ratios.items()},
                      "ratio_ms": m | {f"cam_{k}": v for k, v in cam.items()} | {"blur": blur, "copy": copy},
                      "driver_memory_after": drv, "seconds": time.perf_counter() - t_start}
    write_json(out / "results.json", data)
    return 0


# -- report ---------------------------------------------------------------------------------------

def _f(x, digits=2) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


def cmd_report(args) -> int:
    out = Path(args.out)
    d = load_json(out / "results.json")
    info = d.get("info", {})
    lines = [f"# skinviewer on {info.get('GL_RENDERER', '?')}", "",
             f"- GL: {info.get('GL_VERSION', '?')} ({info.get('GL_VENDOR', '?')}); run {info.get('date', '?')}",
             f"- made by `benchmarks/gpu/run.sh` ({'a GPU' if is_gpu(info) else 'Mesa llvmpipe, lighter sizes'})"]
    for k, v in d.get("extra_info", {}).items():
        lines.append(f"- {k}: {v}")
    suite = d.get("suite")
    if suite:
        lines += ["", "## Headless test suite (`-m \"not viewer\"`)", "", f"`{suite.get('summary', '?')}`"]
        if suite.get("ignored"):
            lines.append(f"(test files left out for packages not carried: {suite['ignored']})")
        if suite.get("deselected"):
            lines.append(f"(tests deselected, their decoders not carried: `-k \"{suite['deselected']}\"`)")
    rend = d.get("renders")
    if rend:
        lines += ["", f"## Every technique renders finite ({rend['size']}², default settings)", "",
                  "| scene / technique | skin px | non-finite | black in skin | magenta |", "| --- | --- | --- | --- | --- |"]
        for k, c in rend["classes"].items():
            lines.append(f"| {k} | {c['mask']} | {c['nonfinite']} | {c['black_in_mask']} | {c['magenta']} |")
        for f in rend.get("failures", []):
            lines.append(f"- FAILED: {f}")
    par = d.get("parity")
    if par:
        ok = sum(1 for v in par.values() if v.get("ok"))
        lines += ["", f"## Image parity against Mesa llvmpipe (relative RMS per channel over the skin; goal ≤ "
                  f"{GOAL_RMS * 100:.1f} %): {ok}/{len(par)} within", "",
                  "| scene / technique | R % | G % | B % | mask px differing | classes on one side only |",
                  "| --- | --- | --- | --- | --- | --- |"]
        for k, v in par.items():
            rr = v.get("rel_rms")
            if rr is None:
                lines.append(f"| {k} | — | — | — | — | {v} |")
                continue
            lines.append(f"| {k} | {rr[0] * 100:.3f} | {rr[1] * 100:.3f} | {rr[2] * 100:.3f} | {v['mask_diff']} | "
                         f"{', '.join(v['class_mismatch']) or '—'} |")
    fr = d.get("frames")
    if fr:
        lines += ["", f"## Frame times at {fr['width']}×{fr['height']} (default head; medians of {fr['repeats']})", "",
                  "Sync = `render.timing = sync` (a glFinish after every pass), wall clock around the frame; GPU = the "
                  "sum of the passes' GL timer queries (`render.timing = gpu`, what the viewer uses on a GPU); wall = "
                  "that frame's wall clock (no glFinish between passes, one after the frame: what a user waits). "
                  "Maps: the defaults (1024² irradiance, shadow, TSM) or 2048².", "",
                  "| technique | maps | full ms (sync) | full ms (GPU) | full (wall) | light move (sync) | light move (GPU) | "
                  "light (wall) | camera only (sync) | camera only (GPU) | camera (wall) | MiB held |",
                  "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for k, row in fr["rows"].items():
            tech, maps = k.split("@")
            sy, gp = row["sync"], row["gpu"]
            lines.append(f"| {tech} | {maps} | {_f(sy['full'])} | {_f(gp['full_passes'])} | {_f(gp['full'])} | "
                         f"{_f(sy['light'])} | {_f(gp['light_passes'])} | {_f(gp['light'])} | {_f(sy['camera'])} | "
                         f"{_f(gp['camera_passes'])} | {_f(gp['camera'])} | {_f(fr['memory'][k]['total'], 1)} |")
        sums = [(k, r["surface_sum_ms"]) for k, r in fr["rows"].items() if r.get("surface_sum_ms")]
        if sums:
            lines += ["", "d'Eon's surface-sum steps (sync, one full frame): " +
                      ", ".join(f"{k} {v:.2f} ms" for k, v in sums)]
        lines += ["", "### Simulate only what the scene calls for (defaults, sync)", "", "| figure | ratio | goal |",
                  "| --- | --- | --- |"]
        for k, (v, g) in fr["ratios"].items():
            lines.append(f"| {k} | {v:.3f} | {g} |")
        rm = fr["ratio_ms"]
        lines.append(f"\n(ms: d'Eon {rm['deon']:.2f}, Phong {rm['phong']:.2f}, camera-only d'Eon {rm['cam_deon']:.2f}"
                     f" / Phong {rm['cam_phong']:.2f}, dark {rm['dark']:.2f}, far {rm['far']:.2f} / close "
                     f"{rm['close']:.2f}, blur direction {_f(rm['blur'], 3)} / copy {rm['copy']:.3f})")
        dm = fr.get("driver_memory_after") or info.get("driver_memory")
        if dm:
            lines.append(f"\nDriver (GL_NVX_gpu_memory_info): total {dm.get('total_kib')} KiB, free "
                         f"{dm.get('free_kib')} KiB after the frames.")
    walls = d.get("walls")
    if walls:
        lines += ["", "## Ground truth and bench wall time", "", "| what | seconds |", "| --- | --- |"]
        for k, v in walls.items():
            lines.append(f"| {k} | {v} |")
    text = "\n".join(lines) + "\n"
    tmp = out / "summary.md.tmp"
    tmp.write_text(text)
    os.replace(tmp, out / "summary.md")
    print(text)
    return 0


def cmd_note(args) -> int:
    """Record a key/value (suite summary, wall times) into results.json."""
    out = Path(args.out)
    d = load_json(out / "results.json")
    d.setdefault(args.section, {})[args.key] = args.value
    write_json(out / "results.json", d)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name in ("info", "renders", "frames", "report", "note"):
        p = sub.add_parser(name)
        p.add_argument("--out", required=True)
        if name == "renders":
            p.add_argument("--size", type=int, default=256)
            p.add_argument("--ref", default=None, help="renders.npz made on another GL, to compare with")
        if name == "frames":
            p.add_argument("--width", type=int, default=1920)
            p.add_argument("--height", type=int, default=1080)
            p.add_argument("--repeats", type=int, default=5)
            p.add_argument("--techniques", default="", help="comma-separated subset (default: all)")
            p.add_argument("--small-maps", type=int, default=0,
                           help="a dry run: maps of this size and twice it instead of the defaults and 2048^2")
        if name == "note":
            p.add_argument("section")
            p.add_argument("key")
            p.add_argument("value")
    args = ap.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)
    return {"info": cmd_info, "renders": cmd_renders, "frames": cmd_frames, "report": cmd_report,
            "note": cmd_note}[args.cmd](args)


if __name__ == "__main__":
    sys.exit(main())
