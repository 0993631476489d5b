#!/usr/bin/env python3
"""hdrflow's `Rotate` and `LatLongToMirrorBall` against skylibs' `rotate` and `convertTo('sphere')`,
in one run on the same maps (the numbers of docs/src/benchmarks/dataset.md, "Toolkit resampling").

For each map and rotation, `hdrflow run --no-cache --json --target NODE` on a graph of a `LoadHdr` and
that one node, --repeats times: the node's own time (the report's `ms`), median. Then
bench/peers/rotate_skylibs.py times skylibs' calls (median of --repeats). Prints a table and writes
WORK/rotate_summary.json. From the repository's root, in a venv with skylibs and OpenCV:

    python3 bench/toolkit/compare_rotate.py --maps 'assets/maps/*.hdr' --hdrflow target/release/hdrflow
"""
import argparse
import glob
import json
import os
import pathlib
import statistics
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", required=True)
    ap.add_argument("--hdrflow", default=str(ROOT / "target" / "release" / "hdrflow"))
    ap.add_argument("--rotations", default="12.5,0,0;0,30,0;33,21,-12")
    ap.add_argument("--ball", type=int, default=768)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--work", default="/tmp/rotate-bench")
    a = ap.parse_args()
    work = pathlib.Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    a.maps = os.path.abspath(a.maps)
    maps = sorted(glob.glob(a.maps))
    rotations = [tuple(float(v) for v in t.split(",")) for t in a.rotations.split(";")]
    rows = []
    for path in maps:
        nodes = {f"rot{i}": f"Rotate(image: \"env\", yaw: {y}, pitch: {p}, roll: {r})"
                 for i, (y, p, r) in enumerate(rotations)}
        if a.ball:
            nodes["ball"] = f"LatLongToMirrorBall(env: \"env\", size: {a.ball})"
        body = ",\n".join(f"    \"{k}\": {v}" for k, v in nodes.items())
        graph = work / "rotate.ron"
        graph.write_text(f"(nodes: {{\n    \"env\": LoadHdr(path: {json.dumps(os.path.abspath(path))}),\n{body},\n}})\n")
        for node in nodes:
            times = []
            for _ in range(a.repeats):
                out = subprocess.run([a.hdrflow, "run", str(graph), "--no-cache", "--json", "--quiet", "--target", node,
                                      "--out", str(work / "out")], check=True, capture_output=True, text=True).stdout
                report = json.loads(out)
                times.append(next(n["ms"] for n in report["nodes"] if n["name"] == node))
            row = {"map": path, "node": node, "hdrflow_ms": statistics.median(times)}
            if node == "ball":
                row.update(op="sphere", size=a.ball)
            else:
                y, p, r = rotations[int(node[3:])]
                row.update(op="rotate", yaw=y, pitch=p, roll=r)
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    peer = subprocess.run([sys.executable, str(ROOT / "bench" / "peers" / "rotate_skylibs.py"), "--maps", a.maps,
                           "--rotations", a.rotations, "--ball", str(a.ball), "--repeats", str(a.repeats)],
                          check=True, capture_output=True, text=True, cwd=ROOT / "bench" / "peers").stdout
    peer_rows = json.loads(peer)["rows"]
    for row, prow in zip(rows, peer_rows):
        assert (row["map"], row["op"]) == (prow["map"], prow["op"]), (row, prow)
        row["skylibs_ms"] = prow["ms"]
        row["ratio"] = prow["ms"] / row["hdrflow_ms"]
    print(f"{'map':28} {'operation':22} {'hdrflow ms':>11} {'skylibs ms':>11} {'skylibs/hdrflow':>16}")
    for row in rows:
        what = (f"ball {row['size']}" if row["op"] == "sphere"
                else f"rotate {row['yaw']:g},{row['pitch']:g},{row['roll']:g}")
        print(f"{pathlib.Path(row['map']).name:28} {what:22} {row['hdrflow_ms']:11.1f} {row['skylibs_ms']:11.1f} "
              f"{row['ratio']:16.2f}")
    summary = {"cpu": os.environ.get("HDRFLOW_CPU", "auto"), "repeats": a.repeats, "rows": rows}
    (work / "rotate_summary.json").write_text(json.dumps(summary, indent=2) + "\n")


if __name__ == "__main__":
    main()
