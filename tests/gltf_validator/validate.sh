#!/usr/bin/env bash
# CTest gltf_validator: decodes every SDF golden vector and every colour vector (COLOR_0) with
# nfc-decode (auto = Vulkan where a device exists, and CPU) to .glb and runs the Khronos glTF
# validator on the results. Exit 77 (skipped) when Node.js/npm is missing.
# Usage: validate.sh NFC_DECODE VECTORS_DIR WORK_DIR
set -euo pipefail
decoder=$1 vectors=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
command -v node >/dev/null && command -v npm >/dev/null || { echo "node/npm not found: skipped"; exit 77; }
mkdir -p "$work"
if [ ! -d "$work/node_modules/gltf-validator" ]; then
  cp "$here/package.json" "$work/"
  (cd "$work" && npm install --silent --no-audit --no-fund >/dev/null) ||
    { echo "npm install gltf-validator failed: skipped"; exit 77; }
fi
files=()
shopt -s nullglob
for nfc in "$vectors"/v1_0_*_sdf_*.nfc "$vectors"/v1_1_*.nfc; do
  for device in auto cpu; do  # auto = Vulkan where a device exists
    out="$work/$(basename "${nfc%.nfc}")_$device.glb"
    "$decoder" "$nfc" -o "$out" --resolution 96 --device "$device"
    files+=("$out")
  done
done
NODE_PATH="$work/node_modules" node "$here/validate.js" "${files[@]}"
