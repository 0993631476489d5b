#!/usr/bin/env bash
# hdrflow's ProbeSphere against the protocol's Blender renders of the same maps, with Blender's own
# noise measured from a second seed:
#
#   bench/peers/probe_vs_blender.sh PROTOCOL_DIR OUT_DIR PERCENT SAMPLES MAP...
#
# For each MAP (anything LoadHdr reads; converted to OpenEXR first, as the protocol's scripts only
# read .exr), renders the three spheres with Blender (bench/peers/blender_probe.sh, seeds 0 and 1)
# and with hdrflow (ProbeSphere at the same size, default fields), then prints, per map and
# material, bench/peers/compare_probe.py's lines for Blender seed 0 against seed 1 (the noise), for
# hdrflow against seed 0, and for hdrflow against the two seeds' mean (the ratio to their noise).
# HDRFLOW (default target/release/hdrflow) and BLENDER name the binaries.
set -euo pipefail
if [ $# -lt 5 ]; then
    sed -n '2,12p' "$0"
    exit 2
fi
protocol=$1
out=$2
percent=$3
samples=$4
shift 4
here=$(cd "$(dirname "$0")" && pwd)
hdrflow=${HDRFLOW:-$here/../../target/release/hdrflow}
blender=${BLENDER:-blender}
width=$((1920 * percent / 100))
height=$((1080 * percent / 100))
mkdir -p "$out/maps"
for map in "$@"; do
    name=$(basename "$map")
    name=${name%.*}
    name=${name%%-*}
    exr="$out/maps/$name.exr"
    if [[ "$map" == *.exr ]]; then
        cp "$map" "$exr"
    else
        printf '(nodes: {"m": LoadHdr(path: "%s"), "s": Save(input: "m", path: "%s.exr")})\n' "$(realpath "$map")" "$name" >"$out/convert.ron"
        "$hdrflow" run "$out/convert.ron" --out "$out/maps" --no-cache >/dev/null
    fi
    for seed in 0 1; do
        echo "blender seed $seed, $name:"
        "$here/blender_probe.sh" "$protocol" "$exr" "$out/blender-$seed" "$percent" "$samples" "$seed"
    done
    cat >"$out/hdrflow-$name.ron" <<EOF
(nodes: {
    "env": LoadHdr(path: "$(realpath "$exr")"),
    "mirror": ProbeSphere(env: "env", material: Mirror, width: $width, height: $height),
    "matte_silver": ProbeSphere(env: "env", material: MatteSilver, width: $width, height: $height),
    "diffuse": ProbeSphere(env: "env", material: Diffuse, width: $width, height: $height),
    "s1": Save(input: "mirror", path: "mirror/$name.exr"),
    "s2": Save(input: "matte_silver", path: "matte_silver/$name.exr"),
    "s3": Save(input: "diffuse", path: "diffuse/$name.exr"),
})
EOF
    start=$(date +%s.%N)
    "$hdrflow" run "$out/hdrflow-$name.ron" --out "$out/hdrflow" --no-cache >/dev/null
    end=$(date +%s.%N)
    printf 'hdrflow, %s: %.2f s for the three spheres\n' "$name" "$(echo "$end - $start" | bc)"
    for material in mirror matte_silver diffuse; do
        "$blender" --background --factory-startup --python "$here/compare_probe.py" -- \
            "$out/hdrflow/$material/$name.exr" "$out/blender-0/$material/$name.exr" \
            "$out/blender-1/$material/$name.exr" "$name $material ratio" 2>/dev/null | grep ratio || true
        for pair in "blender-1 blender-0 noise" "hdrflow blender-0 hdrflow"; do
            set -- $pair
            "$blender" --background --factory-startup --python "$here/compare_probe.py" -- \
                "$out/$1/$material/$name.exr" "$out/$2/$material/$name.exr" "$name $material $3" 2>/dev/null \
                | grep -v '^Blender\|^Read\|^$' || true
        done
    done
done
