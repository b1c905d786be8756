"""``skinviewer export --to hdrp|unreal|materialx|openpbr|blender --out PATH``: the current profile,
fitted with Burley's normalized diffusion, in the file the target reads (see engine/exchange.py)."""
from __future__ import annotations

import argparse
import sys

from skinviewer.cli.args import (
    add_scene_args,
    check_outputs,
    number,
    settings_from_args,
)
from skinviewer.engine.exchange import ExchangeError, ExportResult, export
from skinviewer.physics.engines import TARGETS


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser("export", help="fit the current profile with Burley and write it for an engine",
                       description="Fits Burley's A and d per channel to the current profile (least squares on "
                                   "r R(r)), prints what the fit loses, and writes HDRP .asset + .meta, an Unreal "
                                   "editor script, a MaterialX .mtlx (standard_surface / open_pbr_surface) or a "
                                   "Blender script.")
    add_scene_args(p)
    p.add_argument("--to", required=True, choices=TARGETS, help="target")
    p.add_argument("--out", required=True, help="file to write (.asset, .py or .mtlx as the target reads)")
    p.add_argument("--world-scale", type=number(0, 1e6, above=True), metavar="M",
                   help="HDRP worldScale: metres per world unit (default: scene.mm_per_unit / 1000, else 1 = 1 m)")
    p.add_argument("--unreal-world-unit-scale", type=number(0, 1e6, above=True), default=1.0, metavar="CM",
                   help="Unreal WorldUnitScale (cm per unit; default 1: a real-scale head, 1 uu = 1 cm)")
    p.add_argument("--profile-model", metavar="MODEL[:MATERIAL]",
                   help="fit the profile lab's model instead of the current Gaussians: dipole[:Skin1], "
                        "multipole[:MATERIAL] (default: three-layer skin), burley[:Skin1]")
    p.set_defaults(func=cmd_export)
    return p


UNITS = {"scatteringDistanceMultiplier": "mm (x scatteringDistance = Burley's d)", "worldScale": "m per world unit",
         "MeanFreePathDistance": "cm (Unreal units)", "WorldUnitScale": "cm per Unreal unit",
         "radius_scale_mm": "mm", "Subsurface Scale (m)": "m (the script divides by the scene's unit scale)",
         "smoothness": "(HDRP keeps it in the material)", "MaterialRoughness": "(set on the material)"}


def print_result(r: ExportResult, target: str) -> None:
    print(f"fitted Burley to {r.description}")
    print(f"{'channel':>8} {'A':>8} {'d (mm)':>10} {'err r.R(r)':>11} {'err R_d':>9}")
    for c, ch in enumerate(("red", "green", "blue")):
        print(f"{ch:>8} {r.fit.A[c]:8.4f} {r.fit.d[c]:10.5f} {100 * r.fit.error[c]:10.2f}% "
              f"{100 * r.fit.rd_error[c]:8.2f}%")
    print(f"{target} fields:")
    for k, v in r.fields.items():
        if k == "target":
            continue
        val = ", ".join(f"{x:.5g}" for x in v) if isinstance(v, (list, tuple)) else \
            (f"{v:.6g}" if isinstance(v, float) else str(v))
        print(f"  {k}: {val}" + (f"  {UNITS[k]}" if k in UNITS else ""))
    print(f"  specular: Beckmann m -> roughness {r.skin.roughness:.4f} (alpha = m), F0 -> IOR {r.skin.ior:.4f}")
    for w in r.written:
        print(f"wrote {w}")


def cmd_export(args) -> int:
    s = settings_from_args(args)
    check_outputs({"--out": args.out}, {"--preset": args.preset}, s)
    if args.world_scale is not None and not (args.world_scale > 0):
        print("skinviewer export: error: --world-scale must be > 0 metres per unit", file=sys.stderr)
        return 2
    try:
        r = export(s, args.to, args.out, args.world_scale, args.unreal_world_unit_scale, args.profile_model)
    except ExchangeError as exc:
        print(f"skinviewer export: error: {exc}", file=sys.stderr)
        return 2
    print_result(r, args.to)
    return 0
