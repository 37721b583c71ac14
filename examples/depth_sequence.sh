#!/usr/bin/env bash
# Renders CBspheres.dae at -m 0, 1, 2, 3, 4, 5 and 100 with -s 64 -l 4 and writes the contact
# sheet docs/depth_sequence.png (the renders go to target/depth_sequence/, the sheet is copied).
# Usage: examples/depth_sequence.sh [path/to/CBspheres.dae]
set -euo pipefail
cd "$(dirname "$0")/.."
scene="${1:-../shared/scenes/cs184/sky/CBspheres.dae}"
cargo build --release --quiet
./target/release/pathtracer sequence -s 64 -l 4 --depths 0,1,2,3,4,5,100 \
    -f target/depth_sequence/depth_sequence.png "$scene"
cp target/depth_sequence/depth_sequence.png docs/depth_sequence.png
echo "contact sheet: docs/depth_sequence.png"
