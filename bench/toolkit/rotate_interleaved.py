#!/usr/bin/env python3
"""hdrflow's `Rotate` (one or more binaries) and skylibs' `rotate`, interleaved on a loaded machine (the
version 5 table of docs/src/benchmarks/dataset.md, "Toolkit resampling").

For each of --repeats rounds, each map of assets/maps and each rotation (pitch 30; yaw 33, pitch 21,
roll -12): every binary runs `hdrflow run --no-cache --json --target NODE` on a graph of a `LoadHdr`
and that node (the node's own `ms` from the report, the process's CPU time from getrusage of the
children, which includes loading the map), then skylibs' `rotate` runs in this process (wall and
`process_time`). Prints the medians. Unlike compare_rotate.py, which runs every hdrflow node first
and skylibs after, a change of load hits both alike. From the repository's root, in a venv with
skylibs and OpenCV:

    python3 bench/toolkit/rotate_interleaved.py --repeats 5 old/hdrflow target/release/hdrflow
"""
import argparse
import glob
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench" / "peers"))

from dataset_skylibs import rotation  # noqa: E402
from envmap import EnvironmentMap  # noqa: E402
from rotate_skylibs import load  # noqa: E402

ROTATIONS = [("pitch", (0.0, 30.0, 0.0)), ("ypr", (33.0, 21.0, -12.0))]


def children_cpu_ms():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r.ru_utime + r.ru_stime) * 1e3


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("binaries", nargs="+")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--work", default="/tmp/rotate-interleaved")
    a = ap.parse_args()
    work = pathlib.Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    res = {}
    for _ in range(a.repeats):
        for path in sorted(glob.glob(str(ROOT / "assets" / "maps" / "*.hdr"))):
            name = pathlib.Path(path).name.replace("_1k.hdr", "")
            nodes = ",\n".join(f"    \"{k}\": Rotate(image: \"env\", yaw: {y}, pitch: {p}, roll: {r})"
                               for k, (y, p, r) in ROTATIONS)
            graph = work / f"{name}.ron"
            graph.write_text(f"(nodes: {{\n    \"env\": LoadHdr(path: {json.dumps(path)}),\n{nodes},\n}})\n")
            data = load(path)
            for node, (y, p, r) in ROTATIONS:
                for b in a.binaries:
                    c0 = children_cpu_ms()
                    out = subprocess.run([b, "run", str(graph), "--no-cache", "--json", "--quiet", "--target", node,
                                          "--out", str(work / "out")], check=True, capture_output=True, text=True).stdout
                    ms = next(n["ms"] for n in json.loads(out)["nodes"] if n["name"] == node)
                    res.setdefault((name, node, b), []).append((ms, children_cpu_ms() - c0, os.getloadavg()[0]))
                env = EnvironmentMap(data.copy(), "latlong")
                w0, c0 = time.perf_counter(), time.process_time()
                env.rotate(rotation(y, p, r).T)
                wall, cpu = (time.perf_counter() - w0) * 1e3, (time.process_time() - c0) * 1e3
                res.setdefault((name, node, "skylibs"), []).append((wall, cpu, os.getloadavg()[0]))
    for (name, node, who), v in sorted(res.items()):
        print(f"{name:20} {node:6} {who:40} wall {statistics.median(x[0] for x in v):7.1f} ms  "
              f"cpu {statistics.median(x[1] for x in v):6.1f} ms  load {min(x[2] for x in v):.1f}-{max(x[2] for x in v):.1f}")


if __name__ == "__main__":
    main()
