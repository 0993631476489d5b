#!/usr/bin/env bash
# Makes the "Bevy, rendered" pictures (docs/src/figures/bevy/{test_map,park}_{bevy,exact,difference}.png):
# runs the sphere tests of tests/bevy_render.rs with HDRFLOW_BEVY_PICTURES (they write each Bevy frame
# and its exact reference as EXR), then docs/src/figures/bevy/picture.ron on each map: the frame and the
# reference as PNG with the reference's exposure, and hdrflow's Difference heat map of the two.
#   BEVY_TARGET_DIR  as for scripts/bevy-client.sh (the client is built, or rebuilt, first)
# The test prints the tables of errors (the numbers of docs/src/guides/baking/bevy.md and docs/src/benchmarks/rendered.md) on the way.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
client=$(bash scripts/bevy-client.sh)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
HDRFLOW_BEVY_PICTURES=$tmp HDRFLOW_BEVY_RENDER=$client HDRFLOW_REQUIRE_BEVY=1 \
    cargo test --release --test bevy_render -- --nocapture bevy_shows_the_test_map bevy_shows_the_park_map
for map in test_map park; do
    cargo run --release --quiet -- run docs/src/figures/bevy/picture.ron --out docs/src/figures/bevy --no-cache --quiet \
        --set "bevy.path=$tmp/${map}_bevy.exr" --set "exact.path=$tmp/${map}_exact.exr" \
        --set "save_bevy.path=${map}_bevy.png" --set "save_exact.path=${map}_exact.png" \
        --set "save_diff.path=${map}_difference.png"
done
ls -l docs/src/figures/bevy/*.png
