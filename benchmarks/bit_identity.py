"""Refactoring check (issue 28): render every technique at 96^2 on the head and the back-lit ear
under a sequence of setting edits, and record for each render every texture's hash, each pass's
declared settings, plan, skip reason, inputs and notes, and the frame report (ran / cached / pruned
and why). Capture before a refactor, capture after, compare: a refactor that keeps the images, the
cache keys, the pruning and "what an edit re-runs" shows 0 differences.

    python benchmarks/bit_identity.py capture before.json      # on the old tree
    python benchmarks/bit_identity.py capture after.json       # on the new tree
    python benchmarks/bit_identity.py compare before.json after.json [--rename OLD=NEW ...]

(``--techniques deon,ssss`` captures fewer; ``--rename`` maps a renamed pass.) Run it under nice:
every render runs the real graph on this machine's GL (small sizes, a few minutes on llvmpipe).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]  # this checkout's package and the tests' helpers

# the edits, applied one after another to each technique's base settings (one renderer: the cache
# state carries over, so the report says what each edit re-ran)
COMMON = [{}, {"shadow.pcf": 0, "shadow.pcf_filter": "box"}, {"specular.mode": "beckmann_lut", "specular.lut_size": 64},
          {"render.tone_map": "linear", "render.exposure": 1.3}, {"shadow.map_size_mode": "auto"},
          {"lights.0.enabled": False}, {"lights.1.kind": "point", "lights.1.position": [0, 50, -300]},
          {"render.texel_surface": False}, {"scene.back_faces": "show"}]
PER = {
    "phong": [{"phong.ambient": 0.1, "phong.shininess": 64}],
    "gosselin": [{"gosselin.radius_mode": "mm"}, {"gosselin.specular_shadow": "printed", "gosselin.iterations": 2},
                 {"gosselin.regions.ears.kernel_size": 3.0, "gosselin.scale_y": 1.0}, {"scene.seam_aware": False}],
    "deon": [{"deon.tsm": False}, {"deon.stretch_per_gaussian": True}, {"deon.stretch": False},
             {"deon.surface_gather_below_texels": 0.0}, {"deon.combine_blurs": False}, {"deon.specular_shadows": "pixel"},
             {"deon.texel_samples": 4}, {"deon.irradiance_size_mode": "auto"},
             {"deon.tsm_form": "printed", "deon.tsm_gather": 0}, {"deon.tsm_light": 0},
             {"deon.mix": 0.2, "deon.energy_conservation": False}, {"deon.fold_below_texels": 0.0},
             {"deon.open_border": "absorb", "deon.skip_gutters": False}, {"deon.stretch_shear": False},
             {"deon.gaussians.2.weights": [0.2, 0.1, 0.05]}, {"deon.subpixel_kernel_px": 4.0},
             {"scene.stretch_metric": "triangle"}],
    "ssss": [{"ssss.gaussians": 3, "ssss.taps": 9}, {"ssss.alpha": 5.0}, {"transmittance.enabled": False},
             {"transmittance.form": "exact", "transmittance.wrap": 0.3}, {"screen.texturing": "post"}],
    "separable": [{"separable.taps": 11, "separable.rotation": False}, {"separable.follow_surface": False},
                  {"screen.texturing": "pre", "screen.mix": 0.3}],
    "burley": [{"burley.transmission": "jimenez2010"}, {"burley.transmission": "thick"},
               {"burley.budget": False, "burley.samples": 8}, {"burley.view": "samples"},
               {"burley.fit": "direct", "burley.scale": 2.0}],
    "burley2": [{"burley2.mode": "three-level", "burley2.third": 4}, {"burley2.mode": "beyond"}, {"burley2.reuse": 1},
                {"burley2.temporal": 3}, {"burley2.contrast": "minmax", "burley2.split": "equal-count"},
                {"burley.view": "extra"}],
    "penner": [{"penner.penumbra": False}, {"penner.curvature_scale": 2.0, "penner.lut_size": 32},
               {"deon.energy_conservation": False}, {"penner.max_curvature": 4.0, "penner.penumbra_max_mm": 5.0}],
}


def env_edits() -> list[dict]:
    from skinviewer.ground.settings import default_rig
    rig = [light.model_dump() for light in default_rig()]
    return [{"lights": rig}, {"lights": rig, "render.background_environment": "sharp"}]


def capture(out: Path, only: list[str] | None) -> None:
    from helpers import small_settings

    from skinviewer.engine.renderer import Renderer
    from skinviewer.ground.settings import SettingsError, with_values
    from skinviewer.kernel.gl import headless_context
    from skinviewer.techniques import names
    rd = Renderer(headless_context())
    res: dict[str, dict] = {}
    for tech in names():
        if only and tech not in only:
            continue
        for scene in ("head", "backlit-ear"):
            base = small_settings(scene, tech)
            for i, edit in enumerate(COMMON + PER.get(tech, []) + (env_edits() if scene == "head" else [])):
                key = f"{tech}/{scene}/{i}"
                try:
                    s = with_values(base, edit)
                except SettingsError as exc:  # e.g. a second light on a one-light scene
                    res[key] = {"error": str(exc)}
                    continue
                rep, frames = rd.render_settled(s)
                g = rd.graph(tech)
                tex = {n: hashlib.sha1(g.read(n).tobytes()).hexdigest() for n in sorted(g.resources())}
                refl = {p: {"declared": list(r.declared), "plan": {k: repr(v) for k, v in r.planned.items()},
                            "skip": r.skip_reason, "inputs": list(r.inputs), "notes": list(r.notes)}
                        for p, r in g._last_refl.items()}
                res[key] = {"edit": repr(edit), "frames": frames, "tex": tex, "refl": refl,
                            "report": [(p.name, p.status, p.reason) for p in rep.passes]}
                print(key, f"{len(tex)} textures", flush=True)
    rd.release()
    out.write_text(json.dumps(res, indent=0, sort_keys=True))


def compare(a_path: Path, b_path: Path, renames: list[str]) -> int:
    text = a_path.read_text()
    for r in renames:
        old, new = r.split("=", 1)
        text = text.replace(old, new)
    a, b = json.loads(text), json.loads(b_path.read_text())
    ntex, nrender, bad = 0, 0, []
    only = sorted(set(a) ^ set(b))  # e.g. a capture of fewer techniques: not compared, said
    for k in sorted(set(a) & set(b)):
        x, y = a[k], b[k]
        if "error" in x or "error" in y:
            if x != y:
                bad.append(f"{k}: {x.get('error')} / {y.get('error')}")
            continue
        nrender += 1
        for name in sorted(set(x["tex"]) | set(y["tex"])):
            ntex += 1
            if x["tex"].get(name) != y["tex"].get(name):
                bad.append(f"{k}: texture {name} differs")
        for p in sorted(set(x["refl"]) | set(y["refl"])):
            rx, ry = x["refl"].get(p), y["refl"].get(p)
            if rx is None or ry is None:
                bad.append(f"{k}: pass {p} in one capture only")
                continue
            if sorted(rx["declared"]) != sorted(ry["declared"]):
                bad.append(f"{k}: {p} declares -{sorted(set(rx['declared']) - set(ry['declared']))} "
                           f"+{sorted(set(ry['declared']) - set(rx['declared']))}")
            for f in ("plan", "skip", "inputs", "notes"):
                if rx[f] != ry[f]:
                    bad.append(f"{k}: {p} {f}: {rx[f]} / {ry[f]}")
        if x["report"] != y["report"]:
            bad.append(f"{k}: report {x['report']} / {y['report']}")
    print(f"{nrender} renders, {ntex} textures compared, {len(bad)} differences"
          + (f" ({len(only)} renders in one capture only, not compared)" if only else ""))
    for line in bad[:80]:
        print(" ", line)
    return 1 if bad else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("capture")
    c.add_argument("out", type=Path)
    c.add_argument("--techniques", default="", help="comma-separated (default: all)")
    m = sub.add_parser("compare")
    m.add_argument("a", type=Path)
    m.add_argument("b", type=Path)
    m.add_argument("--rename", action="append", default=[], help="OLD=NEW: a pass renamed between the captures")
    args = ap.parse_args(argv)
    if args.cmd == "capture":
        capture(args.out, [t for t in args.techniques.split(",") if t] or None)
        return 0
    return compare(args.a, args.b, args.rename)


if __name__ == "__main__":
    sys.exit(main())
