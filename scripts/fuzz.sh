#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz/README.md: clang, ASan + UBSan, the parser's CRC checks
# off; line tables only, as scripts/sanitize.sh) into build-fuzz/ and runs each for SECONDS
# (default 30) from its committed corpus (tests/fuzz/corpus/<target>, read only; new inputs go to
# build-fuzz/corpus/<target>). Fails on any crash, abort, leak, timeout or sanitizer report, and
# prints the executions per target.
#     scripts/fuzz.sh [SECONDS [TARGET...]]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
[ $# -gt 0 ] && shift
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(fuzz_asset fuzz_decode fuzz_progressive fuzz_stream)
command -v clang++ >/dev/null || { echo "clang++ not found (Debian: clang libclang-rt-14-dev)" >&2; exit 1; }
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG" \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DNFD_BUILD_FUZZERS=ON \
  -DNFD_WITH_VULKAN=OFF -DNFD_BUILD_SAMPLES=OFF -DNFD_BUILD_TESTS=ON >/dev/null
cmake --build build-fuzz -j"${NFD_FUZZ_JOBS:-2}" --target "${targets[@]}"
status=0
for t in "${targets[@]}"; do
  work=build-fuzz/corpus/$t
  mkdir -p "$work"
  log=build-fuzz/$t.log
  echo "== $t: $seconds s"
  if ! "build-fuzz/tests/$t" "$work" "tests/fuzz/corpus/$t" -dict=tests/fuzz/nfc.dict \
       -max_total_time="$seconds" -timeout=60 -rss_limit_mb=2048 -print_final_stats=1 \
       -artifact_prefix=build-fuzz/ >"$log" 2>&1; then
    status=1
    grep -E "ERROR|SUMMARY|Test unit written" "$log" || tail -20 "$log"
  fi
  grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$log" || true
done
exit $status
