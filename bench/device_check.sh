#!/usr/bin/env bash
# GPU machine check of the decoder (issues 6, 7, 11), one short run that also works on lavapipe:
#   1. builds the tree (Release, tests and benchmarks, no viewer) into BUILD_DIR, unless BUILD_DIR
#      is a prebuilt bundle (bench/device_bundle.sh: no build.ninja, the binaries in place);
#   2. the Vulkan tests: every golden vector, SDF and UDF, against the C++ twin, with the field
#      kernel the device picks and with the shared-memory (GPU) shape forced;
#   3. field evaluation throughput per width (bench/field_eval.cpp, C++ and Vulkan);
#   4. decode times on the Vulkan device and the C++ path (nfc-decode --stats), as a table, for the
#      golden vectors of width 32 / 16 and bench/out/keep's (or the bundle's nfc/) width-32 files,
#      with the Vulkan decode's buffers and the device allocations they took;
#   5. progressive levels streamed at 256 KB/s (bench/progressive.py: first level after the
#      geometry, the ladder's cost against the final level alone);
#   6. ten assets through the queue on the Vulkan device (bench/queue_frame.cpp);
#   7. bytes to mesh with the default device against the paper's dense PyTorch path
#      (bench/decode.py), where the Python there can import torch, skimage and nfencode.
# Usage: bench/device_check.sh [BUILD_DIR]   (default build-device)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build-device}
if [ -f "$build/build.ninja" ] || [ ! -x "$build/samples/nfc-decode" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DNFD_BUILD_TESTS=ON \
    -DNFD_BUILD_BENCH=ON -DNFD_BUILD_VIEWER=OFF > /dev/null
  cmake --build "$build" -j"$(nproc)" > /dev/null
fi
decode="$build/samples/nfc-decode"
keep=$(ls "$build"/nfc/*.nfc 2>/dev/null ||
  ls bench/out/keep/*_w32.nfc 2>/dev/null | head -4 || true)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "== device (what the default picks, and why)"
"$decode" tests/vectors/v1_0_bunny_sdf_w16.nfc -o "$out/m.ply" --resolution 32 --stats 2>&1 | grep '^device'
echo "== Vulkan tests against the C++ twin"
export NFD_REQUIRE_VULKAN=1
suites='Gpu.*:ColourGpu.*:Devices/*:Record.*:GpuFaults.*:Adopt.*:ProgressiveMemory.*'
"$build/tests/nfdecode_tests" --gtest_brief=1 --gtest_filter="$suites:PipelineCache.*" ||
  echo "** FAILED"
"$build/tests/nfdecode_queue_tests" --gtest_brief=1 --gtest_filter='*Vulkan*' || echo "** FAILED"
echo "== field evaluation"
"$build/bench/field_eval" --points 1048576 --repeat 3 --vulkan tests/vectors/v1_0_*.nfc
echo "== decode: bytes to mesh"
echo "| file | res | device | field ms | mesh ms | process s | buffers / allocations |"
echo "|---|---:|---|---:|---:|---:|---|"
# shellcheck disable=SC2086  # $keep: a list of paths without spaces
for f in tests/vectors/v1_0_bunny_sdf_w32.nfc tests/vectors/v1_0_tshirt_udf_w16.nfc $keep; do
  for r in 256 512; do
    for device in vulkan cpu; do
      "$decode" "$f" -o "$out/m.ply" --resolution "$r" --device "$device" > /dev/null  # warm-up
      start=$(date +%s.%N)
      stats=$("$decode" "$f" -o "$out/m.ply" --resolution "$r" --device "$device" --stats 2>&1)
      end=$(date +%s.%N)
      field=$(awk '$1 == "field" {print $2}' <<< "$stats")
      mesh=$(awk '$1 == "mesh" {print $2}' <<< "$stats")
      memory=$(awk '$1 == "device" && $2 == "mem" {print $3 " / " $6}' <<< "$stats")
      printf "| %s | %s | %s | %s | %s | %s | %s |\n" "$(basename "$f")" "$r" "$device" "$field" \
        "$mesh" "$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.3f", b - a }')" "${memory:-}"
    done
  done
done
py=$( [ -x .venv/bin/python ] && echo .venv/bin/python || echo python3 )
# bench/*.py run build/samples/nfc-decode: a bundle elsewhere stands in for a missing build/.
if [ "$build" != build ] && [ ! -e build ]; then ln -s "$build" build; fi
echo "== progressive levels at 256 KB/s"
# shellcheck disable=SC2086
"$py" bench/progressive.py $keep tests/vectors/v1_0_tshirt_udf_w16.nfc --runs 3 \
  --bandwidth 256KB/s --devices vulkan cpu || echo "** progressive.py failed"
echo "== ten assets through the queue (Vulkan, 256 KB/s each, levels 32..256)"
# shellcheck disable=SC2086
"$build/bench/queue_frame" --device vulkan --levels 32,64,128,256 \
  $(ls tests/vectors/v1_*.nfc $keep | head -10) || echo "** queue_frame failed"
echo "== bytes to mesh, default device, against the paper's dense path"
export PYTHONPATH="encoder_py${PYTHONPATH:+:$PYTHONPATH}"
if "$py" -c "import torch, skimage, brotli" 2>/dev/null; then
  # shellcheck disable=SC2086
  "$py" bench/decode.py \
    $(ls $keep tests/vectors/v1_0_bunny_sdf_w32.nfc | head -1) --resolutions 256 512 --device auto \
    --no-reference --repeats 3 || echo "** decode.py failed"
else
  echo "(skipped: no torch, skimage or brotli for $py)"
fi
