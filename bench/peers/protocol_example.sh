#!/usr/bin/env bash
# The evaluation protocol's own example (DiffusionLight-evaluation's example/: a predicted map,
# hdr/stylelight/abandoned_bakery_4k.exr, and the published Blender renders of its ground truth,
# ground_truth/stylelight/{mirror,matte_silver,diffuse}/) scored by hdrflow and by Blender:
#
#   bench/peers/protocol_example.sh PROTOCOL_DIR OUT_DIR [SAMPLES...]
#
# hdrflow prepares the prediction as the protocol does (Resize 256 x 128, ProtocolTonemap), renders
# the three spheres with ProbeSphere at 960 x 540 and scores them against the published renders with
# ImageMetrics (fast_rmse.py's four metrics). Blender renders the same prepared map with the
# protocol's scene (bench/peers/blender_protocol_scene.py, 50%, seeds 0 and 1, without the denoiser
# Debian's build lacks) at each of SAMPLES (default: 5, the protocol's, and 64), and ImageMetrics
# scores those renders the same way. Prints one line per renderer and sphere with the four metrics
# and the wall time. HDRFLOW (default target/release/hdrflow) and BLENDER name the binaries.
set -euo pipefail
if [ $# -lt 2 ]; then
    sed -n '2,14p' "$0"
    exit 2
fi
protocol=$(realpath "$1")
out=$(realpath -m "$2")
shift 2
if [ $# -eq 0 ]; then samples=(5 64); else samples=("$@"); fi
here=$(cd "$(dirname "$0")" && pwd)
hdrflow=${HDRFLOW:-$here/../../target/release/hdrflow}
blender=${BLENDER:-blender}
pred=$protocol/example/hdr/stylelight/abandoned_bakery_4k.exr
gt=$protocol/example/ground_truth/stylelight
[ -f "$pred" ] || { echo "$pred: not a DiffusionLight-evaluation checkout" >&2; exit 1; }
# The paths go into RON strings as they are.
case "$protocol$out" in *'"'* | *'\'*) echo "paths with \" or \\ are not supported" >&2; exit 1 ;; esac
mkdir -p "$out"

# hdrflow: the prepared map (saved for Blender), the spheres and their scores.
{
    echo '(nodes: {'
    echo "\"pred\": LoadHdr(path: \"$pred\"),"
    echo '"small": Resize(image: "pred", width: 256, height: 128),'
    echo '"toned": ProtocolTonemap(image: "small"),'
    echo '"save_map": Save(input: "toned", path: "toned.exr"),'
    for m in mirror:Mirror matte_silver:MatteSilver diffuse:Diffuse; do
        file=${m%%:*}
        echo "\"gt_$file\": LoadHdr(path: \"$gt/$file/abandoned_bakery_4k.exr\"),"
        echo "\"$file\": ProbeSphere(env: \"toned\", material: ${m##*:}),"
        echo "\"m_$file\": ImageMetrics(pred: \"$file\", gt: \"gt_$file\"),"
        echo "\"s_$file\": Save(input: \"m_$file\", path: \"hdrflow_$file.json\"),"
    done
    echo '})'
} >"$out/hdrflow.ron"
start=$EPOCHREALTIME
"$hdrflow" run "$out/hdrflow.ron" --out "$out" --no-cache -q
python3 -c 'import sys; print("hdrflow: %.1f s for the map and three spheres" % (float(sys.argv[2]) - float(sys.argv[1])))' \
    "$start" "$EPOCHREALTIME"

# Blender at each sample count, then the same scores of its renders.
{
    echo '(nodes: {'
    for file in mirror matte_silver diffuse; do
        echo "\"gt_$file\": LoadHdr(path: \"$gt/$file/abandoned_bakery_4k.exr\"),"
    done
    for s in "${samples[@]}"; do
        if ! "$blender" --background --factory-startup --python-exit-code 1 \
            --python "$here/blender_protocol_scene.py" -- \
            "$out/toned.exr" "$out/blender-$s" 50 "$s" 0,1 mirror,matte_silver,diffuse >"$out/blender-$s.log" 2>&1; then
            echo "blender failed at $s samples:" >&2
            tail -n 30 "$out/blender-$s.log" >&2
            exit 1
        fi
        grep '^blender_protocol_scene:' "$out/blender-$s.log" | sed "s/^blender_protocol_scene:/blender $s samples:/" >&2
        for seed in 0 1; do
            for file in mirror matte_silver diffuse; do
                k="${s}_${seed}_$file"
                echo "\"r_$k\": LoadHdr(path: \"$out/blender-$s/seed$seed/$file.exr\"),"
                echo "\"m_$k\": ImageMetrics(pred: \"r_$k\", gt: \"gt_$file\"),"
                echo "\"s_$k\": Save(input: \"m_$k\", path: \"blender_${s}_seed${seed}_$file.json\"),"
            done
        done
    done
    echo '})'
} >"$out/blender.ron"
"$hdrflow" run "$out/blender.ron" --out "$out" --no-cache -q

for f in "$out"/hdrflow_*.json "$out"/blender_*.json; do
    python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); print("%-36s" % sys.argv[1].rsplit("/", 1)[1], " ".join("%s %.4f" % (k, d[k]) for k in ("rmse", "si_rmse", "angular_error_deg", "norm_rmse")))' "$f"
done
