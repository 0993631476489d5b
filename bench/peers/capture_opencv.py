#!/usr/bin/env python3
"""The capture peer: a folder of bracketed exposures through OpenCV's photo module, as a user writes
it (`pip install opencv-python-headless numpy`), for the comparison of issue 38 (`LoadBrackets`,
`AlignBrackets`, `CalibrateResponse`, `MergeBrackets`, `FuseExposures`).

    python3 bench/peers/capture_opencv.py FOLDER [--times 1/1000,1/250,...] --out-dir OUT \
        [--truth TRUTH.pfm] [--true-response srgb] [--robertson] [--mertens] [--repeats 5]

FOLDER holds the frames (PNG, JPEG or TIFF, 8 or 16 bits per channel; grey frames are made RGB)
and, unless `--times` is given, a `times.json` beside them: a list of seconds in file-name order,
an object {file name: seconds}, or either under the key "times" / "exposure_times"; a time may be
a number or a string "1/250". Without both, the frames' EXIF ExposureTime is read when Pillow is
installed. The frames are sorted by exposure time, shortest first (as `LoadBrackets` sorts them).

Steps (each an OpenCV call with its defaults unless said):
1. `createAlignMTB(max_bits=6, exclude_range=4, cut=True)`: the shift of each frame relative to
   the middle frame (index n // 2 of the sorted frames, OpenCV's pivot) from `calculateShift` on
   `cvtColor(frame, COLOR_RGB2GRAY)` (the frames are BGR as `imread` gives them, and OpenCV's
   `AlignMTB::process` converts them with RGB2GRAY all the same: this script does exactly what
   `process` does). A shift (dx, dy) is what `shiftMat` applies to the frame to match the pivot,
   so a frame whose content is displaced by (+3, -2) gets (-3, +2). The shifted frames are cropped
   to the area every frame covers (`cut`), and that rectangle is reported (`crop`, x y w h in the
   frames' pixels). Python's `AlignMTB.process(src, dst)` does not fill `dst`, hence the explicit
   `calculateShift` + `shiftMat` + crop, which is `process`'s own code path. `--no-align` skips it.
2. `createCalibrateDebevec(samples=70, lambda_=10)` (grid sampling, random=False) on the aligned
   frames: `response_debevec.csv` (code,R,G,B; OpenCV's response is near 1 at code 128: g(128) = 0
   is one more least-squares equation, not a hard constraint).
3. `createMergeDebevec().process(frames, times, response)`: `merged_debevec.exr` through
   `cv2.imwrite` when this OpenCV build writes EXR (`OPENCV_IO_ENABLE_OPENEXR=1` is set before
   cv2 is imported), otherwise `merged_debevec.pfm` (hdrflow's PFM convention: RGB, float32,
   little-endian, rows bottom to top, `pfm_common.write_pfm`); `--format npy` writes `.npy` (RGB).
   With `--response linear`, no calibration: MergeDebevec's built-in linear response (for linear
   16-bit TIFFs exported from raw files).
4. Optional: `--robertson` (`createCalibrateRobertson()` then `createMergeRobertson()`, written
   as `response_robertson.csv` and `merged_robertson.*`) and `--mertens` (`createMergeMertens()`,
   written as `fused_mertens.png`, 8 bits, clipped to [0, 1], and `fused_mertens.pfm`).
5. Timing: `MergeDebevec` alone, from decoded frames, best (and median) of `--repeats` calls, in a
   child process (this script with `--merge-child`) that decodes the frames, resets its peak-RSS
   mark (writing 5 to /proc/self/clear_refs) and reads VmHWM after the merges: `merge_peak_rss`
   is the process's peak during the merges (frames, output and OpenCV's temporaries, plus
   Python's own baseline), `merge_extra` that peak less the RSS just before the first merge
   (OpenCV's temporaries and the output). tracemalloc cannot see OpenCV's allocations. Where
   clear_refs cannot be written, the child's ru_maxrss over its whole life is reported instead
   (`peak_method`). `decode_peak_rss` is VmHWM before the reset, `child_peak_rss` the child's
   whole-life peak. (The parent's RUSAGE_CHILDREN ru_maxrss is no measure of the child: Linux
   counts in it the parent's memory copied at fork, before the exec.)

16-bit frames: OpenCV's CalibrateDebevec, MergeDebevec, MergeRobertson and AlignMTB take 8-bit
frames only (`CV_Assert(images[0].depth() == CV_8U)`), so 16-bit frames are reduced to 8 bits by
`code >> 8` before every step (reported as `"reduced_to_8bit": "code >> 8"`).

With `--truth` (a PFM in hdrflow's convention or an RGB .npy, in the middle frame's pixels), each
merged map is compared with it over the channels that are neither 0 nor 255 in at least one
(aligned) frame: `median_rel` is the median of |s m - t| / t with s = 1 / median(m / t), the scale
that makes the median pixel exact; `rel_rmse` is sqrt(mean(((s2 m - t) / t)^2)) with s2 the scale
that minimises it. With `--true-response srgb|gamma2.2|linear|FILE.csv`, each recovered response
is compared with the truth (the inverse camera curve, code z -> relative exposure) after the
scale that minimises the mean squared log error, over codes `--response-codes` (default 10-245).

Prints one JSON object on stdout (versions, defaults, frames, times, shifts, crop, timings in ms,
memory in bytes, errors, paths); `--json FILE` also writes it to FILE.

`--make-synthetic DIR` writes a synthetic bracket set with a known truth instead (see
`make_synthetic`); the test `bench/peers/test_capture_opencv.py` uses it.
"""

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")  # before cv2 is imported

import numpy as np  # noqa: E402

try:
    import cv2  # noqa: E402
except ImportError:  # the synthetic-set maker and the PFM helpers need only NumPy
    cv2 = None

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pfm_common import read_pfm, write_pfm  # noqa: E402

FRAME_EXTS = (".png", ".jpg", ".jpeg", ".tif", ".tiff")


class PeerError(Exception):
    """A bad input: reported as {"error": ...} and exit status 2, never a traceback."""


# ----------------------------------------------------------------------------------------------
# Inputs


def parse_time(value, where):
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        t = float(value)
    elif isinstance(value, str):
        s = value.strip()
        try:
            if "/" in s:
                num, den = s.split("/", 1)
                t = float(num) / float(den)
            else:
                t = float(s)
        except (ValueError, ZeroDivisionError):
            raise PeerError(f"{where}: exposure time {value!r} is not a number or a fraction")
    else:
        raise PeerError(f"{where}: exposure time {value!r} is not a number or a fraction")
    if not math.isfinite(t) or t <= 0:
        raise PeerError(f"{where}: exposure time {value!r} is not a positive number of seconds")
    return t


def list_frames(folder):
    if not os.path.isdir(folder):
        raise PeerError(f"{folder}: not a folder")
    names = sorted(
        n for n in os.listdir(folder)
        if n.lower().endswith(FRAME_EXTS) and os.path.isfile(os.path.join(folder, n))
    )
    if not names:
        raise PeerError(f"{folder}: no PNG, JPEG or TIFF frames")
    return names


def exif_time(path):
    """ExposureTime (tag 0x829A) read with Pillow when it is installed, else None."""
    try:
        from PIL import Image
    except ImportError:
        return None
    try:
        with Image.open(path) as im:
            exif = im.getexif()
            t = exif.get_ifd(0x8769).get(0x829A) or exif.get(0x829A)
        return float(t) if t else None
    except Exception:
        return None


def load_times(folder, names, cli_times):
    """Exposure times in `names` order, and where they came from."""
    if cli_times is not None:
        items = [s for s in cli_times.split(",") if s.strip()]
        times = [parse_time(s, "--times") for s in items]
        source = "--times"
    else:
        path = os.path.join(folder, "times.json")
        if os.path.isfile(path):
            with open(path) as f:
                try:
                    data = json.load(f)
                except json.JSONDecodeError as e:
                    raise PeerError(f"{path}: not JSON ({e})")
            if isinstance(data, dict) and ("times" in data or "exposure_times" in data):
                data = data.get("times", data.get("exposure_times"))
            if isinstance(data, dict):
                missing = [n for n in names if n not in data]
                if missing:
                    raise PeerError(f"{path}: no exposure time for {missing[0]}")
                times = [parse_time(data[n], f"{path} [{n}]") for n in names]
            elif isinstance(data, list):
                times = [parse_time(v, f"{path} [{i}]") for i, v in enumerate(data)]
            else:
                raise PeerError(f"{path}: expected a list of times or an object {{file: time}}")
            source = path
        else:
            times = [exif_time(os.path.join(folder, n)) for n in names]
            if any(t is None for t in times):
                first = names[[t is None for t in times].index(True)]
                raise PeerError(
                    f"{folder}: no exposure times: no --times, no times.json, and no EXIF "
                    f"ExposureTime in {first}" + ("" if _has_pillow() else " (Pillow not installed)")
                )
            source = "exif"
    if len(times) != len(names):
        raise PeerError(f"{len(times)} exposure times from {source} for {len(names)} frames")
    return times, source


def _has_pillow():
    try:
        import PIL  # noqa: F401
        return True
    except ImportError:
        return False


def decode(path):
    """A frame as OpenCV decodes it for a user: BGR, uint8 or uint16, EXIF orientation applied
    (IMREAD_COLOR | IMREAD_ANYDEPTH; IMREAD_UNCHANGED would ignore the orientation)."""
    img = cv2.imread(path, cv2.IMREAD_COLOR | cv2.IMREAD_ANYDEPTH)
    if img is None:
        raise PeerError(f"{path}: OpenCV cannot decode it as an image")
    if img.dtype not in (np.uint8, np.uint16):
        raise PeerError(f"{path}: {img.dtype} samples; expected 8 or 16 bits per channel")
    return img


def load_frames(folder, names, times):
    """Decoded frames sorted by exposure (shortest first), checked; 16-bit reduced to 8."""
    if len(names) < 2:
        raise PeerError(f"{folder}: {len(names)} frame; merging needs at least 2")
    order = sorted(range(len(names)), key=lambda i: times[i])
    names = [names[i] for i in order]
    times = [times[i] for i in order]
    for a, b, na, nb in zip(times, times[1:], names, names[1:]):
        if a == b:
            raise PeerError(f"{na} and {nb} have the same exposure time {a} s")
    frames = []
    for n in names:
        img = decode(os.path.join(folder, n))
        if frames:
            if img.shape != frames[0].shape:
                raise PeerError(
                    f"{n}: {img.shape[1]} x {img.shape[0]}, but {names[0]} is "
                    f"{frames[0].shape[1]} x {frames[0].shape[0]}"
                )
            if img.dtype != frames[0].dtype:
                raise PeerError(
                    f"{n}: {8 * img.itemsize}-bit, but {names[0]} is {8 * frames[0].itemsize}-bit"
                )
        frames.append(img)
    bits = 8 * frames[0].itemsize
    if bits == 16:
        frames = [(f >> 8).astype(np.uint8) for f in frames]
    return names, times, frames, bits


# ----------------------------------------------------------------------------------------------
# Outputs


def write_response_csv(path, response):
    """OpenCV's response (256, 1, 3) in BGR order -> code,R,G,B."""
    r = np.asarray(response, dtype=np.float64).reshape(-1, 3)
    with open(path, "w") as f:
        f.write("code,R,G,B\n")
        for z, (b, g, rr) in enumerate(r):
            f.write(f"{z},{rr:.9g},{g:.9g},{b:.9g}\n")


def write_hdr(stem, bgr, fmt):
    """Writes a float32 BGR image; returns (path, format, note)."""
    note = None
    if fmt == "exr":
        path = stem + ".exr"
        try:
            if cv2.imwrite(path, bgr):
                return path, "exr", None
            note = "cv2.imwrite returned False for .exr"
        except cv2.error as e:
            note = "this OpenCV build writes no EXR: " + str(e).strip().splitlines()[-1]
        fmt = "pfm"
    rgb = np.ascontiguousarray(bgr[:, :, ::-1])
    if fmt == "npy":
        path = stem + ".npy"
        np.save(path, rgb.astype(np.float32))
        return path, "npy", note
    path = stem + ".pfm"
    write_pfm(path, rgb)
    return path, "pfm", note


def read_truth(path):
    if path.lower().endswith(".npy"):
        t = np.load(path).astype(np.float64)
    else:
        t = read_pfm(path).astype(np.float64)
    if t.ndim == 2:
        t = np.repeat(t[:, :, None], 3, axis=2)
    return t[:, :, :3]


# ----------------------------------------------------------------------------------------------
# Errors against a truth


def true_response(kind, codes=256):
    """The true inverse camera curve, code z -> relative exposure, (256, 3) RGB."""
    v = np.arange(codes, dtype=np.float64) / (codes - 1)
    if kind == "srgb":
        g = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    elif kind == "gamma2.2":
        g = v ** 2.2
    elif kind == "linear":
        g = v
    else:
        data = np.loadtxt(kind, delimiter=",", skiprows=1)
        return data[:, 1:4]
    return np.repeat(g[:, None], 3, axis=1)


def response_error(resp_bgr, truth_rgb, lo, hi):
    r = np.asarray(resp_bgr, dtype=np.float64).reshape(-1, 3)[:, ::-1]
    z = np.arange(lo, hi + 1)
    out = {"codes": [lo, hi], "per_channel": {}}
    rels = []
    for c, name in enumerate("RGB"):
        rc, tc = r[z, c], truth_rgb[z, c]
        ok = (rc > 0) & (tc > 0) & np.isfinite(rc)
        s = math.exp(np.mean(np.log(tc[ok]) - np.log(rc[ok])))
        rel = np.abs(s * rc[ok] - tc[ok]) / tc[ok]
        rels.append(rel)
        out["per_channel"][name] = {"median_rel": float(np.median(rel)), "max_rel": float(rel.max())}
    allrel = np.concatenate(rels)
    out["median_rel"] = float(np.median(allrel))
    out["max_rel"] = float(allrel.max())
    return out


def merge_error(merged_bgr, truth_rgb, valid_rgb):
    m = merged_bgr[:, :, ::-1].astype(np.float64)
    finite = np.isfinite(m)
    ok = valid_rgb & finite & (truth_rgb > 0)
    r = m[ok] / truth_rgb[ok]
    s = 1.0 / np.median(r)
    rel = np.abs(s * r - 1.0)
    s2 = np.sum(r) / np.sum(r * r)  # minimises sum (s r - 1)^2
    return {
        "median_rel": float(np.median(rel)),
        "p95_rel": float(np.percentile(rel, 95)),
        "rel_rmse": float(math.sqrt(np.mean((s2 * r - 1.0) ** 2))),
        "scale": float(s),
        "channels_compared": int(ok.sum()),
        "channels_total": int(ok.size),
        "nonfinite": int((~finite).sum()),
    }


# ----------------------------------------------------------------------------------------------
# Memory (Linux /proc) and the timed merge in a child process


def proc_status():
    out = {}
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(("VmRSS:", "VmHWM:")):
                    k, v = line.split(":", 1)
                    out[k] = int(v.split()[0]) * 1024
    except OSError:
        pass
    return out


def reset_peak():
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def merge_child(spec_path):
    """Runs in a fresh process: decode, reset the peak mark, MergeDebevec best of N."""
    with open(spec_path) as f:
        spec = json.load(f)
    if spec.get("threads") is not None:
        cv2.setNumThreads(int(spec["threads"]))
    baseline = proc_status().get("VmRSS")
    t0 = time.perf_counter()
    frames = [decode(p) for p in spec["paths"]]
    if frames[0].dtype == np.uint16:
        frames = [(f >> 8).astype(np.uint8) for f in frames]
    decode_ms = (time.perf_counter() - t0) * 1e3
    times = np.asarray(spec["times"], dtype=np.float32)
    response = np.load(spec["response"]) if spec.get("response") else None
    merge = cv2.createMergeDebevec()
    before = proc_status()  # VmHWM here: the peak of the start and the decoding
    can_reset = reset_peak()
    ms = []
    out = None
    for _ in range(max(1, int(spec["repeats"]))):
        out = None  # free the previous output first, as a loop over captures would
        t0 = time.perf_counter()
        if response is None:
            out = merge.process(frames, times)
        else:
            out = merge.process(frames, times, response)
        ms.append((time.perf_counter() - t0) * 1e3)
    after = proc_status()
    ru = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    frames_bytes = sum(f.nbytes for f in frames)
    result = {
        "ms": ms,
        "best_ms": min(ms),
        "median_ms": float(np.median(ms)),
        "decode_ms": decode_ms,
        "threads": cv2.getNumThreads(),
        "baseline_rss": baseline,
        "rss_before_merge": before.get("VmRSS"),
        "decoded_frames_bytes": frames_bytes,
        "output_bytes": int(out.nbytes),
        "nonfinite": int((~np.isfinite(out)).sum()),
    }
    if can_reset and "VmHWM" in after:
        result["peak_method"] = "VmHWM after clear_refs=5"
        result["merge_peak_rss"] = after["VmHWM"]
    else:
        result["peak_method"] = "ru_maxrss (whole child, not resettable)"
        result["merge_peak_rss"] = ru
    if result["rss_before_merge"] is not None:
        result["merge_extra"] = result["merge_peak_rss"] - result["rss_before_merge"]
    # the child's own whole-life peak (its VmHWM starts afresh at exec; RUSAGE_CHILDREN's
    # ru_maxrss would also count the parent's memory at fork time, copied before the exec)
    if "VmHWM" in before:
        result["decode_peak_rss"] = before["VmHWM"]
        result["child_peak_rss"] = max(before["VmHWM"], result["merge_peak_rss"])
    print(json.dumps(result))


def timed_merge(paths, times, response_path, repeats, threads, out_dir):
    spec = {"paths": paths, "times": times, "response": response_path, "repeats": repeats,
            "threads": threads}
    spec_path = os.path.join(out_dir, "merge_child.json")
    with open(spec_path, "w") as f:
        json.dump(spec, f)
    proc = subprocess.run(
        [sys.executable, os.path.abspath(__file__), "--merge-child", spec_path],
        capture_output=True, text=True,
    )
    if proc.returncode != 0:
        raise RuntimeError(f"merge child failed ({proc.returncode}): {proc.stderr.strip()[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


# ----------------------------------------------------------------------------------------------
# The pipeline


def align_frames(frames, max_bits, exclude_range, cut):
    """AlignMTB::process, step by step: the shifts, the shifted frames, the crop rectangle."""
    align = cv2.createAlignMTB(max_bits, exclude_range, cut)
    pivot = len(frames) // 2
    gray_base = cv2.cvtColor(frames[pivot], cv2.COLOR_RGB2GRAY)
    shifts, out = [], []
    for i, f in enumerate(frames):
        if i == pivot:
            shifts.append((0, 0))
            out.append(f)
            continue
        s = align.calculateShift(gray_base, cv2.cvtColor(f, cv2.COLOR_RGB2GRAY))
        s = (int(s[0]), int(s[1]))
        shifts.append(s)
        out.append(align.shiftMat(f, s))
    h, w = frames[0].shape[:2]
    crop = [0, 0, w, h]
    if cut:
        x0 = max([0] + [s[0] for s in shifts])
        y0 = max([0] + [s[1] for s in shifts])
        x1 = min([0] + [s[0] for s in shifts]) + w
        y1 = min([0] + [s[1] for s in shifts]) + h
        crop = [x0, y0, x1 - x0, y1 - y0]
        out = [np.ascontiguousarray(f[y0:y1, x0:x1]) for f in out]
    return out, shifts, crop, pivot


def valid_mask(frames):
    """RGB mask: the channel is neither 0 nor 255 in at least one frame."""
    ok = np.zeros(frames[0].shape, dtype=bool)
    for f in frames:
        ok |= (f > 0) & (f < 255)
    return ok[:, :, ::-1]


def run(args):
    t_start = time.perf_counter()
    folder = args.folder
    os.makedirs(args.out_dir, exist_ok=True)
    if args.threads is not None:
        cv2.setNumThreads(args.threads)
    names = list_frames(folder)
    times, times_source = load_times(folder, names, args.times)
    names, times, frames, bits = load_frames(folder, names, times)
    h, w = frames[0].shape[:2]
    times32 = np.asarray(times, dtype=np.float32)
    res = {
        "peer": "opencv",
        "version": cv2.__version__,
        "numpy": np.__version__,
        "threads": cv2.getNumThreads(),
        "folder": os.path.abspath(folder),
        "frames": names,
        "times": times,
        "times_source": times_source,
        "size": [w, h],
        "bits": bits,
        "reduced_to_8bit": "code >> 8" if bits == 16 else None,
        "outputs": {},
        "ms": {},
    }

    # 1. alignment
    if args.no_align:
        aligned, res["shifts"], res["crop"] = frames, None, [0, 0, w, h]
        res["pivot"] = len(frames) // 2
    else:
        t0 = time.perf_counter()
        aligned, shifts, crop, pivot = align_frames(frames, args.max_bits, args.exclude_range,
                                                    not args.no_cut)
        res["ms"]["align"] = (time.perf_counter() - t0) * 1e3
        res["pivot"] = pivot
        res["pivot_frame"] = names[pivot]
        res["shifts"] = {n: list(s) for n, s in zip(names, shifts)}
        res["crop"] = crop
        res["align_params"] = {"max_bits": args.max_bits, "exclude_range": args.exclude_range,
                               "cut": not args.no_cut}

    truth = read_truth(args.truth) if args.truth else None
    if truth is not None:
        x, y, cw, ch = res["crop"]
        if truth.shape[:2] != (h, w):
            raise PeerError(f"{args.truth}: {truth.shape[1]} x {truth.shape[0]}, frames {w} x {h}")
        truth = truth[y:y + ch, x:x + cw]
        valid = valid_mask(aligned)
    tresp = true_response(args.true_response) if args.true_response else None
    lo, hi = (int(v) for v in args.response_codes.split(","))

    # 2. response (Debevec)
    response = None
    if args.response == "debevec":
        cal = cv2.createCalibrateDebevec(args.samples, args.lambda_, False)
        t0 = time.perf_counter()
        response = cal.process(aligned, times32)
        res["ms"]["calibrate_debevec"] = (time.perf_counter() - t0) * 1e3
        p = os.path.join(args.out_dir, "response_debevec.csv")
        write_response_csv(p, response)
        res["outputs"]["response_debevec"] = p
        res["calibrate_params"] = {"samples": cal.getSamples(), "lambda": cal.getLambda(),
                                   "random": cal.getRandom()}
        if tresp is not None:
            res["response_error_debevec"] = response_error(response, tresp, lo, hi)

    # 3. merge (Debevec)
    merge = cv2.createMergeDebevec()
    t0 = time.perf_counter()
    merged = merge.process(aligned, times32) if response is None else \
        merge.process(aligned, times32, response)
    res["ms"]["merge_debevec_inline"] = (time.perf_counter() - t0) * 1e3
    p, fmt, note = write_hdr(os.path.join(args.out_dir, "merged_debevec"), merged, args.format)
    res["outputs"]["merged_debevec"] = p
    res["merged_format"] = fmt
    if note:
        res["merged_format_note"] = note
    res["nonfinite_debevec"] = int((~np.isfinite(merged)).sum())
    if truth is not None:
        res["merge_error_debevec"] = merge_error(merged, truth, valid)

    # 4. optional peers
    if args.robertson:
        cal = cv2.createCalibrateRobertson()
        t0 = time.perf_counter()
        resp_r = cal.process(aligned, times32)
        res["ms"]["calibrate_robertson"] = (time.perf_counter() - t0) * 1e3
        p = os.path.join(args.out_dir, "response_robertson.csv")
        write_response_csv(p, resp_r)
        res["outputs"]["response_robertson"] = p
        t0 = time.perf_counter()
        merged_r = cv2.createMergeRobertson().process(aligned, times32, resp_r)
        res["ms"]["merge_robertson"] = (time.perf_counter() - t0) * 1e3
        p, _, _ = write_hdr(os.path.join(args.out_dir, "merged_robertson"), merged_r, args.format)
        res["outputs"]["merged_robertson"] = p
        res["nonfinite_robertson"] = int((~np.isfinite(merged_r)).sum())
        res["robertson_params"] = {"max_iter": cal.getMaxIter(), "threshold": cal.getThreshold()}
        if tresp is not None:
            res["response_error_robertson"] = response_error(resp_r, tresp, lo, hi)
        if truth is not None:
            res["merge_error_robertson"] = merge_error(merged_r, truth, valid)
    if args.mertens:
        mm = cv2.createMergeMertens()
        t0 = time.perf_counter()
        fused = mm.process(aligned)
        res["ms"]["merge_mertens"] = (time.perf_counter() - t0) * 1e3
        p = os.path.join(args.out_dir, "fused_mertens.png")
        cv2.imwrite(p, np.clip(fused * 255.0 + 0.5, 0, 255).astype(np.uint8))
        res["outputs"]["fused_mertens"] = p
        p2 = os.path.join(args.out_dir, "fused_mertens.pfm")
        write_pfm(p2, fused[:, :, ::-1])
        res["outputs"]["fused_mertens_pfm"] = p2
        res["mertens_params"] = {"contrast": mm.getContrastWeight(),
                                 "saturation": mm.getSaturationWeight(),
                                 "exposure": mm.getExposureWeight()}

    # Other merges of the same frames (hdrflow's), measured exactly as OpenCV's: --also NAME=MAP.
    for spec in args.also or []:
        name, _, path = spec.partition("=")
        x, y, cw, ch = res["crop"]
        other = read_truth(path)
        if other.shape[:2] != (h, w):
            raise PeerError(f"{path}: {other.shape[1]} x {other.shape[0]}, frames {w} x {h}")
        other = other[y:y + ch, x:x + cw]
        res.setdefault("also", {})[name] = {
            "nonfinite": int((~np.isfinite(other)).sum()),
            **({"merge_error": merge_error(other[:, :, ::-1], truth, valid)} if truth is not None else {}),
        }

    # 5. MergeDebevec alone, timed, with its memory, in a child process
    if args.repeats > 0:
        rp = None
        if response is not None:
            rp = os.path.join(args.out_dir, "response_debevec.npy")
            np.save(rp, response)
        paths = [os.path.abspath(os.path.join(folder, n)) for n in names]
        res["merge_debevec_timed"] = timed_merge(paths, times, rp, args.repeats, args.threads,
                                                 args.out_dir)
    res["ms"]["total"] = (time.perf_counter() - t_start) * 1e3
    return res


# ----------------------------------------------------------------------------------------------
# A synthetic bracket set with a known truth


def srgb_oetf(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def make_synthetic(folder, size=(256, 192), frames=5, stops=2.0, t0=1.0 / 4000, response="srgb",
                   shift_px=0, bits=8, ext="png", seed=1, noise=0.0, range_stops=6.0, mid_exposure=0.05,
                   displace=True):
    """Writes `frames` brackets `stops` apart (times t0 * 2^(stops k)) of a scene of known
    radiance, their times.json and the truth in the sub-folder truth/ (truth.pfm, truth.npy: RGB
    radiance in the middle frame's pixels; truth.json: times, shifts, response). The scene's log2
    radiance is a horizontal gradient over `range_stops` stops plus fractal noise (six octaves of
    blurred white noise, 2 to 64 px, 1.5 stops standard deviation) plus sharp discs (+-1 stop) and
    bars (-1.3 stops), times a smooth per-channel colour; it spans about 12 stops. Frame code =
    round(max * oetf(radiance * t * k)), k putting the middle frame's median exposure at
    `mid_exposure` (0.05: with 5 frames 2 stops apart, the shortest frame's median is then code ~10
    and the longest's ~230, so that no frame is mostly clipped, which AlignMTB cannot align).
    `noise` > 0 adds Gaussian shot noise (`noise` = its standard deviation at exposure 1) and read
    noise (noise / 20) before quantisation. With `shift_px` > 0, every frame but the middle one has
    its content displaced by a vector drawn in [-shift_px, shift_px]^2 (not (0, 0)); AlignMTB
    should answer the opposite vector; `displace=False` (`--no-displace`) writes the same scene
    and noise without the displacements, the unshifted reference of a shifted set."""
    w, h = size
    rng = np.random.default_rng(seed)
    pad = shift_px
    W, H = w + 2 * pad, h + 2 * pad
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    xx -= pad
    yy -= pad
    # log2 radiance: a gradient, fractal noise (octaves of blurred white noise, 2 to 64 px) and
    # sharp discs and bars, so that every region has structure at every scale
    fy = np.fft.fftfreq(H)[:, None]
    fx = np.fft.fftfreq(W)[None, :]
    k2 = (2 * np.pi) ** 2 * (fx ** 2 + fy ** 2)
    fractal = np.zeros((H, W))
    for octave in range(6):
        sigma = 2.0 * 2 ** octave
        field = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((H, W))) * np.exp(-k2 * sigma ** 2 / 2)))
        fractal += field / (field.std() + 1e-12) * 2 ** (0.3 * octave)
    fractal *= 1.5 / fractal.std()
    log2l = range_stops * (xx / max(w - 1, 1) - 0.5) + fractal
    for _ in range(12):
        cx, cy, r = rng.uniform(0, w), rng.uniform(0, h), rng.uniform(0.03, 0.08) * min(w, h)
        log2l = np.where((xx - cx) ** 2 + (yy - cy) ** 2 < r * r, log2l + rng.choice([-1.0, 1.0]), log2l)
    for _ in range(4):
        x0, bw = rng.uniform(0, w), rng.uniform(2, 6)
        log2l = np.where((xx >= x0) & (xx < x0 + bw), log2l - 1.3, log2l)
    colour = np.stack([
        1.0 + 0.0 * yy,
        0.75 + 0.2 * np.sin(2 * np.pi * yy / max(h, 1)),
        0.55 + 0.35 * (yy / max(h - 1, 1)),
    ], axis=-1)
    radiance = np.exp2(log2l)[..., None] * colour
    truth = radiance[pad:pad + h, pad:pad + w]

    n = frames
    mid = n // 2
    times = [t0 * 2.0 ** (stops * i) for i in range(n)]
    kexp = mid_exposure / (np.median(truth) * times[mid])
    shifts = []
    for i in range(n):
        if i == mid or shift_px == 0:
            shifts.append((0, 0))
            continue
        while True:
            d = tuple(int(v) for v in rng.integers(-shift_px, shift_px + 1, 2))
            if d != (0, 0):
                break
        shifts.append(d if displace else (0, 0))
    maxcode = 255 if bits == 8 else 65535
    dtype = np.uint8 if bits == 8 else np.uint16
    os.makedirs(folder, exist_ok=True)
    names = []
    for i, t in enumerate(times):
        dx, dy = shifts[i]
        view = radiance[pad - dy:pad - dy + h, pad - dx:pad - dx + w]
        x = view * t * kexp
        if noise > 0:
            sd = np.sqrt(noise ** 2 * np.maximum(x, 0) + (noise / 20) ** 2)
            x = x + sd * rng.standard_normal(x.shape)
        if response == "srgb":
            v = srgb_oetf(x)
        elif response == "gamma2.2":
            v = np.power(np.clip(x, 0, 1), 1 / 2.2)
        elif response == "linear":
            v = np.clip(x, 0, 1)
        else:
            raise ValueError(response)
        codes = np.round(v * maxcode).astype(dtype)
        name = f"frame_{i}.{ext}"
        params = [cv2.IMWRITE_JPEG_QUALITY, 95] if ext in ("jpg", "jpeg") else []
        if not cv2.imwrite(os.path.join(folder, name), codes[:, :, ::-1], params):
            raise RuntimeError(f"cannot write {name}")
        names.append(name)
    with open(os.path.join(folder, "times.json"), "w") as f:
        json.dump({n: t for n, t in zip(names, times)}, f, indent=1)
    truth_dir = os.path.join(folder, "truth")  # a sub-folder: not a frame
    os.makedirs(truth_dir, exist_ok=True)
    write_pfm(os.path.join(truth_dir, "truth.pfm"), truth.astype(np.float32))
    np.save(os.path.join(truth_dir, "truth.npy"), truth.astype(np.float32))
    meta = {
        "frames": names, "times": times, "response": response, "bits": bits, "size": [w, h],
        "exposure_scale": float(kexp), "noise": noise, "seed": seed,
        "content_shift": {n: list(s) for n, s in zip(names, shifts)},
        "expected_alignmtb_shift": {n: [-s[0], -s[1]] for n, s in zip(names, shifts)},
    }
    with open(os.path.join(truth_dir, "truth.json"), "w") as f:
        json.dump(meta, f, indent=1)
    return meta


# ----------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", nargs="?", help="the folder of bracket frames")
    ap.add_argument("--times", help="exposure times in seconds, file-name order: 1/1000,1/250,...")
    ap.add_argument("--out-dir", default="capture_opencv_out")
    ap.add_argument("--json", help="also write the JSON result to this file")
    ap.add_argument("--format", choices=("exr", "pfm", "npy"), default="exr",
                    help="merged maps: exr (falls back to pfm when unavailable), pfm or npy")
    ap.add_argument("--response", choices=("debevec", "linear"), default="debevec")
    ap.add_argument("--samples", type=int, default=70)
    ap.add_argument("--lambda", dest="lambda_", type=float, default=10.0)
    ap.add_argument("--max-bits", type=int, default=6)
    ap.add_argument("--exclude-range", type=int, default=4)
    ap.add_argument("--no-cut", action="store_true", help="AlignMTB cut=False (keep the size)")
    ap.add_argument("--no-align", action="store_true")
    ap.add_argument("--robertson", action="store_true")
    ap.add_argument("--mertens", action="store_true")
    ap.add_argument("--repeats", type=int, default=5,
                    help="timed MergeDebevec calls in the child (best and median); 0: none")
    ap.add_argument("--threads", type=int, help="cv2.setNumThreads")
    ap.add_argument("--truth", help="the true radiance (PFM or .npy, RGB, middle frame's pixels)")
    ap.add_argument("--true-response", help="srgb | gamma2.2 | linear | CSV code,R,G,B")
    ap.add_argument("--response-codes", default="10,245")
    ap.add_argument("--also", action="append", metavar="NAME=MAP",
                    help="measure another merge of the same frames (PFM or .npy, RGB) as OpenCV's")
    ap.add_argument("--merge-child", metavar="SPEC", help=argparse.SUPPRESS)
    ap.add_argument("--make-synthetic", metavar="DIR",
                    help="write a synthetic bracket set with its truth to DIR and exit")
    ap.add_argument("--size", default="256x192")
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--stops", type=float, default=2.0)
    ap.add_argument("--synthetic-response", default="srgb", choices=("srgb", "gamma2.2", "linear"))
    ap.add_argument("--shift-px", type=int, default=0)
    ap.add_argument("--no-displace", action="store_true",
                    help="with --shift-px: the same scene without the displacements")
    ap.add_argument("--bits", type=int, choices=(8, 16), default=8)
    ap.add_argument("--ext", default="png", choices=("png", "jpg", "tif"))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise", type=float, default=0.0)
    args = ap.parse_args()

    if cv2 is None:
        print(json.dumps({"error": "OpenCV is not installed: pip install opencv-python-headless"}))
        sys.exit(2)
    if args.merge_child:
        merge_child(args.merge_child)
        return
    if args.make_synthetic:
        w, h = (int(v) for v in args.size.lower().split("x"))
        meta = make_synthetic(args.make_synthetic, (w, h), args.frames, args.stops,
                              response=args.synthetic_response, shift_px=args.shift_px,
                              bits=args.bits, ext=args.ext, seed=args.seed, noise=args.noise,
                              displace=not args.no_displace)
        print(json.dumps(meta))
        return
    if not args.folder:
        ap.error("a folder of frames, or --make-synthetic DIR")
    try:
        res = run(args)
    except PeerError as e:
        print(json.dumps({"error": str(e)}))
        sys.exit(2)
    text = json.dumps(res, indent=1)
    if args.json:
        with open(args.json, "w") as f:
            f.write(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
