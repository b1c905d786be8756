"""``skinviewer import PATH``: an HDRP .asset, a .mtlx, an exported script or the JSON of values an
engine shows -> Burley's profile -> the techniques' Gaussians (the profile lab's fit) -> a preset and
a preview render. Every field it does not use is listed."""
from __future__ import annotations

import argparse
import sys

from skinviewer.cli.args import _size, check_outputs, image_output
from skinviewer.engine.exchange import ExchangeError, Imported, read_any, settings_with
from skinviewer.ground.settings import Settings, SettingsError, load_preset, save_preset
from skinviewer.physics import engines as E


def add_parser(sub) -> argparse.ArgumentParser:
    p = sub.add_parser("import", help="read an engine's skin profile back (HDRP .asset, .mtlx, JSON)",
                       description="Reads an HDRP Diffusion Profile .asset, a MaterialX .mtlx, a script written by "
                                   "`skinviewer export` or a JSON of the values an engine shows; converts them to "
                                   "Burley's profile, fits the techniques' Gaussians, writes a preset and a preview.")
    p.add_argument("path", help="file to import")
    p.add_argument("--material", help=".mtlx: which material or surface shader, when it holds several")
    p.add_argument("--base-preset", metavar="FILE.json", help="preset the imported profile goes into")
    p.add_argument("--preset-out", metavar="FILE.json", help="write the result as a preset")
    p.add_argument("--preview", metavar="FILE.png", help="render the result (headless) to this image (.png, .jpg, "
                   ".tif or .bmp)")
    p.add_argument("--technique", default=None, help="technique of the preview (default: the preset's)")
    p.add_argument("--size", type=_size, default=(384, 384), help="preview size WxH (default 384x384)")
    p.set_defaults(func=cmd_import)
    return p


def print_import(imp: Imported, fit) -> None:
    print(f"read a {imp.target} profile: Burley per channel")
    print(f"{'channel':>8} {'A':>8} {'d (mm)':>10}")
    for c, ch in enumerate(("red", "green", "blue")):
        print(f"{ch:>8} {imp.skin.A[c]:8.4f} {imp.skin.d_mm[c]:10.5f}")
    if not imp.skin.albedo_in_profile:
        print("  (the profile is normalised: the albedo is the material's base colour)")
    rough = (f"roughness {imp.skin.roughness:.4f} -> Beckmann m {E.roughness_to_beckmann(imp.skin.roughness):.4f}, "
             if imp.has_roughness else "roughness: the material's (specular.m kept), ")
    print(f"  specular: {rough}IOR {imp.skin.ior:.4f} -> F0 {E.ior_to_f0(imp.skin.ior):.4f}")
    if imp.metres_per_unit is not None:
        print(f"  world scale: {imp.metres_per_unit:g} m per unit ({imp.metres_per_unit * 1000:g} mm)")
    print(f"Gaussians for the techniques: {fit.k}, error (eq. 3.1) " +
          " ".join(f"{100 * e:.2f}%" for e in fit.errors))
    for n in imp.notes:
        print(f"note: {n}")
    if imp.skipped:
        print(f"skipped (not used here): {', '.join(imp.skipped)}")


def cmd_import(args) -> int:
    image_output(args.preview, "--preview", linear=False)
    check_outputs({"--preset-out": args.preset_out, "--preview": args.preview},
                  {"the imported file": args.path, "--base-preset": args.base_preset})
    try:
        imp = read_any(args.path, args.material)
        base = load_preset(args.base_preset) if args.base_preset else Settings()
        s, fit = settings_with(base, imp)
    except ExchangeError as exc:
        print(f"skinviewer import: error: {args.path}: {exc}", file=sys.stderr)
        return 2
    except SettingsError as exc:
        print(f"skinviewer import: error: {exc}", file=sys.stderr)
        return 2
    print_import(imp, fit)
    if args.preset_out:
        save_preset(s, args.preset_out)
        print(f"wrote {args.preset_out}")
    if args.preview:
        from skinviewer.cli.turntable import render_frames
        from skinviewer.ground.settings import with_values
        w, h = args.size
        vals = {"render.width": w, "render.height": h}
        if args.technique:
            vals["technique"] = args.technique
        ps = with_values(s, vals)
        (img, ms), = render_frames(ps, [ps])
        from skinviewer.ground.files import save_image
        save_image(args.preview, img)
        print(f"wrote {args.preview} ({ps.technique}, {w}x{h}, {ms:.0f} ms)")
    return 0
