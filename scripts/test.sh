#!/usr/bin/env bash
# Runs every test: the C++ suite (CTest: parser, hostile input, CPU reference, Vulkan on lavapipe or a
# GPU, consumer project), the C++ suite under ASan + UBSan and the queue tests under TSan, each
# libFuzzer target for a bounded time (NFD_FUZZ_SECONDS, default 30), and the Python suite (pytest).
# Installs what it needs first.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
status=0
export NFD_REQUIRE_VULKAN=1  # lavapipe is installed: GPU tests must run, not skip
ctest --test-dir build --output-on-failure -j2 || status=1
scripts/sanitize.sh || status=1  # ASan + UBSan (the C++ suite), TSan (the queue tests)
scripts/fuzz.sh "${NFD_FUZZ_SECONDS:-30}" || status=1  # each libFuzzer target from its corpus
.venv/bin/python -m pytest tests/python -q || status=1
exit $status
