#!/usr/bin/env bash
# Source-based coverage (clang -fprofile-instr-generate -fcoverage-mapping) of what the fuzz
# corpora reach: builds the fuzz targets once more into build-cov/ (as scripts/fuzz.sh does, plus
# the coverage flags), runs each over its committed corpus and what scripts/fuzz.sh found
# (build-fuzz/corpus/<target>), and prints llvm-cov's line, region and branch coverage of the
# parser and stream reader (bitstream.cpp, stream.cpp) and of the whole library.
#     scripts/fuzz_coverage.sh
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang++ >/dev/null || { echo "clang++ not found (Debian: clang libclang-rt-14-dev)" >&2; exit 1; }
profdata=$(command -v llvm-profdata || command -v llvm-profdata-14)
cov=$(command -v llvm-cov || command -v llvm-cov-14)
flags="-fprofile-instr-generate -fcoverage-mapping"
cmake -S . -B build-cov -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DNFD_BUILD_FUZZERS=ON \
  -DNFD_WITH_VULKAN=OFF -DNFD_BUILD_SAMPLES=OFF -DNFD_BUILD_TESTS=ON \
  -DCMAKE_C_FLAGS="$flags" -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" >/dev/null
targets=(fuzz_asset fuzz_decode fuzz_progressive fuzz_stream)
cmake --build build-cov -j"${NFD_FUZZ_JOBS:-2}" --target "${targets[@]}"
rm -rf build-cov/profiles && mkdir -p build-cov/profiles
for t in "${targets[@]}"; do
  dirs=("tests/fuzz/corpus/$t")
  [ -d "build-fuzz/corpus/$t" ] && dirs+=("build-fuzz/corpus/$t")
  inputs=$(find "${dirs[@]}" -type f | wc -l)
  echo "== $t: $inputs inputs"
  LLVM_PROFILE_FILE="build-cov/profiles/$t.%p.profraw" "build-cov/tests/$t" -runs=0 \
    -rss_limit_mb=2048 -timeout=60 "${dirs[@]}" >"build-cov/$t.log" 2>&1
done
"$profdata" merge -sparse build-cov/profiles/*.profraw -o build-cov/fuzz.profdata
objects=("build-cov/tests/${targets[0]}")
for t in "${targets[@]:1}"; do objects+=(-object "build-cov/tests/$t"); done
echo "== parser and stream reader"
"$cov" report "${objects[@]}" -instr-profile=build-cov/fuzz.profdata \
  libnfdecode/src/bitstream.cpp libnfdecode/src/stream.cpp
echo "== libnfdecode (all sources)"
"$cov" report "${objects[@]}" -instr-profile=build-cov/fuzz.profdata libnfdecode/src | tail -1
