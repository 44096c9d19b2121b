#!/usr/bin/env bash
# The queue tests under ThreadSanitizer and AddressSanitizer (leaks included: cancel and destroy
# must free everything). CPU path only: Vulkan is off in these builds, as the driver (lavapipe)
# is not instrumented and would report its own threads. Builds build-tsan/ and build-asan/
# (incremental), then runs the Queue* tests in each.
#     scripts/sanitize.sh [tsan|asan]...   (default: both)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=${NFD_SANITIZE_JOBS:-2}
kinds=("$@")
[ ${#kinds[@]} -eq 0 ] && kinds=(tsan asan)
status=0
for kind in "${kinds[@]}"; do
  case $kind in
    tsan) flags="-fsanitize=thread" ;;
    asan) flags="-fsanitize=address -fno-omit-frame-pointer" ;;
    *) echo "unknown sanitizer $kind (tsan, asan)" >&2; exit 2 ;;
  esac
  dir=build-$kind
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS=$flags" "-DCMAKE_C_FLAGS=$flags" \
    "-DCMAKE_EXE_LINKER_FLAGS=$flags" \
    -DNFD_WITH_VULKAN=OFF -DNFD_WITH_OPENVDB=OFF -DNFD_BUILD_SAMPLES=OFF -DNFD_BUILD_TESTS=ON >/dev/null
  cmake --build "$dir" -j"$jobs" --target nfdecode_tests
  echo "== $kind: Queue tests"
  TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
  ASAN_OPTIONS="detect_leaks=1:halt_on_error=1" \
    "$dir/tests/nfdecode_tests" --gtest_filter='Queue*:-*Vulkan' || status=1  # Vulkan is off here
done
exit $status
