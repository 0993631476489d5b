#!/usr/bin/env python3
"""Runs the dataset job twice in one run, on the same maps, and compares: `hdrflow batch
examples/dataset/dataset.ron` (cold cache, then warm) and bench/peers/dataset_skylibs.py (skylibs +
NumPy/SciPy, a process pool). Prints the throughput of each (items = (map, azimuth) pairs, crops,
maps per second), their ratio, and how far the two outputs agree, and writes it all to
WORK/summary.json. From the repository's root, in a venv with the peer's packages:

    pip install skylibs scipy opencv-python-headless OpenEXR
    cargo build --release
    python3 bench/dataset/compare.py --maps 'assets/maps/*.hdr' --work /tmp/dataset-bench

What is compared, per item and crop: the label keys (must be equal), the camera matrices, the SH
coefficients (max |difference| over the 27 numbers / |L_00| of the luminance), the lights (count,
angle between matched directions, solid-angle ratio), the fits' relative RMSE (each on its own
256 x 128 fit map) and the crops (the median over pixels of |a - b| / |a|, then its median and
maximum over crops: the two cameras' pixel grids differ, so edges and the sun differ most).
"""
import argparse
import glob
import json
import math
import os
import pathlib
import shutil
import subprocess
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
YAWS = "0,45,90,135,180,225,270,315"
CROPS = 4


def run(cmd, **kw):
    start = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, **kw)
    seconds = time.perf_counter() - start
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(map(str, cmd))}\n{p.stdout}\n{p.stderr}")
    return p, seconds


def read_exr(path):
    sys.path.insert(0, str(ROOT / "bench" / "peers"))
    import ezexr
    return ezexr.imread(str(path)).astype(np.float64)


def keys(v, prefix=""):
    """Every key path of a JSON document (lists by their first element)."""
    out = set()
    if isinstance(v, dict):
        for k, x in v.items():
            out.add(prefix + k)
            out |= keys(x, prefix + k + ".")
    elif isinstance(v, list) and v:
        out |= keys(v[0], prefix + "[].")
    return out


def angle_deg(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return math.degrees(math.acos(max(-1.0, min(1.0, float(a @ b / np.linalg.norm(a) / np.linalg.norm(b))))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", default="assets/maps/*.hdr")
    ap.add_argument("--work", default="/tmp/dataset-bench")
    ap.add_argument("--hdrflow", default=str(pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
                                            / "release" / "hdrflow"))
    ap.add_argument("--workers", type=int, default=os.cpu_count())
    ap.add_argument("--yaws", default=YAWS)
    a = ap.parse_args()
    maps = sorted(glob.glob(a.maps))
    if not maps:
        sys.exit(f"no map matches {a.maps}")
    yaws = a.yaws.split(",")
    work = pathlib.Path(a.work)
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    graph = ROOT / "examples" / "dataset" / "dataset.ron"
    batch = [a.hdrflow, "batch", str(graph), "--over", f"env.path={a.maps}", "--sweep", f"rot.yaw={a.yaws}",
             "--out", str(work / "hdrflow"), "--cache-dir", str(work / "cache"), "--jobs", str(a.workers), "-q"]
    _, cold = run(batch + ["--report", str(work / "report.json")])
    _, warm = run(batch)
    peer_cmd = [sys.executable, str(ROOT / "bench" / "peers" / "dataset_skylibs.py"), "--maps", a.maps,
                "--out", str(work / "peer"), "--yaws", a.yaws, "--workers", str(a.workers)]
    p, peer_wall = run(peer_cmd)
    peer = json.loads(p.stdout.strip().splitlines()[-1])
    # One item's per-operator times (hdrflow run, no cache), for the breakdown.
    _, _ = run([a.hdrflow, "run", str(graph), "--set", f"env.path={maps[0]}", "--set", f"rot.yaw={yaws[1 % len(yaws)]}",
                "--out", str(work / "one"), "--no-cache", "--jobs", str(a.workers), "-q",
                "--report", str(work / "one.json")])
    per_op = {}
    for node in json.loads((work / "one.json").read_text())["nodes"]:
        per_op[node["op"]] = per_op.get(node["op"], 0.0) + node["ms"] / 1000.0
    peer_stages = {}
    for row in peer["rows"]:
        for stage, s in row["seconds"].items():
            peer_stages[stage] = peer_stages.get(stage, 0.0) + s / len(peer["rows"])

    items = len(maps) * len(yaws)
    worst = {"sh": 0.0, "matrix": 0.0, "light_angle_deg": 0.0, "light_solid_angle_ratio": [1.0, 1.0]}
    crop_diff, light_counts, rmse = [], [], {"hdrflow": [], "peer": []}
    for m in maps:
        stem = pathlib.Path(m).stem
        for y in yaws:
            item = f"{stem}/yaw={float(y):g}"
            ours_dir, peer_dir = work / "hdrflow" / f"{stem}/yaw={y}", work / "peer" / item
            rmse["hdrflow"].append(json.loads((ours_dir / "map" / "sg_fit.json").read_text())["relative_rmse"])
            for k in range(CROPS):
                ours = json.loads((ours_dir / f"crop_{k}.json").read_text())
                theirs = json.loads((peer_dir / f"crop_{k}.json").read_text())
                if keys(ours) != keys(theirs):
                    sys.exit(f"{item} crop {k}: the label keys differ: {sorted(keys(ours) ^ keys(theirs))}")
                worst["matrix"] = max(worst["matrix"], float(np.max(np.abs(
                    np.array(ours["camera"]["world_to_camera"]) - np.array(theirs["camera"]["world_to_camera"])))))
                a_sh, b_sh = np.array(ours["sh"]["coefficients"]), np.array(theirs["sh"]["coefficients"])
                l00 = abs(float(a_sh[0] @ [0.2126, 0.7152, 0.0722]))
                worst["sh"] = max(worst["sh"], float(np.max(np.abs(a_sh - b_sh))) / l00)
                la, lb = ours["lights"]["lights"], theirs["lights"]["lights"]
                if k == 0:
                    light_counts.append((len(la), len(lb)))
                    for x, z in zip(la, lb):
                        worst["light_angle_deg"] = max(worst["light_angle_deg"], angle_deg(x["direction"], z["direction"]))
                        r = z["solid_angle"] / x["solid_angle"]
                        lo, hi = worst["light_solid_angle_ratio"]
                        worst["light_solid_angle_ratio"] = [min(lo, r), max(hi, r)]
                ca, cb = read_exr(ours_dir / f"crop_{k}.exr"), read_exr(peer_dir / f"crop_{k}.exr")
                # Per pixel (a sun of 6e4 in a few pixels would swamp a mean over the crop).
                rel = np.abs(ca - cb) / (np.abs(ca) + 1e-3 * np.mean(np.abs(ca)))
                crop_diff.append(float(np.median(rel)))
    per_map_rmse = {}
    for row in peer["rows"]:
        rmse["peer"].append(row["sg_relative_rmse"])
    for i, m in enumerate(maps):
        stem = pathlib.Path(m).stem
        per_map_rmse[stem] = {k: float(np.mean(v[i * len(yaws):(i + 1) * len(yaws)])) for k, v in rmse.items()}
    summary = {
        "machine": f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end",
        "maps": len(maps), "items": items, "crops": items * CROPS, "workers": a.workers,
        "seconds": {"hdrflow_cold": cold, "hdrflow_warm": warm, "peer": peer_wall, "peer_pool": peer["seconds"]},
        "throughput": {
            "hdrflow_cold": {"items_s": items / cold, "crops_s": items * CROPS / cold, "maps_s": len(maps) / cold},
            "peer": {"items_s": items / peer_wall, "crops_s": items * CROPS / peer_wall, "maps_s": len(maps) / peer_wall},
        },
        "ratio_cold": peer_wall / cold,
        "ratio_warm": peer_wall / warm,
        "hdrflow_one_item_seconds_by_operator": per_op,
        "peer_mean_item_seconds_by_stage": peer_stages,
        "peer_rows": peer["rows"],
        "agreement": {
            "sh_max_abs_diff_over_l00": worst["sh"],
            "camera_matrix_max_abs_diff": worst["matrix"],
            "light_counts_equal": sum(x == z for x, z in light_counts), "light_counts_of": len(light_counts),
            "light_counts": light_counts,
            "light_direction_max_angle_deg": worst["light_angle_deg"],
            "light_solid_angle_ratio_peer_over_hdrflow": worst["light_solid_angle_ratio"],
            "sg_relative_rmse_mean": {k: float(np.mean(v)) for k, v in rmse.items()},
            "sg_relative_rmse_by_map": per_map_rmse,
            "crop_median_pixel_relative_diff": {"median": float(np.median(crop_diff)), "max": float(np.max(crop_diff))},
        },
    }
    (work / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    t = summary["throughput"]
    print(f"{len(maps)} maps, {items} items, {items * CROPS} crops, {a.workers} workers")
    print(f"hdrflow batch (cold): {cold:8.1f} s  {t['hdrflow_cold']['items_s']:.3f} items/s  "
          f"{t['hdrflow_cold']['crops_s']:.3f} crops/s  {t['hdrflow_cold']['maps_s']:.4f} maps/s")
    print(f"hdrflow batch (warm): {warm:8.1f} s")
    print(f"skylibs + NumPy peer: {peer_wall:8.1f} s  {t['peer']['items_s']:.3f} items/s  "
          f"{t['peer']['crops_s']:.3f} crops/s  {t['peer']['maps_s']:.4f} maps/s")
    print(f"ratio (peer time / hdrflow time): {summary['ratio_cold']:.2f} cold, {summary['ratio_warm']:.0f} warm")
    print(json.dumps(summary["agreement"], indent=2))
    print("hdrflow, one item, seconds by operator:", {k: round(v, 3) for k, v in per_op.items()})
    print("peer, mean item, seconds by stage:", {k: round(v, 3) for k, v in peer_stages.items()})


if __name__ == "__main__":
    main()
