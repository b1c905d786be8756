#!/usr/bin/env bash
# The GPU check (issue 31) in one call: correctness, image parity, timings and memory on the GL at
# hand, results into OUTDIR (summary.md, results.json, renders.npz, suite.log, bench.md, run.log).
#
#   benchmarks/gpu/run.sh OUTDIR [--light]
#
# On a machine without network (the lent GPU machine) it first unpacks the carried EGL/GLVND loader
# (.gl/*.deb, as root) and installs the carried wheels (.whl/*.whl) into a private folder; both are
# made beforehand by `benchmarks/gpu/prepare.sh`. Reference renders made on llvmpipe by the same
# script (.gpuref/renders.npz) are compared with this GL's. The scan is read from $SKINVIEWER_SHARED
# (default ../shared; .gpushared when carried). --light: smaller sizes, for a dry run on llvmpipe.
set -uo pipefail
OUT=${1:?usage: benchmarks/gpu/run.sh OUTDIR [--light]}
LIGHT=${2:-}
cd "$(dirname "$0")/../.."
ROOT=$PWD
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
exec > >(tee -a "$OUT/run.log") 2>&1
T0=$(date +%s)
# STEPS: which of renders, frames, suite, truth, calibrate, perf, diag to run (default all but perf, diag)
STEPS=${STEPS:-renders frames calibrate suite truth}
want() { [[ " $STEPS " == *" $1 "* ]]; }
stamp() { echo "== $(( $(date +%s) - T0 )) s: $*"; }
# the whole run fits in RUN_SECONDS (default 520: a 10-minute call with the machine's start): each
# step gets at most what is left, less 20 s for the report
DEADLINE=$(( T0 + ${RUN_SECONDS:-520} ))
cap() { local left=$(( DEADLINE - $(date +%s) - 20 )); [ "$left" -lt "$1" ] && echo $(( left > 5 ? left : 5 )) || echo "$1"; }

stamp "loaders and wheels"
if compgen -G ".gl/*.deb" >/dev/null && [ "$(id -u)" = 0 ]; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
for j in /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json /usr/share/glvnd/egl_vendor.d/10_nvidia.json; do
    if [ -f "$j" ] && [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ]; then export __EGL_VENDOR_LIBRARY_FILENAMES=$j; fi
done
# the wheels only where the renderer's packages are missing (they are built for the GPU image's Python)
if compgen -G ".whl/*.whl" >/dev/null && ! python3 -c "import moderngl, glcontext, glm, trimesh, embreex, pydantic" 2>/dev/null; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/skinviewer-site .whl/*.whl \
        || { echo "the carried wheels did not install"; exit 2; }
    export PYTHONPATH=/tmp/skinviewer-site${PYTHONPATH:+:$PYTHONPATH}
fi
export PYTHONPATH=$ROOT${PYTHONPATH:+:$PYTHONPATH}
if [ -z "${SKINVIEWER_SHARED:-}" ]; then
    if [ -d .gpushared ]; then export SKINVIEWER_SHARED=$ROOT/.gpushared; else export SKINVIEWER_SHARED=$ROOT/../shared; fi
fi
export SKINVIEWER_CACHE=${SKINVIEWER_CACHE:-/tmp/skinviewer-gpu-cache}
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader \
    | tee "$OUT/nvidia-smi.txt"

stamp "GL context"
python3 benchmarks/gpu/gpu_check.py info --out "$OUT" || { echo "no GL context: stopping"; exit 3; }
if [ -f "$OUT/nvidia-smi.txt" ]; then
    python3 benchmarks/gpu/gpu_check.py note --out "$OUT" extra_info "nvidia-smi (name, driver, memory)" "$(cat "$OUT/nvidia-smi.txt")"
    rm -f "$OUT/nvidia-smi.txt"
fi

if [ "$LIGHT" = "--light" ]; then SIZE=128; W=320; H=180; REPS=2; TSIZE=96x96; FRAMES_EXTRA=(--small-maps 256); SUITE=(tests/test_settings.py tests/test_graph.py); PERF=(--maps 512 --size 128 --repeats 2); else SIZE=256; W=1920; H=1080; REPS=5; TSIZE=128x128; FRAMES_EXTRA=(); SUITE=(); PERF=(--maps 1024 --repeats 5); fi
# SUITE_FILES: a part of the suite (test files or globs) instead of the whole, for a short call
if [ -n "${SUITE_FILES:-}" ]; then SUITE=($SUITE_FILES); fi

want renders && stamp "renders and parity" && timeout "$(cap 120)" python3 benchmarks/gpu/gpu_check.py renders --out "$OUT" --size $SIZE $( [ "$SIZE" = 256 ] && echo --ref .gpuref/renders.npz )

want frames && stamp "frames, ratios, memory" && timeout "$(cap 240)" python3 benchmarks/gpu/gpu_check.py frames --out "$OUT" --width $W --height $H --repeats $REPS "${FRAMES_EXTRA[@]}"

if want perf; then
    # issue 27 on this GL, <= 90 s in all: one d'Eon blur direction as fragment draws vs compute passes
    # (render.compute_blur off / on, the defaults' light move, outputs compared), the synthetic compute
    # blur (outputs checked against the fragment one), and the graph's own CPU work per frame
    stamp "perf: d'Eon blur direction fragment vs compute, synthetic compute blur, CPU overhead"
    PERF_END=$(( $(date +%s) + 60 ))
    left() { local l=$(( PERF_END - $(date +%s) )); [ "$l" -lt "$1" ] && l=$(( l > 5 ? l : 5 )) || l=$1; cap "$l"; }
    timeout "$(left 30)" python3 benchmarks/bench_blur_floor.py --compute "${PERF[@]}" >> "$OUT/perf.md" 2>&1
    timeout "$(left 10)" python3 benchmarks/bench_compute_blur.py --maps "${PERF[1]}" --repeats 9 >> "$OUT/perf.md" 2>&1
    if [ -f benchmarks/bench_cpu_overhead.py ]; then
        # both paths of the graph's cached-frame fast path, interleaved (session 10: --fast ab), then issue 27's
        # camera-only goal at the frames' size: d'Eon's wall / Phong's, the fast path off / on
        PERF_END=$(( PERF_END + 40 ))
        timeout "$(left 35)" python3 benchmarks/bench_cpu_overhead.py --repeats 9 >> "$OUT/perf.md" 2>&1
        timeout "$(left 25)" python3 benchmarks/bench_cpu_overhead.py --size "${W}x${H}" --techniques phong,deon \
            --kinds camera --repeats 15 --profile "" >> "$OUT/perf.md" 2>&1
    fi
    # d'Eon's light move draw by draw, the summed step four texels a fragment (forced: auto keeps it to
    # software rasterizers) against one texel a fragment (B): whether the quad sum pays on a GPU too
    PERF_END=$(( PERF_END + 30 ))
    SKINVIEWER_QUAD_SUM=1 timeout "$(left 30)" python3 benchmarks/bench_deon_draws.py "${PERF[@]}" --ab-no-quad-sum \
        > "$OUT/deon_draws.txt" 2>&1  # whole (a pipe into head broke it off); its head in perf.md
    head -n 16 "$OUT/deon_draws.txt" >> "$OUT/perf.md"
fi

if want calibrate; then
    # the quality governor's calibration of this GPU (issue 27): shipped for exactly this renderer
    stamp "governor calibration"
    timeout "$(cap 120)" python3 -m skinviewer calibrate --runs 3 && cp "$SKINVIEWER_CACHE"/calibration/*.json "$OUT/calibration.json"
fi

if want suite; then
stamp "headless test suite"
ignore=()
for mod in imageio_ffmpeg moderngl_window imgui_bundle materialx; do
    python3 -c "import $mod" 2>/dev/null && continue
    pat="^(import|from) $mod|^[A-Za-z_].*importorskip\(\"$mod\"\)"  # module level only: a test that skips itself stays
    [ "$mod" = imgui_bundle ] && pat="$pat|^from skinviewer\.ui|^import skinviewer\.ui"  # the viewer's modules import imgui
    for f in $(grep -l -E "$pat" tests/*.py 2>/dev/null); do ignore+=(--ignore "$f"); done
done
[ ${#ignore[@]} -gt 0 ] && python3 benchmarks/gpu/gpu_check.py note --out "$OUT" suite ignored "$(printf '%s ' "${ignore[@]}" | sed 's/--ignore //g')"
# tests of CPU-side file formats whose decoders are not carried (the MP4 encoder; Radiance .hdr)
k=""
python3 -c "import imageio_ffmpeg" 2>/dev/null || k="not mp4"
python3 -c "import imagecodecs" 2>/dev/null || k="${k:+$k and }not hdr_and_exr and not cube_cross and not bad_environment_files"
kexpr=(); [ -n "$k" ] && kexpr=(-k "$k") && python3 benchmarks/gpu/gpu_check.py note --out "$OUT" suite deselected "$k"
NPROC=$(nproc)
xdist=(); if python3 -c "import xdist" 2>/dev/null && [ "$NPROC" -ge 8 ]; then xdist=(-n 8); fi
# in parallel workers where the machine has the cores; what fails there is re-run alone (--lf), so
# a race between workers is told apart from a failure
PYC=(-o cache_dir=/tmp/skinviewer-pytest-cache)
timeout "$(cap "${SUITE_SECONDS:-170}")" python3 -m pytest -q "${PYC[@]}" -m "not viewer" "${kexpr[@]}" "${ignore[@]}" "${xdist[@]}" "${SUITE[@]}" > "$OUT/suite.log" 2>&1
rc=$?
echo "pytest exit $rc"
if [ $rc = 1 ] && [ ${#xdist[@]} -gt 0 ]; then
    echo "== re-running the failures alone" >> "$OUT/suite.log"
    timeout "$(cap 60)" python3 -m pytest -q "${PYC[@]}" -m "not viewer" "${kexpr[@]}" --lf "${ignore[@]}" "${SUITE[@]}" >> "$OUT/suite.log" 2>&1
    echo "pytest --lf exit $?"
fi
tail -n 15 "$OUT/suite.log"
python3 benchmarks/gpu/gpu_check.py note --out "$OUT" suite summary "$(tail -n 1 "$OUT/suite.log")"

fi

if want truth; then
stamp "ground truth and bench wall time"
s0=$(date +%s.%N)
timeout "$(cap 100)" python3 -m skinviewer reference --size $TSIZE --no-cache --out /tmp/skinviewer-truth.png >/dev/null \
    && python3 benchmarks/gpu/gpu_check.py note --out "$OUT" walls "reference, default head, $TSIZE, no cache" \
       "$(python3 -c "print(f'{$(date +%s.%N) - $s0:.1f}')")"
s0=$(date +%s.%N)
[ -f /tmp/skinviewer-truth.png ] && timeout "$(cap 90)" python3 -m skinviewer bench --quick --size $TSIZE --techniques phong,deon,ssss,burley2 --out /tmp/skinviewer-bench >/dev/null \
    && python3 benchmarks/gpu/gpu_check.py note --out "$OUT" walls "bench --quick (phong, deon, ssss, burley2), $TSIZE, truth cached" \
       "$(python3 -c "print(f'{$(date +%s.%N) - $s0:.1f}')")" \
    && cp /tmp/skinviewer-bench/results.md "$OUT/bench.md"
[ -f "$OUT/bench.md" ] || python3 benchmarks/gpu/gpu_check.py note --out "$OUT" walls "reference or bench" "did not finish in the time left"

fi


if want diag; then
    stamp "diagnostics"
    timeout "$(cap 120)" python3 benchmarks/gpu/diag.py --out "$OUT"
fi

stamp "report"
python3 benchmarks/gpu/gpu_check.py report --out "$OUT" >/dev/null
stamp "done: $OUT/summary.md"
