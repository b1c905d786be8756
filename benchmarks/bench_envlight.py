"""Environment lighting (issue 32): every technique's error against the ground truth with the studio
environment plus a key light, beside its error with the key light alone; the environment's cost in each
technique's frame; the visibility bake apart; and the deon sweep of the diffuse visibility (SH transfer
vectors of order 4 / 2, AO x SH at the bent normal, none), the bake's rays and the SH order.

    python benchmarks/bench_envlight.py [--size 192] [--scan PATH] [--runs 3] [--out DIR] [--techniques a,b]
                                        [--no-head] [--no-scan]

Both references (key alone, environment + key) come from skinviewer.engine.reference (Embree, brute-force
diffusion; the environment by the control-variate Monte Carlo, its standard error printed). Frame times are
sync-timed (glFinish + wall clock), the median of ``--runs`` forced frames, env and key-only runs
interleaved in one process. Never asserted anywhere: machine-dependent.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from skinviewer import techniques
from skinviewer.engine.bench import compare_mask, linear_image
from skinviewer.engine.reference import compute_reference
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import load_preset, with_values
from skinviewer.kernel.gl import describe, headless_context
from skinviewer.physics.metrics import image_error

ROOT = Path(__file__).resolve().parents[1]


def scenes(args):
    base = load_preset(ROOT / "presets" / "studio-environment.json")
    base = with_values(base, {"render.width": args.size, "render.height": args.size})
    out = [] if args.no_head else [("head", base)]
    if args.scan and Path(args.scan).is_file() and not args.no_scan:
        out.append(("scan", with_values(base, {"scene.mesh": args.scan, "scene.mm_per_unit": 48.0})))
    return out


def key_only(s):
    d = s.model_dump(mode="json")
    d["lights"] = [l for l in d["lights"] if l["kind"] != "environment"]
    d["deon"]["tsm_light"] = 0
    return type(s).model_validate(d)


def frame_ms(r, s, runs):
    r.render(s, timing="sync")
    return statistics.median(r.render(s, force=True, timing="sync").total_ms for _ in range(runs))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=192)
    ap.add_argument("--scan", default=str(ROOT.parent / "shared/assets/lee-perry-smith/LeePerrySmith.glb"))
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default="bench_envlight")
    ap.add_argument("--techniques", default=",".join(techniques.names()))
    ap.add_argument("--no-scan", action="store_true")
    ap.add_argument("--no-head", action="store_true")
    args = ap.parse_args()
    names = args.techniques.split(",")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ctx = headless_context()
    print("GL:", describe(ctx))
    rows, extra = [], {}
    for scene, s_env in scenes(args):
        s_key = key_only(s_env)
        t0 = time.perf_counter()
        ref_env = compute_reference(s_env)
        t_env = time.perf_counter() - t0
        ref_key = compute_reference(s_key)
        extra[scene] = {"reference_env_s": t_env, "reference_env_meta": ref_env.meta.get("env", {})}
        print(f"{scene}: reference (env + key) {t_env:.0f} s; MC error {ref_env.meta.get('env')}")
        r = Renderer(ctx)
        try:
            for tech in names:
                se, sk = with_values(s_env, {"technique": tech}), with_values(s_key, {"technique": tech})
                r.render(se, timing="sync")
                bake = dict(r.scene.gpu.env_bake_seconds)
                img, cov = linear_image(r, se)
                e_env = image_error(img, ref_env.lit, compare_mask(ref_env.mask, cov))
                r.render(sk, timing="sync")
                img, cov = linear_image(r, sk)
                e_key = image_error(img, ref_key.lit, compare_mask(ref_key.mask, cov))
                ms_env, ms_key = [], []
                for _ in range(args.runs):  # interleaved: load on the machine hits both alike
                    ms_env.append(frame_ms(r, se, 1))
                    ms_key.append(frame_ms(r, sk, 1))
                row = {"scene": scene, "technique": tech, "rms_env": e_env.rms_mean, "dssim_env": e_env.dssim,
                       "rms_key": e_key.rms_mean, "dssim_key": e_key.dssim,
                       "ms_env": statistics.median(ms_env), "ms_key": statistics.median(ms_key),
                       "ao_bake_s": {f"lod{k[0]} rays{k[1]}": v for k, v in bake.items()}}
                rows.append(row)
                print(f"{scene:5s} {tech:9s} RMS env+key {100 * row['rms_env']:6.2f} %  key only {100 * row['rms_key']:6.2f} %"
                      f"  DSSIM {row['dssim_env']:.4f} / {row['dssim_key']:.4f}  frame {row['ms_env']:8.1f} ms"
                      f" vs {row['ms_key']:8.1f} ms  bake {row['ao_bake_s']}", flush=True)
            # deon: SH order and AO rays against the same truth
            for label, ch in [("transfer4", {}), ("transfer2", {"lights.0.transfer_order": 2}),
                              ("AOxSH", {"lights.0.transfer_order": 0}),
                              ("AOxSH r64", {"lights.0.transfer_order": 0, "lights.0.ao_rays": 64}),
                              ("no occl", {"lights.0.occlusion": False}),
                              ("t4 r64", {"lights.0.ao_rays": 64}), ("t4 r1024", {"lights.0.ao_rays": 1024}),
                              ("sh0 (AO)", {"lights.0.sh_order": 0, "lights.0.transfer_order": 0}),
                              ("sh1 (AO)", {"lights.0.sh_order": 1, "lights.0.transfer_order": 0})]:
                s = with_values(s_env, {"technique": "deon", **ch})
                r.render(s, timing="sync")
                img, cov = linear_image(r, s)
                e = image_error(img, ref_env.lit, compare_mask(ref_env.mask, cov))
                rows.append({"scene": scene, "technique": f"deon {label}", "rms_env": e.rms_mean, "dssim_env": e.dssim})
                print(f"{scene:5s} deon {label:7s} RMS {100 * e.rms_mean:6.2f} %  DSSIM {e.dssim:.4f}", flush=True)
        finally:
            r.release()
        (out / "results.json").write_text(json.dumps({"gl": describe(ctx), "size": args.size, "rows": rows,
                                                      "references": extra}, indent=2) + "\n")
    (out / "results.json").write_text(json.dumps({"gl": describe(ctx), "size": args.size, "rows": rows,
                                                  "references": extra}, indent=2) + "\n")


if __name__ == "__main__":
    main()
