#!/usr/bin/env bash
# Wall time of `graphs/seed.ron` over 16 maps of 1024x512 as a Slurm job array on the one-node
# cluster of scripts/slurm-cluster.sh, against the same batch run locally, in one run
# (docs/src/benchmarks/batch.md, "Batch runs"). Needs root and the slurm packages (scripts/slurm-cluster.sh
# install) and a release build (cargo build --release).
#   scripts/bench-slurm.sh [MAP]     MAP: any map hdrflow reads (default: the built-in sky)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
hdrflow=$root/target/release/hdrflow
map=${1:-builtin:sky}
[ -x "$hdrflow" ] || { echo "build first: cargo build --release" >&2; exit 1; }
work=$(mktemp -d)
chmod 755 "$work" # munged (user munge) must reach the cluster folder inside it
trap 'bash "$root/scripts/slurm-cluster.sh" stop "$work/cluster" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
cd "$work"

# The library: the map at 1024x512, at 16 exposures.
cat > make.ron <<EOF
( nodes: {
  "src": LoadHdr(path: "$map"),
  "res": Resize(image: "src", width: 1024, height: 512),
  "exp": Exposure(image: "res", stops: 0),
  "save": Save(input: "exp", path: "map.hdr"),
} )
EOF
"$hdrflow" batch make.ron --sweep "exp.stops=$(seq -s, -4 0.5 3.5)" --item-dir 'm{index}' \
    --out lib --cache-dir make-cache -q
mkdir maps
for d in lib/m*; do cp "$d/map.hdr" "maps/$(basename "$d").hdr"; done
echo "library: $(ls maps | wc -l) maps of 1024x512"

now() { date +%s.%N; }
elapsed() { echo "$(now) - $1" | bc; }

t=$(now)
"$hdrflow" batch "$root/graphs/seed.ron" --over 'env.path=maps/*.hdr' --out local1 --cache-dir c-local1 --jobs 1 -q
echo "local batch --jobs 1: $(elapsed "$t") s"
t=$(now)
"$hdrflow" batch "$root/graphs/seed.ron" --over 'env.path=maps/*.hdr' --out local2 --cache-dir c-local2 --jobs 2 -q
echo "local batch --jobs 2: $(elapsed "$t") s"

eval "$(bash "$root/scripts/slurm-cluster.sh" start "$work/cluster")"
for shards in 2 4 16; do
    "$hdrflow" batch "$root/graphs/seed.ron" --over 'env.path=maps/*.hdr' --out "s$shards" \
        --cache-dir "c-s$shards" --jobs 1 --emit-slurm "s$shards.sbatch" --shards "$shards" 2>/dev/null
    t=$(now)
    job=$(sbatch --parsable "s$shards.sbatch")
    # Poll the queue (sbatch --wait polls only every 2 s, which would dominate the numbers).
    for ((i = 0; i < 6000; i++)); do
        [ -z "$(squeue -h -j "$job" 2>/dev/null)" ] && break
        sleep 0.1
    done
    wall=$(elapsed "$t")
    left=$("$hdrflow" batch "$root/graphs/seed.ron" --over 'env.path=maps/*.hdr' --out "s$shards" \
        --cache-dir "c-s$shards" --jobs 1 --failed-shards "$shards" 2>/dev/null)
    same=$(diff -rq --exclude=shards --exclude=slurm --exclude='batch*' local1 "s$shards" >/dev/null && echo identical || echo DIFFERENT)
    echo "slurm array, $shards elements of --jobs 1: $wall s (unfinished shards: '${left}'; outputs $same to the local batch)"
done
