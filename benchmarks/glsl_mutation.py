"""Hand-made GLSL mutation testing (issue 36): one-line mutations of each pass's core formula, each run
against the tests that should notice it. A mutant "survives" when those tests still pass. The shaders
are copied to a scratch folder and the tests pointed at it (SKINVIEWER_SHADERS); the checkout is not
touched. Not part of CI's time budget (each mutant renders; ~20-90 s on llvmpipe).

    python benchmarks/glsl_mutation.py                 # every mutation below
    python benchmarks/glsl_mutation.py burley-weight output-aces
    python benchmarks/glsl_mutation.py --list

Each entry: (id, shader file, the exact original text (must occur once), its replacement, pytest args:
files and one -k expression).
Results and triage are in notes/mutation.md."""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
T = "tests/"

MUTATIONS: list[tuple[str, str, str, str, list[str]]] = [
    # Burley (seed 001 eq. 3.9-3.13, 4.1; spec §5.3, §7.6)
    ("burley-inverse-cdf-misprint", "lib/burley.glsl", "(1.0 + 1.0 / g + g)", "(1.0 + 1.0 / g + 1.0 / g)",
     [T + "test_glsl_pins.py"]),
    ("burley-weight", "lib/burley.glsl", "exp(-u_S * rp) + exp(-u_S * rp / 3.0)",
     "exp(-u_S * rp) + exp(-u_S * rp / 2.0)", [T + "test_burley_gpu.py", "-k", "numpy_reference"]),
    ("burley-trigger-cutoff", "lib/burley.glsl", "any(greaterThan(C, u_cutoff1 * cut_scale))",
     "any(greaterThan(C, 2.0 * u_cutoff1 * cut_scale))", [T + "test_burley_gpu.py", "-k", "iff_contrast"]),
    ("burley-ring-contrast", "lib/burley.glsl", "return abs(L_in - L_out) / max(L_in + L_out, vec3(1e-6));",
     "return abs(L_in - L_out) / max(2.0 * (L_in + L_out), vec3(1e-6));",
     [T + "test_burley_gpu.py", "-k", "numpy_reference or iff_contrast"]),
    ("burley-reuse-tent", "burley_reuse.frag", "float g = float((REUSE_R + 1 - abs(dx)) * (REUSE_R + 1 - abs(dy)));",
     "float g = float((REUSE_R + 1 - abs(dx)));", [T + "test_burley_techniques.py"]),
    # Phong (the baseline)
    ("phong-lambert", "phong.frag", "color += Lc * s * (C * ndl + spec * ndl);", "color += Lc * s * (C + spec * ndl);",
     [T + "test_render.py", T + "test_glsl_pins.py", "-k", "plausible or pcf or phong"]),
    # output: ACES fit and sRGB encoding
    ("output-aces", "output.frag", "2.51 * x + 0.03", "2.51 * x + 0.3", [T + "test_output.py"]),
    ("srgb-encode", "lib/color.glsl", "1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055", "1.055 * pow(c, vec3(1.0 / 2.2)) - 0.055",
     [T + "test_output.py"]),
    # Kelemen/Szirmay-Kalos specular (seed 002 listings 14-1, 14-2)
    ("ks-schlick", "lib/kelemen.glsl", "float e = b2 * b2 * b;", "float e = b2 * b2;", [T + "test_specular.py"]),
    ("ks-beckmann", "lib/kelemen.glsl", "return exp(-s2 / (c2 * m2)) / (m2 * c2 * c2);",
     "return exp(-s2 / (c2 * m2)) / (m2 * c2);", [T + "test_specular.py"]),
    # d'Eon & Luebke texture-space diffusion (seed 000 eq. 21, 28, 33, 34)
    ("deon-blur-7tap-step", "lib/deon_blur.glsl", "vec2 t = uv + step_uv * float(k - 3);",
     "vec2 t = uv + 1.5 * step_uv * float(k - 3);", [T + "test_deon.py", "-k", "laser_profile or stretch_plane"]),
    ("deon-blur-narrow-gauss", "lib/deon_blur.glsl", ": exp(-fk * fk / (2.0 * s_t * s_t));", ": exp(-fk * fk / (s_t * s_t));",
     [T + "test_deon.py", T + "test_fidelity.py", "-k", "laser_profile or laser_error_falls"]),
    ("deon-final-albedo", "deon_final.frag", "diffuse *= safe_pow(C, 1.0 - u_mix) * rho_v;", "diffuse *= C * rho_v;",
     [T + "test_bench.py", T + "test_fidelity.py", "-k", "lit_plane or backlit_ear_transmits"]),
    ("deon-irradiance-ndl", "lib/deon_irradiance.glsl", "E += Lc * (ndl * s * rho);", "E += Lc * (s * rho);",
     [T + "test_bench.py", T + "test_deon.py", "-k", "lit_plane or laser_profile"]),
    ("deon-tsm-eq33", "lib/tsm_transmit.glsl", "float term = max(exp(-m * m / (k2 * v)) - carried, 0.0);",
     "float term = max(exp(-m / (k2 * v)) - carried, 0.0);",
     [T + "test_fidelity.py", "-k", "backlit_ear_transmits or fold_transmits"]),
    # Gosselin (seed 004 eq. 12, 17)
    ("gosselin-albedo", "gosselin_final.frag", "vec3 color = C * E;", "vec3 color = E;",
     [T + "test_gosselin.py", T + "test_glsl_pins.py", "-k", "not hard_cases and not nan_maps"]),
    ("gosselin-poisson-radius", "poisson_blur.frag", "sum += k * finite4(texture(source, uv + u_poisson[i] * radius));",
     "sum += k * finite4(texture(source, uv + u_poisson[i] * radius * 0.7));", [T + "test_gosselin.py"]),
    # Penner pre-integrated skin
    ("penner-penumbra", "penner.frag", "diffuse += Lc * rho * D * P;", "diffuse += Lc * rho * D;", [T + "test_penner.py"]),
    # screen space (seed 001 ch. 3; [SEP])
    ("ss-combine-albedo", "ss_combine.frag", "texelFetch(diffuse, p, 0).rgb * texelFetch(albedo, p, 0).rgb + s.rgb",
     "texelFetch(diffuse, p, 0).rgb + s.rgb", [T + "test_screen_space.py"]),
    ("ss-transmittance-gauss", "ss_transmittance.frag", "exp(-d * d / (u_tr_div * v))", "exp(-d / (u_tr_div * v))",
     [T + "test_ssss.py", T + "test_ss_transmittance.py", "-k", "transmittance"]),
    ("ss-transmittance-burley", "ss_transmittance.frag", "0.25 * (exp(-u_tr_S * d) + 3.0 * exp(-u_tr_S * d / 3.0))",
     "0.25 * (exp(-u_tr_S * d) + 3.0 * exp(-u_tr_S * d / 2.0))", [T + "test_ss_transmittance.py"]),
    ("ss-transmittance-thickness", "ss_lighting.frag", "return vec2(n / 9.0, d_sum / n);", "return vec2(n / 9.0, 0.5 * d_sum / n);",
     [T + "test_burley_techniques.py", "-k", "transmission_through_a_slab"]),
    ("ss-gauss-blur-tap", "ss_gauss_blur.frag", "acc += u_w[k] * (t.a < 0.999 ? c.rgb : t.rgb);",
     "acc += u_w[k] * t.rgb;", [T + "test_ssss.py", T + "test_screen_blur_buffers.py", "-k",
                                 "bleeding or energy or non_skin"]),
    ("ss-separable-follow", "ss_separable_blur.frag", "acc += u_k[i] * mix(t.rgb, c.rgb, k);", "acc += u_k[i] * t.rgb;",
     [T + "test_ssss.py", T + "test_screen_blur_buffers.py", "-k", "follow_surface or bleeding or non_skin"]),
    ("ss-separable-follow-depth", "ss_separable_blur.frag", "k = max(k, clamp(abs(dM - di) / u_follow_mm, 0.0, 1.0));",
     "k = max(k, 0.0 * clamp(abs(dM - di) / u_follow_mm, 0.0, 1.0));",
     [T + "test_ssss.py", T + "test_screen_blur_buffers.py", "-k", "follow"]),
    # shadows (PCF normalisation)
    ("pcf-normalisation", "lib/lights.glsl", "return lit / float((2 * r + 1) * (2 * r + 1));\n#else",
     "return lit / float((2 * r + 1) * (2 * r + 2));\n#else", [T + "test_render.py", T + "test_gosselin.py",
                                                         "-k", "pcf or zero_radius"]),
]


def apply(shaders: Path, file: str, old: str, new: str) -> None:
    p = shaders / file
    text = p.read_text()
    n = text.count(old)
    if n != 1:
        raise SystemExit(f"{file}: the original text occurs {n} times (must be once): {old!r}")
    p.write_text(text.replace(old, new))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ids", nargs="*", help="mutations to run (default: all)")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per mutant's test run")
    a = ap.parse_args(argv)
    todo = [m for m in MUTATIONS if not a.ids or m[0] in a.ids]
    if a.list or not todo:
        for mid, f, _old, _new, tests in MUTATIONS:
            print(f"{mid:<28} {f:<26} {' '.join(tests)}")
        return 0 if a.list else 2
    for mid, f, old, _new, _ in todo:  # every original present once before any run
        if (ROOT / "shaders" / f).read_text().count(old) != 1:
            print(f"{mid}: the original text is not in shaders/{f} exactly once", file=sys.stderr)
            return 2
    rows = []
    for mid, f, old, new, tests in todo:
        with tempfile.TemporaryDirectory(prefix=f"glsl-{mid}-") as d:
            shaders = Path(d) / "shaders"
            shutil.copytree(ROOT / "shaders", shaders)
            apply(shaders, f, old, new)
            env = {k: v for k, v in os.environ.items() if k != "CI"}
            env["SKINVIEWER_SHADERS"] = str(shaders)
            env["SKINVIEWER_CACHE"] = str(Path(d) / "cache")
            t0 = time.perf_counter()
            try:
                r = subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests],
                                   cwd=ROOT, env=env, capture_output=True, text=True, timeout=a.timeout, check=False)
                rc, out = r.returncode, r.stdout
            except subprocess.TimeoutExpired:
                rc, out = -1, "timeout"
            dt = time.perf_counter() - t0
        # pytest: 0 all passed (survived), 1 a test failed (killed), 5 no tests selected (a broken entry)
        status = {0: "survived", 1: "killed", -1: "timeout"}.get(rc, f"error (pytest exit {rc})")
        failed = [ln.split(" ")[1] for ln in out.splitlines() if ln.startswith("FAILED ")]
        rows.append((mid, f, status, dt, failed[:1]))
        print(f"{mid:<28} {f:<26} {status:<9} {dt:6.0f} s  {' '.join(failed[:1])}", flush=True)
    killed = sum(r[2] == "killed" for r in rows)
    print(f"\n{killed} / {len(rows)} GLSL mutants killed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
