"""``skinviewer profile``: diffusion profile -> sum of Gaussians -> d'Eon preset.

  skinviewer profile --model dipole --material Skin1 --fit 6 --preset-out skin1.json
  skinviewer render --preset skin1.json
"""
from __future__ import annotations

import argparse
import json
import math
import sys

from skinviewer.cli.args import check_outputs, number
from skinviewer.physics import profiles as P
from skinviewer.physics.fitting import FitResult, fit_gaussians

MAX_PRESET_GAUSSIANS = 8


class _Bad(Exception):
    pass


def _triple(text: str, name: str) -> tuple[float, float, float]:
    parts = [p.strip() for p in str(text).split(",")]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise _Bad(f"{name}: expected a number or r,g,b numbers, got {text!r}") from None
    if len(vals) == 1:
        vals *= 3
    if len(vals) != 3 or not all(math.isfinite(v) for v in vals):
        raise _Bad(f"{name}: expected 1 or 3 finite numbers (r,g,b), got {text!r}")
    return (vals[0], vals[1], vals[2])


def _warn_thin(thickness: float, ssp, sa, what: str) -> None:
    """The multipole assumes a slab thicker than one transport mean free path 1/sigma_t' (seed 001
    §2.3.4); thinner, its transmittance can even turn negative. Say so, once, on stderr."""
    mfp = max(1.0 / max(s + a, 1e-12) for s, a in zip(ssp, sa))
    if math.isfinite(thickness) and thickness < mfp:
        print(f"skinviewer profile: note: {what} is {thickness:g} mm thick, under one mean free path "
              f"({mfp:.3g} mm): the multipole is unreliable there", file=sys.stderr)


def _layer(text: str) -> P.Layer:
    # THICKNESS:SSP_R,SSP_G,SSP_B:SA_R,SA_G,SA_B[:ETA]
    parts = text.split(":")
    if len(parts) not in (3, 4):
        raise _Bad(f"--layer: expected THICKNESS:SIGMA_S'(r,g,b):SIGMA_A(r,g,b)[:ETA], got {text!r}")
    try:
        t = float(parts[0])
        eta = float(parts[3]) if len(parts) == 4 else 1.4
    except ValueError:
        raise _Bad(f"--layer: bad thickness or eta in {text!r}") from None
    if not (t > 0 and not math.isnan(t) and math.isfinite(eta) and 0 < eta <= 10):
        raise _Bad(f"--layer: the thickness must be > 0 mm (inf: the last layer) and eta in (0, 10], got {text!r}")
    return P.Layer(_triple(parts[1], "--layer sigma_s'"), _triple(parts[2], "--layer sigma_a"), t, eta)


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "profile", help="compute a diffusion profile, fit Gaussians, write a d'Eon preset",
        description="Diffusion profile (dipole / multipole / Burley) -> sum-of-Gaussians fit (seed 000 "
                    "eq. 20-22, error seed 001 eq. 3.1) -> optional plot and preset. Units: mm, 1/mm.")
    p.add_argument("--model", choices=("dipole", "multipole", "burley"), default="dipole")
    p.add_argument("--material", help=f"Jensen 2001 measured material: {', '.join(P.MATERIALS)}")
    p.add_argument("--sigma-s-prime", metavar="R,G,B", help="reduced scattering coefficient (1/mm)")
    p.add_argument("--sigma-a", metavar="R,G,B", help="absorption coefficient (1/mm)")
    p.add_argument("--eta", type=number(0, 10, above=True), default=None, help="relative index of refraction (default 1.3; "
                                                           "layers 1.4)")
    p.add_argument("--thickness", type=number(0, None, above=True, allow_inf=True), default=math.inf,
                   help="multipole: slab thickness in mm for --material/--sigma-* (default inf = dipole)")
    p.add_argument("--layer", action="append", default=[], metavar="T:SSP:SA[:ETA]",
                   help="multipole: a layer, top first, e.g. 0.25:8,9,10:0.05,0.15,0.4:1.4; "
                        "T may be inf for the last layer (repeat the option)")
    p.add_argument("--skin-example", action="store_true",
                   help="multipole: the documented three-layer skin example (default without layers)")
    p.add_argument("--albedo", metavar="R,G,B", help="burley: surface albedo A in [0, 1]")
    p.add_argument("--mfp", metavar="R,G,B", help="burley: (diffuse) mean free path in mm")
    p.add_argument("--burley-config", choices=P.BURLEY_CONFIGS, default="searchlight-dmfp",
                   help="Christensen's s(A) fit: eq. 2.86, 2.88 (default), 2.89")
    p.add_argument("--fit", type=int, default=4, metavar="K", help="number of Gaussians (1..16, default 4)")
    p.add_argument("--fixed-variances", metavar="V1,V2,...", help="fit only weights for these variances (mm^2)")
    p.add_argument("--per-channel", action="store_true", help="separate variances per channel "
                                                              "(default: shared, as a preset needs)")
    p.add_argument("--json", action="store_true", help="print the fit as JSON")
    p.add_argument("--plot", metavar="FILE.png", help="write r*R(r) with the fit overlaid")
    p.add_argument("--preset-out", metavar="FILE.json", help="write a d'Eon preset with the fitted Gaussians")
    p.add_argument("--base-preset", metavar="FILE.json", help="preset to start from (default: defaults)")
    p.add_argument("--no-normalize", action="store_true",
                   help="keep raw weights in the preset (default: each channel's weights sum to 1)")
    p.set_defaults(func=run)
    return p


def _build_model(a):
    has_coeffs = a.sigma_s_prime is not None or a.sigma_a is not None
    if a.model == "burley":
        if a.layer or a.skin_example:
            raise _Bad("--layer/--skin-example are multipole options")
        if a.material:
            if has_coeffs or a.albedo or a.mfp:
                raise _Bad("give either --material or --albedo/--mfp, not both")
            m = _material(a.material)
            if min(m.sigma_a) <= 0:
                raise _Bad(f"{a.material}: Burley's diffuse mean free path needs sigma_a > 0 in every channel")
            eta = m.eta if a.eta is None else a.eta
            # searchlight + diffuse mean free path: A = R_d of the dipole, l_d = 1/sigma_tr (eq. 2.87)
            A = P.Dipole(m.sigma_s_prime, m.sigma_a, eta).total_reflectance()
            return P.Burley(A, P.diffuse_mean_free_path(m.sigma_s_prime, m.sigma_a), "searchlight-dmfp"), \
                f"Burley (dmfp) from {a.material}"
        if a.albedo is None or a.mfp is None:
            raise _Bad("burley needs --albedo R,G,B and --mfp R,G,B (mm), or --material NAME")
        return P.Burley(_triple(a.albedo, "--albedo"), _triple(a.mfp, "--mfp"), a.burley_config), \
            f"Burley ({a.burley_config})"
    if a.albedo or a.mfp:
        raise _Bad("--albedo/--mfp are Burley options (use --model burley)")
    ssp, sa, eta, name = None, None, a.eta, ""
    if a.material:
        if has_coeffs:
            raise _Bad("give either --material or --sigma-s-prime/--sigma-a, not both")
        m = _material(a.material)
        ssp, sa, name = m.sigma_s_prime, m.sigma_a, a.material
        eta = m.eta if eta is None else eta
    elif has_coeffs:
        if a.sigma_s_prime is None or a.sigma_a is None:
            raise _Bad("give both --sigma-s-prime and --sigma-a")
        ssp, sa = _triple(a.sigma_s_prime, "--sigma-s-prime"), _triple(a.sigma_a, "--sigma-a")
        name = "custom"
    eta = 1.3 if eta is None else eta
    if a.model == "dipole":
        if a.layer or a.skin_example or not math.isinf(a.thickness):
            raise _Bad("--layer/--skin-example/--thickness are multipole options")
        if ssp is None or sa is None:
            raise _Bad("dipole needs --material NAME or --sigma-s-prime R,G,B --sigma-a R,G,B")
        return P.Dipole(ssp, sa, eta), f"dipole: {name}"
    # multipole
    if ssp is not None and sa is not None:
        if a.layer or a.skin_example:
            raise _Bad("give either a material/coefficients (one slab) or --layer/--skin-example")
        if not (a.thickness > 0):
            raise _Bad("--thickness must be > 0 mm")
        _warn_thin(a.thickness, ssp, sa, "the slab")
        return P.Multipole(ssp, sa, a.thickness, eta), f"multipole: {name}, slab {a.thickness:g} mm"
    if a.layer:
        if a.skin_example:
            raise _Bad("give either --layer options or --skin-example")
        layers = [_layer(t) for t in a.layer]
        for i, lay in enumerate(layers):
            _warn_thin(lay.thickness, lay.sigma_s_prime, lay.sigma_a, f"layer {i + 1}")
        return P.LayeredMultipole(layers), f"multipole: {len(a.layer)} layers"
    return P.three_layer_skin(), "multipole: three-layer skin example"


def _material(name: str) -> P.Material:
    try:
        return P.material(name)
    except KeyError as exc:
        raise _Bad(exc.args[0]) from None


def _fit(a, model) -> FitResult:
    fixed = None
    if a.fixed_variances:
        try:
            fixed = [float(x) for x in a.fixed_variances.split(",")]
        except ValueError:
            raise _Bad(f"--fixed-variances: expected comma-separated numbers, got {a.fixed_variances!r}") from None
        if not all(math.isfinite(v) and v > 0 for v in fixed):
            raise _Bad("--fixed-variances must be positive (mm^2)")
    elif not (1 <= a.fit <= 16):
        raise _Bad("--fit must be between 1 and 16")
    return fit_gaussians(model, a.fit, shared=not a.per_channel, fixed_variances=fixed)


def _preset(a, fit: FitResult):
    from skinviewer.ground.settings import (
        Settings,
        SettingsError,
        load_preset,
        save_preset,
        with_values,
    )
    rows = fit.table(normalize=not a.no_normalize)
    if len(rows) > MAX_PRESET_GAUSSIANS:
        raise _Bad(f"a preset holds at most {MAX_PRESET_GAUSSIANS} Gaussians, this fit has {len(rows)} "
                   "(use fewer, or shared variances)")
    try:
        base = load_preset(a.base_preset) if a.base_preset else Settings()
        s = with_values(base, {"technique": "deon",
                               "deon.gaussians": [{"variance": v, "weights": list(w)} for v, w in rows]})
        save_preset(s, a.preset_out)
    except SettingsError as exc:
        raise _Bad(str(exc)) from None
    except OSError as exc:
        raise _Bad(f"cannot write {a.preset_out}: {exc.strerror or exc}") from None


def _print_table(title: str, fit: FitResult, normalize: bool) -> None:
    print(f"{title}: {fit.k} Gaussians, {'shared' if fit.shared else 'per-channel'} variances, "
          f"fit in {1000 * fit.seconds:.0f} ms")
    print(f"{'variance (mm^2)':>16} {'red':>9} {'green':>9} {'blue':>9}")
    for v, w in fit.table():
        print(f"{v:16.5g} {w[0]:9.4f} {w[1]:9.4f} {w[2]:9.4f}")
    print(f"{'error (eq. 3.1)':>16} " + " ".join(f"{100 * e:8.4f}%" for e in fit.errors))
    print(f"{'R_d profile':>16} " + " ".join(f"{x:9.4f}" for x in fit.target_total))
    print(f"{'R_d Gaussians':>16} " + " ".join(f"{x:9.4f}" for x in fit.fitted_total))
    if normalize:
        print("(the preset stores each channel's weights normalised to sum 1; R_d belongs in the albedo)")


def run(args: argparse.Namespace) -> int:
    if args.plot and not str(args.plot).lower().endswith(".png"):
        print(f"skinviewer profile: error: --plot {args.plot}: the plot is a PNG; name the file .png", file=sys.stderr)
        return 2
    check_outputs({"--plot": args.plot, "--preset-out": args.preset_out}, {"--base-preset": args.base_preset})
    try:
        model, title = _build_model(args)
        fit = _fit(args, model)
        if args.plot:
            from skinviewer.cli.profile_plot import save_plot
            try:
                save_plot(args.plot, model, fit, title=title)
            except OSError as exc:
                raise _Bad(f"cannot write {args.plot}: {exc.strerror or exc}") from None
        if args.preset_out:
            _preset(args, fit)
        if args.json:
            out = fit.to_dict()
            out["model"] = title
            out["preset_table"] = [{"variance": v, "weights": list(w)}
                                   for v, w in fit.table(normalize=not args.no_normalize)]
            print(json.dumps(out, indent=2))
        else:
            _print_table(title, fit, normalize=bool(args.preset_out) and not args.no_normalize)
        return 0
    except (_Bad, ValueError) as exc:
        print(f"skinviewer profile: error: {exc}", file=sys.stderr)
        return 2


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="skinviewer")
    add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
