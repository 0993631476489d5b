#!/usr/bin/env bash
# The lighting-estimation protocol's three spheres of one map, rendered by Blender (the peer of
# hdrflow's ProbeSphere), with the protocol's own scripts (bench/peers/blender_probe_setup.py says
# what it changes for a CPU build without the denoiser).
#
#   bench/peers/blender_probe.sh PROTOCOL_DIR MAP.exr OUT_DIR [PERCENT] [SAMPLES] [SEED]
#
# PROTOCOL_DIR: a checkout of DiffusionLight/DiffusionLight-evaluation (its stylelight/ is used).
# Defaults: PERCENT 50 (960 x 540, the published renders), SAMPLES 5 (job_distributor.py's), SEED 0.
# Writes OUT_DIR/{mirror,matte_silver,diffuse}/<map name up to its first '-'>.exr and prints each
# render's wall time. Needs Debian's `blender` (3.4.1) and `python3-numpy` (the protocol's utils
# import numpy).
set -euo pipefail
if [ $# -lt 3 ]; then
    sed -n '2,12p' "$0"
    exit 2
fi
protocol=$1
map=$2
out=$3
percent=${4:-50}
samples=${5:-5}
seed=${6:-0}
here=$(cd "$(dirname "$0")" && pwd)
blender=${BLENDER:-blender}
command -v "$blender" >/dev/null || { echo "blender not found (apt-get install blender python3-numpy)" >&2; exit 1; }
[ -d "$protocol/stylelight/utils" ] || { echo "$protocol/stylelight/utils: not a DiffusionLight-evaluation checkout" >&2; exit 1; }
mkdir -p "$out"
for material in mirror matte_silver diffuse; do
    start=$(date +%s.%N)
    "$blender" --background --factory-startup --python-exit-code 1 --python "$here/blender_probe_setup.py" -- \
        "$protocol/stylelight" "$material" "$percent" "$samples" "$map" "$out" "$seed" >"$out/$material.log" 2>&1 \
        || { echo "$material: blender failed, see $out/$material.log" >&2; exit 1; }
    end=$(date +%s.%N)
    printf '%s\t%.2f s\n' "$material" "$(echo "$end - $start" | bc)"
done
