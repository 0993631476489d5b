#!/usr/bin/env bash
# The whole sphere evaluation of examples/evaluation/ against the Blender protocol on the same
# prepared maps, in one run, in CPU seconds (user + system; the machine is shared, so wall times
# say less):
#
#   bench/peers/evaluation_speed.sh OUT_DIR [PERCENT [SAMPLES [CHECKPOINT]]]
#
# PERCENT (default 50, the published renders' 960 x 540) and SAMPLES (default 5, what the
# protocol's job_distributor.py passes) are Blender's (evaluate.ron renders 960 x 540 whatever
# they are: other values compare different work, and the script says so); CHECKPOINT (default
# turned) names the predictions of examples/evaluation/predictions/. OUT_DIR must be new or empty.
# Run from the repository's root after `cargo build --release`. Prints:
# - Blender: the protocol's scene (bench/peers/blender_protocol_scene.py: CPU, no denoiser, one
#   process per map for its three spheres, as the protocol runs a script per material over a
#   folder) on the three truths and three predictions, prepared as the protocol prepares them
#   (256 x 128, its tonemap, saved as OpenEXR);
# - hdrflow: `hdrflow batch examples/evaluation/evaluate.ron` over the same pairs from their
#   .hdr files (resize, tonemap, the 18 spheres, the metrics and the saved files included), with
#   an empty cache; and over the first pair alone, so that (all - first) / 2 is what each further
#   pair costs once the frames' plans are made (a batch over a test set pays the plans once); and
#   the other checkpoint's predictions with that cache (the truths' spheres read back, as at every
#   checkpoint after the first), against Blender's 9 prediction spheres;
# - the ratios;
# - with PROTOCOL_DIR set to a DiffusionLight-evaluation checkout, also Blender running the
#   protocol's own stylelight/{mirror,matte_silver,diffuse}.py on the same six prepared maps, one
#   process a material over the folder as its job_distributor.py runs them (copies of the scripts
#   with utils/utils.py's defaults set to the CPU and no denoiser, which Debian's build lacks;
#   nothing of the checkout is changed), and that ratio.
# HDRFLOW (default target/release/hdrflow) and BLENDER name the binaries. REPEATS (default 1) runs
# every measurement that many times, in rounds (Blender's scene, the protocol's scripts, then the
# three batches), and reports each one's median: this machine's CPU times swing by 20% within an
# hour, the differenced further pair most.
set -euo pipefail
export LC_ALL=C # `times` prints its seconds with this locale's decimal point
if [ $# -lt 1 ]; then
    sed -n '2,32p' "$0"
    exit 2
fi
repeats=${REPEATS:-1}
case $repeats in
'' | *[!0-9]* | 0) echo "REPEATS=$repeats: give a whole number of runs, at least 1" >&2; exit 2 ;;
esac
# The median of the numbers given (the mean of the middle two for an even count).
median() {
    printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END { printf "%.2f", NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'
}
out=$(realpath -m "$1") # absolute: the protocol's scripts run from their own folder
percent=${2:-50}
samples=${3:-5}
checkpoint=${4:-turned}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
hdrflow=${HDRFLOW:-$root/target/release/hdrflow}
blender=${BLENDER:-blender}
if [ -e "$out" ] && [ -n "$(ls -A "$out")" ]; then
    echo "$out is not empty: give a new folder" >&2
    exit 2
fi
if [ "$percent" != 50 ]; then
    echo "note: Blender renders ${percent}% while evaluate.ron renders 960 x 540 (50%)" >&2
fi
mkdir -p "$out/prepared"
# CPU seconds of the children waited for between two `times` snapshots (bash's builtin, written
# to a file from this shell itself: a subshell would report its own). No /usr/bin/time needed.
cpu_between() {
    awk 'function s(t,  m) { split(t, m, "m"); sub("s", "", m[2]); return m[1] * 60 + m[2] }
         FNR == 2 { c[++n] = s($1) + s($2) } END { printf "%.2f", c[2] - c[1] }' "$1" "$2"
}

# The six maps as the protocol prepares them, for Blender (not timed).
cat >"$out/prepare.ron" <<'EOF'
(nodes: {
    "map": LoadHdr(path: "x.hdr"),
    "small": Resize(image: "map", width: 256, height: 128),
    "toned": ProtocolTonemap(image: "small"),
    "save": Save(input: "toned", path: "prepared.exr"),
})
EOF
maps=()
for gt in "$root"/assets/maps/*.hdr; do
    name=$(basename "$gt" .hdr)
    pred="$root/examples/evaluation/predictions/$checkpoint/$name.hdr"
    for kind in gt pred; do
        src=$gt
        [ "$kind" = pred ] && src=$pred
        "$hdrflow" run "$out/prepare.ron" --set "map.path=\"$src\"" --out "$out/prepared/$kind-$name" \
            --no-cache -q
        maps+=("$out/prepared/$kind-$name/prepared.exr")
    done
done

# Blender: one process per map, its three spheres.
blender_scene() {
    for map in "${maps[@]}"; do
        dir=$(dirname "$map")
        "$blender" --background --factory-startup \
            --python-exit-code 1 --python "$here/blender_protocol_scene.py" -- "$map" "$dir/blender" \
            "$percent" "$samples" 0 mirror,matte_silver,diffuse >"$dir/blender.log" 2>&1 ||
            { echo "Blender failed on $map (see $dir/blender.log)" >&2; exit 1; }
        for material in mirror matte_silver diffuse; do
            [ -s "$dir/blender/seed0/$material.exr" ] ||
                { echo "Blender wrote no $material sphere for $map (see $dir/blender.log)" >&2; exit 1; }
        done
    done
}

# The protocol's own scripts, when a checkout is given.
if [ -n "${PROTOCOL_DIR:-}" ]; then
    scripts="$PROTOCOL_DIR/stylelight"
    [ -f "$scripts/mirror.py" ] && [ -f "$scripts/utils/utils.py" ] ||
        { echo "PROTOCOL_DIR=$PROTOCOL_DIR: no stylelight/mirror.py and utils/utils.py there" >&2; exit 1; }
    cp -r "$scripts" "$out/protocol"
    utils="$out/protocol/utils/utils.py"
    for flag in use_denoising prefer_cuda_use; do
        grep -q "$flag: bool = True" "$utils" ||
            { echo "$utils: no '$flag: bool = True' default to turn off" >&2; exit 1; }
        sed -i "s/$flag: bool = True/$flag: bool = False/" "$utils"
    done
    mkdir -p "$out/protocol-maps" "$out/protocol-renders"
    for map in "${maps[@]}"; do
        # The scripts name a render after the map's name up to its first '-'.
        name=$(basename "$(dirname "$map")")
        cp "$map" "$out/protocol-maps/${name//-/_}.exr"
    done
fi
protocol_scripts() {
    for material in mirror matte_silver diffuse; do
        (cd "$out/protocol" && "$blender" --background --factory-startup --python-exit-code 1 \
            --python "$material.py" -- "$percent" "$samples" "$out/protocol-maps" "$out/protocol-renders" \
            0 "${#maps[@]}") >"$out/protocol-$material.log" 2>&1 ||
            { echo "the protocol's $material.py failed (see $out/protocol-$material.log)" >&2; exit 1; }
        made=$(ls "$out/protocol-renders/$material" | wc -l)
        [ "$made" -eq "${#maps[@]}" ] ||
            { echo "the protocol's $material.py wrote $made of ${#maps[@]} renders" >&2; exit 1; }
    done
}

# hdrflow: the batch over every pair, then over the first pair alone, each with an empty cache.
batch() {
    local name=$1 gts=$2 preds=$3
    "$hdrflow" batch "$root/examples/evaluation/evaluate.ron" \
        --over "gt.path=$gts" --over "pred.path=$preds" --zip --item-dir '{stem}' \
        --out "$out/$name" --report "$out/$name/batch.json" --cache-dir "$out/$name-cache" -q >/dev/null
}
first=$(basename "$(ls "$root"/assets/maps/*.hdr | head -1)")
other=blurred
[ "$checkpoint" = blurred ] && other=turned

# The rounds: each measurement's CPU seconds, one a round (the first round's folders are all,
# first and next; a later round's carry its number, all-2 ...).
blender_runs=() protocol_runs=() all_runs=() first_runs=() next_runs=()
for r in $(seq "$repeats"); do
    n=
    [ "$r" -gt 1 ] && n=-$r
    times >"$out/t0"
    blender_scene
    times >"$out/t1"
    blender_runs+=("$(cpu_between "$out/t0" "$out/t1")")
    if [ -n "${PROTOCOL_DIR:-}" ]; then
        times >"$out/t0"
        protocol_scripts
        times >"$out/t1"
        protocol_runs+=("$(cpu_between "$out/t0" "$out/t1")")
    fi
    times >"$out/t0"
    batch "all$n" "$root/assets/maps/*.hdr" "$root/examples/evaluation/predictions/$checkpoint/*.hdr"
    times >"$out/t1"
    batch "first$n" "$root/assets/maps/$first" "$root/examples/evaluation/predictions/$checkpoint/$first"
    times >"$out/t2"
    # Another checkpoint's predictions against the same truths, with the first batch's cache: the
    # truths' spheres are read back, as at every checkpoint after the first.
    cp -r "$out/all$n-cache" "$out/next$n-cache"
    times >"$out/t3"
    batch "next$n" "$root/assets/maps/*.hdr" "$root/examples/evaluation/predictions/$other/*.hdr"
    times >"$out/t4"
    all_runs+=("$(cpu_between "$out/t0" "$out/t1")")
    first_runs+=("$(cpu_between "$out/t1" "$out/t2")")
    next_runs+=("$(cpu_between "$out/t3" "$out/t4")")
done
blender_cpu=$(median "${blender_runs[@]}")
protocol_cpu=
[ -n "${PROTOCOL_DIR:-}" ] && protocol_cpu=$(median "${protocol_runs[@]}")
all_cpu=$(median "${all_runs[@]}")
first_cpu=$(median "${first_runs[@]}")
next_cpu=$(median "${next_runs[@]}")
if [ "$repeats" -gt 1 ]; then
    scripts_runs=
    [ -n "$protocol_cpu" ] && scripts_runs="the protocol's scripts ${protocol_runs[*]}; "
    echo "medians of $repeats rounds; each round's CPU seconds: Blender's scene ${blender_runs[*]};" \
        "${scripts_runs}the batch ${all_runs[*]}; one pair ${first_runs[*]};" \
        "the next checkpoint ${next_runs[*]}" >&2
fi

awk -v b="$blender_cpu" -v a="$all_cpu" -v f="$first_cpu" -v n="$next_cpu" -v o="$other" -v p="$percent" -v s="$samples" 'BEGIN {
    printf "Blender, the protocol'"'"'s scene (blender_protocol_scene.py), 18 spheres at %s%% and %s samples: %.2f s CPU (%.2f s a pair of maps)\n", p, s, b, b / 3
    printf "hdrflow, the batch of 3 pairs (18 spheres, empty cache): %.2f s CPU: %.1fx less\n", a, b / a
    printf "hdrflow, one pair alone: %.2f s CPU; each further pair: %.2f s CPU: %.1fx less than Blender a pair\n", f, (a - f) / 2, (b / 3) / ((a - f) / 2)
    printf "hdrflow, the %s checkpoint against the same truths (their spheres cached): %.2f s CPU: %.1fx less than Blender'"'"'s 9 prediction spheres\n", o, n, (b / 2) / n
}'
if [ -n "$protocol_cpu" ]; then
    awk -v b="$protocol_cpu" -v a="$all_cpu" -v f="$first_cpu" -v n="$next_cpu" -v p="$percent" -v s="$samples" 'BEGIN {
        printf "Blender, the protocol'"'"'s own three scripts, 18 spheres at %s%% and %s samples: %.2f s CPU (%.2f s a pair of maps): %.1fx the batch, %.1fx a further pair, %.1fx the next checkpoint\n", p, s, b, b / 3, b / a, (b / 3) / ((a - f) / 2), (b / 2) / n
    }'
fi
