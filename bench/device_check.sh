#!/usr/bin/env bash
# GPU machine check of the decoder (issue 11, item 5), one short run that also works on lavapipe:
#   1. builds the tree (Release, tests and benchmarks, no viewer) into BUILD_DIR;
#   2. the Vulkan tests: every golden vector, SDF and UDF, against the C++ twin, with the field
#      kernel the device picks and with the shared-memory (GPU) shape forced;
#   3. field evaluation throughput per width (bench/field_eval.cpp, C++ and Vulkan);
#   4. decode times on the Vulkan device and the C++ path (nfc-decode --stats), as a table.
# Usage: bench/device_check.sh [BUILD_DIR]   (default build-device)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-device}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DNFD_BUILD_TESTS=ON \
  -DNFD_BUILD_BENCH=ON -DNFD_BUILD_VIEWER=OFF > /dev/null
cmake --build "$build" -j"$(nproc)" > /dev/null
decode="$build/samples/nfc-decode"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "== device (what the default picks, and why)"
"$decode" tests/vectors/v1_0_bunny_sdf_w16.nfc -o "$out/m.ply" --resolution 32 --stats 2>&1 | grep '^device'
echo "== Vulkan tests against the C++ twin"
NFD_REQUIRE_VULKAN=1 "$build/tests/nfdecode_tests" --gtest_brief=1 \
  --gtest_filter='Gpu.*:Devices/*:Record.*:GpuFaults.*'
echo "== field evaluation"
"$build/bench/field_eval" --points 1048576 --repeat 3 --vulkan tests/vectors/v1_0_*.nfc
echo "== decode: bytes to mesh"
echo "| file | res | device | field ms | mesh ms | process s |"
echo "|---|---:|---|---:|---:|---:|"
for f in tests/vectors/v1_0_bunny_sdf_w32.nfc tests/vectors/v1_0_tshirt_udf_w16.nfc; do
  for r in 256 512; do
    for device in vulkan cpu; do
      "$decode" "$f" -o "$out/m.ply" --resolution "$r" --device "$device" > /dev/null  # warm-up
      start=$(date +%s.%N)
      stats=$("$decode" "$f" -o "$out/m.ply" --resolution "$r" --device "$device" --stats 2>&1)
      end=$(date +%s.%N)
      field=$(awk '$1 == "field" {print $2}' <<< "$stats")
      mesh=$(awk '$1 == "mesh" {print $2}' <<< "$stats")
      printf "| %s | %s | %s | %s | %s | %s |\n" "$(basename "$f")" "$r" "$device" "$field" \
        "$mesh" "$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.3f", b - a }')"
    done
  done
done
