"""What the Python bindings cost over the command line (the numbers in docs/src/benchmarks/engine.md).

    python python/bench/overhead.py [--bin target/release/hdrflow] [--repeats 30]

1. The cached seed graph, the same run both ways: `hdrflow run graphs/seed.ron` (the process,
   start-up included, and its report's `total_ms`) against `hdrflow.run(...)` in a warm Python
   process with the same targets (the call, and its report's `total_ms`); then the Python
   default targets (the Save nodes' values come back as arrays too).
2. A Python operator per call: an identity operator against the built-in `Exposure` (stops 0),
   on arrays fed with `inputs=`, no cache: the node's own time from the report, and the call.
Medians of `--repeats` runs after one warm-up.
"""

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import tempfile
import time

import numpy as np

import hdrflow

ROOT = pathlib.Path(__file__).resolve().parents[2]


def median_ms(f, repeats):
    f()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=os.environ.get("HDRFLOW_BIN", str(ROOT / "target/release/hdrflow")))
    ap.add_argument("--repeats", type=int, default=30)
    args = ap.parse_args()
    tmp = pathlib.Path(tempfile.mkdtemp())
    seed = ROOT / "graphs/seed.ron"
    cli = [args.bin, "run", str(seed), "--out", str(tmp / "out"), "--cache-dir", str(tmp / "cache"), "--quiet"]
    subprocess.run(cli, check=True)  # fills the cache
    subprocess.run(cli + ["--report", str(tmp / "r.json")], check=True)
    report = json.loads((tmp / "r.json").read_text())
    # In a fully cached run only the targets are loaded: they are the cached nodes.
    targets = [n["name"] for n in report["nodes"] if n["status"] == "cached"]

    cli_totals = []

    def cli_run():
        subprocess.run(cli + ["--report", str(tmp / "r.json")], check=True)
        cli_totals.append(json.loads((tmp / "r.json").read_text())["total_ms"])

    py_totals = []

    def py_run():
        r = hdrflow.run(seed, targets=targets, out=tmp / "out", cache_dir=tmp / "cache")
        py_totals.append(r.report["total_ms"])
        assert all(n["status"] != "computed" for n in r.report["nodes"])

    default_totals = []

    def py_default():
        r = hdrflow.run(seed, out=tmp / "out", cache_dir=tmp / "cache")
        default_totals.append(r.report["total_ms"])

    cli_ms = median_ms(cli_run, args.repeats)
    py_ms = median_ms(py_run, args.repeats)
    default_ms = median_ms(py_default, args.repeats)
    print(f"cached seed graph, {len(targets)} targets ({args.repeats} runs, medians):")
    print(f"  CLI process          {cli_ms:7.2f} ms   (report total_ms {statistics.median(cli_totals):.2f})")
    print(f"  hdrflow.run          {py_ms:7.2f} ms   (report total_ms {statistics.median(py_totals):.2f})"
          f"   ratio to the CLI process {py_ms / cli_ms:.2f}")
    print(f"  hdrflow.run default  {default_ms:7.2f} ms   (report total_ms {statistics.median(default_totals):.2f};"
          " + the Save nodes' values as arrays)")

    @hdrflow.operator(name="BenchIdentity", fields={"image": "image"}, output="image")
    def identity(image):
        return image

    for h, w in [(64, 64), (256, 512), (1024, 2048)]:
        env = np.random.default_rng(0).random((h, w, 3), dtype=np.float32)
        for op in ["BenchIdentity(image: \"env\")", "Exposure(image: \"env\", stops: 0.0)"]:
            graph = f'(nodes: {{"env": LoadHdr(path: "builtin:sky"), "x": {op}}})'
            node_ms = []

            def one():
                r = hdrflow.run(graph, targets=["x"], inputs={"env": env}, no_cache=True, jobs=2)
                node_ms.append(next(n["ms"] for n in r.report["nodes"] if n["name"] == "x"))

            call_ms = median_ms(one, args.repeats)
            print(f"  {w}x{h} {op.split('(')[0]:<14} node {statistics.median(node_ms):8.3f} ms   call {call_ms:8.3f} ms")


if __name__ == "__main__":
    main()
