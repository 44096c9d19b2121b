#!/usr/bin/env bash
# The main job end to end: encode a shape to .nfc with the Python encoder, decode it with
# libnfdecode (Vulkan; lavapipe where there is no GPU) to a .glb, and report bytes and quality.
#   scripts/demo.sh                      # built-in demo shape (bumpy torus), no external data
#   scripts/demo.sh path/to/shape.ply    # any PLY/OBJ/OFF/glTF mesh or point cloud (.gz too)
#   WIDTH=16 FIELD=sdf scripts/demo.sh ../shared/data/stanford/bun_zipper.ply.gz
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh >/dev/null
out=out/demo
mkdir -p "$out"
input=${1:-}
if [ -z "$input" ]; then
  input=$out/demo_shape.ply
  .venv/bin/python -m nfencode.shapes "$input"
fi
.venv/bin/nfc encode "$input" -o "$out/shape.nfc" --width "${WIDTH:-32}" --field "${FIELD:-auto}"
.venv/bin/nfc info "$out/shape.nfc"
build/samples/nfc-decode "$out/shape.nfc" -o "$out/shape.glb" --resolution "${RESOLUTION:-256}" --stats
.venv/bin/nfc eval "$input" "$out/shape.glb"
echo "wrote $out/shape.nfc ($(stat -c %s "$out/shape.nfc") bytes) and $out/shape.glb"
