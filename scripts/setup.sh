#!/usr/bin/env bash
# Installs everything nfc needs on a fresh Debian 12 machine and builds it. Idempotent: a second
# run only re-checks. Used by the README's two commands (demo.sh, test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(
  build-essential cmake ninja-build pkg-config python3 python3-venv
  libvulkan-dev mesa-vulkan-drivers vulkan-tools glslang-tools spirv-tools
  libbrotli-dev libtinygltf-dev nlohmann-json3-dev libglm-dev libglfw3-dev libgtest-dev
  libopenvdb-dev libboost-iostreams-dev libopenvdb-tools
  draco
  libimgui-dev libstb-dev xvfb xauth
  clang libclang-rt-14-dev
)
missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "[setup] apt-get install ${missing[*]}"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q "${missing[@]}"
fi

# Python >= 3.10 venv with the encoder (torch, numpy, scipy, brotli, ...) installed editable.
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "[setup] creating .venv"
  "$PY" -m venv .venv
fi
if ! .venv/bin/python -c "import nfencode, pytest, matplotlib, fast_simplification, ray" 2>/dev/null; then
  echo "[setup] pip install ./encoder_py[test,bench,batch]"
  .venv/bin/pip install -q --upgrade pip
  .venv/bin/pip install -q -e "./encoder_py[test,bench,batch]"
fi

# The C++ decoder, samples and tests.
if [ ! -f build/build.ninja ]; then
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DNFD_BUILD_TESTS=ON -DNFD_BUILD_SAMPLES=ON
fi
cmake --build build -j"$(nproc)"
