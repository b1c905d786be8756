#!/usr/bin/env bash
# Prepare what the GPU check carries to a machine without network (issue 31), in the checkout:
#   .gl/        the GLVND/EGL/Vulkan loader .debs (amd64), unpacked there as root
#   .whl/       Python 3.12 manylinux wheels of the renderer's packages that machine lacks
#   .gpushared/ a copy of ../shared (the scan), read through SKINVIEWER_SHARED
#   .gpuref/    the same renders made here (Mesa llvmpipe), for image parity
# All four are ignored by git (.git/info/exclude) and named in the device call's `carry`.
#   benchmarks/gpu/prepare.sh [--no-ref]
set -euo pipefail
cd "$(dirname "$0")/../.."
mkdir -p .git/info
for p in /.gl/ /.whl/ /.gpushared/ /.gpuref/; do grep -qx "$p" .git/info/exclude 2>/dev/null || echo "$p" >> .git/info/exclude; done
mkdir -p .gl /tmp/amd64/partial
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
apt-get $o update -qq
(cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
mkdir -p .whl
plat=""; for n in 2_17 2_24 2_27 2_28 2_31 2_34 2_35; do plat="$plat --platform manylinux_${n}_x86_64"; done
# (imagecodecs, 28 MB, is left out to stay under 64 MiB: only .hdr decoding needs it)
# the renderer's packages that the GPU image (numpy, scipy, scikit-image, pillow, matplotlib, rich,
# pytest, hypothesis, pyyaml, imageio) lacks, at the versions installed here; not the viewer's imgui
pkgs=""
for p in moderngl glcontext pyglm trimesh embreex xatlas openexr pydantic pydantic_core typing-inspection \
         annotated-types fast-simplification materialx adjusttext; do
    v=$(python3 -m pip show "$p" 2>/dev/null | awk '/^Version:/{print $2}')
    pkgs="$pkgs $p${v:+==$v}"
done
# shellcheck disable=SC2086
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
    --platform manylinux2014_x86_64 --platform manylinux1_x86_64 $plat -d .whl $pkgs
# pytest-xdist (pure Python, not a dependency here): the suite runs in 8 workers on the GPU machine's cores
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp -d .whl \
    "pytest-xdist>=3.5" "execnet>=2.1"
rm -rf .gpushared && cp -r "${SKINVIEWER_SHARED:-../shared}" .gpushared && chmod -R u+w .gpushared
rm -rf .gpushared/seeds
if [ "${1:-}" != "--no-ref" ]; then
    SKINVIEWER_SHARED=$PWD/.gpushared python3 benchmarks/gpu/gpu_check.py renders --out .gpuref --size 256
fi
du -sh .gl .whl .gpushared .gpuref 2>/dev/null
