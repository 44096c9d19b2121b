#!/usr/bin/env bash
# The queue tests under ThreadSanitizer, and the whole C++ suite under AddressSanitizer with
# UndefinedBehaviorSanitizer (leaks included: cancel and destroy must free everything; any UB
# report fails). CPU path only: Vulkan is off in these builds, as the driver (lavapipe) is not
# instrumented and would report its own threads; Vulkan tests skip here even when test.sh
# requires Vulkan (NFD_REQUIRE_VULKAN) for the main suite. Builds build-tsan/ and build-asan/
# (incremental; -g1: line tables are all a report needs, and the build is the longer part of a
# run), then runs the tests in each.
#     scripts/sanitize.sh [tsan|asan]...   (default: both)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${NFD_SANITIZE_JOBS:-2}
kinds=("$@")
[ ${#kinds[@]} -eq 0 ] && kinds=(tsan asan)
status=0
for kind in "${kinds[@]}"; do
  case $kind in
    tsan) flags="-fsanitize=thread"
          runs=("nfdecode_queue_tests:*:-*Vulkan") ;;  # Vulkan is off here
    # All but the longest tests, which repeat big decodes of paths the others cover (each 0.5-8
    # min here, 13 min together; they run in the Release CTest): CRC-consistent damage through
    # every progressive level (ExtractUdf.*, Colour.* and the parser's damage tests do run), every
    # stream split of every file at resolution 64 (the prefix and flip tests do run), the band
    # at 256, the progressive memory bounds and the progressive suite's full ladders.
    asan) flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
          runs=("nfdecode_tests:*:-ProgressiveCpu.AcceptedDamageGivesFiniteLevelsOrErrors:Stream.AnySplitGivesTheOneShotMesh:GridVoxels.*:ProgressiveMemory.*:Devices/Progressive.*"
                "nfdecode_queue_tests:*") ;;
    *) echo "unknown sanitizer $kind (tsan, asan)" >&2; exit 2 ;;
  esac
  dir=build-$kind
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS=$flags" "-DCMAKE_C_FLAGS=$flags" \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" \
    "-DCMAKE_EXE_LINKER_FLAGS=$flags" \
    -DNFD_WITH_VULKAN=OFF -DNFD_WITH_OPENVDB=OFF -DNFD_BUILD_SAMPLES=OFF -DNFD_BUILD_TESTS=ON >/dev/null
  targets=()
  for run in "${runs[@]}"; do targets+=("${run%%:*}"); done
  cmake --build "$dir" -j"$jobs" --target "${targets[@]}"
  for run in "${runs[@]}"; do
    exe=${run%%:*} filter=${run#*:}
    echo "== $kind: $exe --gtest_filter=$filter"
    TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
    ASAN_OPTIONS="detect_leaks=1:halt_on_error=1" UBSAN_OPTIONS="print_stacktrace=1" \
    NFD_REQUIRE_VULKAN=0 \
      "$dir/tests/$exe" --gtest_filter="$filter" --gtest_brief=1 || status=1
  done
done
exit $status
