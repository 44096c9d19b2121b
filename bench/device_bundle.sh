#!/usr/bin/env bash
# Prepares a GPU machine's run of bench/device_check.sh when that machine cannot build the tree
# (no Vulkan headers, glslang or brotli there, and no package registry): builds here (Release,
# tests and benchmarks, no viewer, no OpenVDB) into build-device and copies what the check runs
# into .devkit/, laid out as a build folder (samples/, tests/, bench/) plus lib/ (the shared
# libraries the binaries need beyond glibc and libstdc++) and nfc/ (bench/out/keep's files).
# On the GPU machine, from the repository root:
#   LD_LIBRARY_PATH=$PWD/.devkit/lib bench/device_check.sh .devkit
# The C++ tests find the golden vectors by this checkout's absolute path (NFD_TEST_VECTORS_DIR), so
# that path must lead to the copy there (a symbolic link).
set -euo pipefail
cd "$(dirname "$0")/.."
# Without OpenVDB: its libraries (~60 MB) would not fit the 64 MiB that a device run carries.
cmake -S . -B build-device -G Ninja -DCMAKE_BUILD_TYPE=Release -DNFD_BUILD_TESTS=ON \
  -DNFD_BUILD_BENCH=ON -DNFD_BUILD_VIEWER=OFF -DNFD_WITH_OPENVDB=OFF > /dev/null
cmake --build build-device -j"$(nproc)" > /dev/null
rm -rf .devkit
mkdir -p .devkit/samples .devkit/tests .devkit/bench .devkit/lib .devkit/nfc
cp build-device/samples/nfc-decode .devkit/samples/
cp build-device/tests/nfdecode_tests build-device/tests/nfdecode_queue_tests .devkit/tests/
cp build-device/bench/field_eval build-device/bench/queue_frame .devkit/bench/
for binary in .devkit/samples/* .devkit/tests/* .devkit/bench/*; do
  ldd "$binary" | awk '$3 ~ /^\// {print $3}'
done | sort -u | grep -Ev '/(libc|libm|libstdc\+\+|libgcc_s|ld-linux[^/]*)\.so' |
  xargs -r cp -L -t .devkit/lib
strip .devkit/samples/* .devkit/tests/* .devkit/bench/*
cp bench/out/keep/*.nfc .devkit/nfc/ 2>/dev/null || true
echo "$(git rev-parse --short HEAD)$(git diff --quiet || echo +changes)" > .devkit/COMMIT
du -sh .devkit
