#!/usr/bin/env bash
# Builds clients/bevy (the Bevy 0.19.1 program that renders hdrflow's Bevy bake headless, for
# tests/bevy_render.rs) once, and prints the path of its binary. Bevy is its own crate with its own
# lock file, outside hdrflow's workspace, so a normal hdrflow build never compiles it.
#   BEVY_TARGET_DIR  target folder (default: clients/bevy/target); a build from scratch takes about
#                    20 minutes on 2 cores and some 4 GB of disk (docs/src/benchmarks/rendered.md, "Bevy, rendered for real").
# The renderer runs on Mesa's lavapipe (a CPU Vulkan driver): Debian `mesa-vulkan-drivers`.
# Run the test with: HDRFLOW_BEVY_RENDER=$(scripts/bevy-client.sh) cargo test --release --test bevy_render
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
target=${BEVY_TARGET_DIR:-$root/clients/bevy/target}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg-runtime-$(id -u)}
mkdir -p "$XDG_RUNTIME_DIR" && chmod 700 "$XDG_RUNTIME_DIR"
export WGPU_BACKEND=vulkan
if [ ! -e /usr/share/vulkan/icd.d/lvp_icd.x86_64.json ]; then
    echo "warning: no lavapipe ICD (apt-get install -y mesa-vulkan-drivers); the binary builds but cannot render" >&2
fi
# --locked: the committed clients/bevy/Cargo.lock, never a newer Bevy dependency.
# A failed build prints its messages with each line cut to 400 characters (the linker's command
# line alone is tens of kilobytes and would hide the reason printed after it), and the free disk
# space (a Bevy build needs some 4 GB; a full disk is the usual reason a link fails).
log=$(mktemp)
if ! cargo build --locked --quiet --manifest-path "$root/clients/bevy/Cargo.toml" --target-dir "$target" 2>"$log"; then
    cut -c1-400 "$log" >&2
    df -h "$target" >&2
    rm -f "$log"
    echo "error: the Bevy client did not build (messages above)" >&2
    exit 1
fi
cat "$log" >&2
rm -f "$log"
echo "$target/debug/hdrflow-bevy-render"
