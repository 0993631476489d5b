#!/usr/bin/env python3
"""Mitsuba 3 peer: the diffuse sphere under the environment map, rendered by Mitsuba's `direct`
integrator (emitter sampling + BSDF sampling combined with MIS), framed and lit exactly as
hdrflow's RelightSphere so that the images compare pixel for pixel.

Scene: `sphere` (radius 1 at the origin) with a `diffuse` BSDF (rgb reflectance = albedo); an
`envmap` emitter built from the same lat-long map (see "Map conversion"); an `orthographic`
sensor at 10 view_dir looking at the origin with hdrflow's screen up, whose default [-1, 1]^2
screen inscribes the unit sphere; `hdrfilm` S x S, `box` reconstruction filter, rgb; integrator
`direct` with `hide_emitters` (the background stays black as in hdrflow). Samplers
`independent` and `ldsampler`; spp = each of --counts (ldsampler rounds up to a power of two).

Map conversion (verified numerically, see README.md and --check):
- Mitsuba's envmap maps a direction v to u = atan2(v.x, -v.z) / (2 pi) (mod 1), v = acos(v.y) / pi;
  hdrflow's phi = atan2(-d.x, d.z) = 2 pi u - pi: Mitsuba's column = ours + W/2 (np.roll by W/2).
- Mitsuba interpolates bilinearly (the envmap has no filter_type) between grid values placed at
  u = (x + 0.5) / W (a half-texel shift) and theta = pi y / (H - 1), i.e. its first and last rows
  sit ON the poles, not half a texel inside as ours do. Passing the rolled map as is ("naive")
  therefore shifts rows by up to half a texel and blurs texel edges: a converged bias of ~0.2%
  relative RMSE on the test map. By default the map is resampled onto Mitsuba's grid aligned with
  ours (`--env-upsample K`, default 1): (K W) x (K H + 1) values, rolled by half the width, with
  our texel edges falling exactly halfway between columns and exactly on rows whose value is the
  mean of the two texels they separate. Mitsuba's bilinear map is then our piecewise-constant map
  blurred symmetrically about each texel edge, over 1/K texel on either side: nothing is shifted
  and every texel's energy is kept (to the sin(theta) weighting), so the irradiance differs at
  second order only. Converged bias on the test map:
  K=1 0.03%, K=2 0.015%, K=4 ~0.01% (at the accuracy of the quadrature used to measure it).
  K=1 renders as fast as the naive map; K=4 made renders ~60% slower here (a 16x larger texture
  and sampling hierarchy), hence the default K=1.
  `--env-upsample 0` passes the naive rolled map (what a user would do without thinking).
- Film orientation: Mitsuba's film rows go top to bottom and its x axis matches hdrflow's
  (look_at with hdrflow's up): no flip is needed (--check prints the mirrored alternatives' errors).

Each variant runs in its own child process, so a variant that crashes (llvm_ad_rgb with LLVM < 19
aborts in LLVM's instruction selection) is recorded in "skipped" without losing the others.

Seeds: `--seeds 1,2,...` renders every (variant, sampler, count) once per seed (default: the
single `--seed`), one image and one results.json entry per seed, each with its `seed`. The seed
is `mi.render`'s: independent random streams for `independent`, a new scramble for `ldsampler`.

scalar_rgb and llvm_ad_rgb run the same algorithm (same distribution of images); scalar_rgb is
about 12x slower. The LLVM variants run first; when one of them rendered, scalar_rgb renders only
the counts <= --scalar-max-spp (default 256; the others are listed in "skipped"), so that 8 seeds
at 4096 spp do not cost many minutes per map. Without a working LLVM variant scalar_rgb renders
every count (subject to --max-render-s).

Timing per (variant, sampler, count): the scene is loaded once per (variant, sampler)
(`scene_load_ms`); each count is rendered once untimed (warm-up: JIT compilation for LLVM), then
`--repeats` times, on the FIRST seed only, and the median of `mi.render(scene, spp=N, seed=seed)`
+ conversion to a NumPy array is reported (`ms`). The other seeds are rendered once, untimed
(`ms` null: timing does not depend on the seed). Long renders are kept affordable on a small machine: fewer repeats when
repeats x one render would exceed --budget-s (the number used is reported as `repeats`), no
warm-up when the render is predicted (from the previous count, linearly in spp) to take longer
than --warmup-below-s (`warmup_ms` is then null: a warm-up only hides one-off costs, negligible
against such a render), and a count predicted to take longer than --max-render-s is not rendered
but listed in "skipped" with its variant, sampler and count.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pfm_common as pc  # noqa: E402


# ----------------------------------------------------------------------------------------------
# Map conversion (pure NumPy)


def mitsuba_envmap_grid(env, k):
    """The float32 (H', W', 3) array to pass to Mitsuba's envmap so that, in world space, it
    shows hdrflow's map `env` (H, W, 3).

    k == 0: the naive conversion, np.roll(env, W/2) (exact for the columns when W is even; rows
    land at Mitsuba's theta = pi y / (H - 1) instead of pi (y + 0.5) / H).
    k >= 1: the aligned resampling (K W) x (K H + 1) described in the module documentation.
    """
    h, w = env.shape[:2]
    if k <= 0:
        if w % 2:
            raise ValueError("--env-upsample 0 needs an even map width (a roll by W/2 texels)")
        return np.ascontiguousarray(np.roll(env, w // 2, axis=1)).astype(np.float32)
    wm, hm = k * w, k * h + 1
    # Column xm is centred on u = (xm + 0.5) / wm, i.e. hdrflow's phi = 2 pi u - pi.
    phi = (2.0 * math.pi * (np.arange(wm) + 0.5) / wm - math.pi) % (2.0 * math.pi)
    x = np.clip(np.floor(phi / (2.0 * math.pi) * w).astype(np.int64), 0, w - 1)
    cols = env[:, x]
    # Row ym sits at theta = pi ym / (k h): inside texel row (ym // k) unless ym is a multiple of
    # k, where it lies on the edge between rows ym/k - 1 and ym/k (poles: the edge row itself).
    ym = np.arange(hm)
    lo = np.clip((ym - 1) // k, 0, h - 1)
    hi = np.clip(ym // k, 0, h - 1)
    grid = 0.5 * (cols[lo].astype(np.float64) + cols[hi])
    return np.ascontiguousarray(grid.astype(np.float32))


# ----------------------------------------------------------------------------------------------
# Worker: one variant, in its own process


def scene_dict(mi, grid, size, view, albedo, sampler, max_spp):
    v, right, up = view
    to_world = mi.ScalarTransform4f().look_at(origin=(10.0 * v).tolist(), target=[0.0, 0.0, 0.0], up=up.tolist())
    return {
        "type": "scene",
        "integrator": {"type": "direct", "hide_emitters": True},
        "sensor": {
            "type": "orthographic",
            "to_world": to_world,
            "sampler": {"type": sampler, "sample_count": max_spp},
            "film": {
                "type": "hdrfilm",
                "width": size,
                "height": size,
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },
        },
        "envmap": {"type": "envmap", "bitmap": mi.Bitmap(grid)},
        "sphere": {
            "type": "sphere",
            "center": [0.0, 0.0, 0.0],
            "radius": 1.0,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(albedo)}},
        },
    }


def render_np(mi, scene, spp, seed):
    img = mi.render(scene, spp=spp, seed=seed)
    return np.array(img, dtype=np.float32)  # (S, S, 3), row 0 at the top: hdrflow's framing


def worker(args):
    import mitsuba as mi

    mi.set_variant(args.worker)
    variant = args.worker
    if args.threads:
        import drjit as dr

        dr.set_thread_count(args.threads)
    counts = pc.parse_counts(args.counts)
    seeds = pc.parse_seeds(args.seeds, args.seed)
    view = pc.sphere_view(*pc.parse_pair(args.view))
    albedo = pc.parse_triple(args.albedo)

    t0 = time.perf_counter()
    env = pc.read_pfm(args.env)
    load_ms = (time.perf_counter() - t0) * 1e3
    if env.shape[2] == 1:
        env = np.repeat(env, 3, axis=2)
    env = env[:, :, :3]
    t0 = time.perf_counter()
    grid = mitsuba_envmap_grid(env, args.env_upsample)
    prep_ms = (time.perf_counter() - t0) * 1e3

    ref = None
    if args.check:
        ref = pc.read_pfm(os.path.join(args.out_dir, "reference.pfm"))
        inner = pc.inner_mask(args.size)

    results, skipped = [], []
    for sampler in args.samplers.split(","):
        sampler = sampler.strip()
        t0 = time.perf_counter()
        scene = mi.load_dict(scene_dict(mi, grid, args.size, view, albedo, sampler, max(counts)))
        scene_ms = (time.perf_counter() - t0) * 1e3
        pc.eprint(f"mitsuba {variant} {sampler}: scene loaded in {scene_ms:.0f} ms")
        last = None  # (count, ms) of the previous count, to predict the next render's time
        for count in counts:
            if args.worker_max_spp and count > args.worker_max_spp:
                why = (
                    f"{variant} renders only up to --scalar-max-spp {args.worker_max_spp} when an LLVM variant "
                    "works (same distribution, ~12x slower)"
                )
                pc.eprint(f"mitsuba {variant} {sampler} spp={count}: skipped: {why}")
                skipped.append({"variant": variant, "sampler": sampler, "count": count, "why": why})
                continue
            predicted_s = last[1] * 1e-3 * count / last[0] if last else 0.0
            if predicted_s > args.max_render_s:
                why = f"predicted {predicted_s:.0f} s per render > --max-render-s {args.max_render_s:g}"
                pc.eprint(f"mitsuba {variant} {sampler} spp={count}: skipped: {why}")
                skipped.append({"variant": variant, "sampler": sampler, "count": count, "why": why})
                continue
            for i, seed in enumerate(seeds):
                r = {
                    "strategy": f"mitsuba {variant} direct {sampler}",
                    "variant": variant,
                    "sampler": sampler,
                    "count": count,
                    "seed": seed,
                    "ms": None,
                    "scene_load_ms": scene_ms,
                }
                if i == 0:
                    warm_ms = None
                    if predicted_s <= args.warmup_below_s:
                        t0 = time.perf_counter()
                        render_np(mi, scene, count, seed)  # warm-up, untimed
                        warm_ms = (time.perf_counter() - t0) * 1e3
                    one_s = warm_ms * 1e-3 if warm_ms is not None else predicted_s
                    repeats = max(1, min(args.repeats, int(args.budget_s / max(one_s, 1e-6))))
                    times = []
                    img = None
                    for _ in range(repeats):
                        t0 = time.perf_counter()
                        img = render_np(mi, scene, count, seed)
                        times.append((time.perf_counter() - t0) * 1e3)
                    last = (count, float(np.median(times)))
                    r.update({"ms": float(np.median(times)), "repeats": repeats, "warmup_ms": warm_ms})
                    line = f"{r['strategy']:42s} spp={count:6d} seed {seed}  {r['ms']:10.1f} ms (x{repeats})"
                else:
                    img = render_np(mi, scene, count, seed)  # untimed: timing does not depend on the seed
                    line = f"{r['strategy']:42s} spp={count:6d} seed {seed}  (untimed)"
                name = f"mitsuba_{variant}_direct_{sampler}_{count}_seed{seed}.pfm"
                pc.write_pfm(os.path.join(args.out_dir, name), img)
                r["image"] = name
                if ref is not None:
                    r["rel_rmse_inner"] = pc.relative_rmse(img, ref, inner)
                    line += f"  rel RMSE inner {r['rel_rmse_inner']:.4%}"
                    if count == max(counts) and i == 0:
                        r["orientation_check"] = {
                            "as_is": r["rel_rmse_inner"],
                            "mirror_x": pc.relative_rmse(img[:, ::-1], ref, inner),
                            "mirror_y": pc.relative_rmse(img[::-1], ref, inner),
                            "rotate_180": pc.relative_rmse(img[::-1, ::-1], ref, inner),
                        }
                        oc = r["orientation_check"]
                        line += (
                            f"  [mirrored x {oc['mirror_x']:.1%}, y {oc['mirror_y']:.1%},"
                            f" 180 {oc['rotate_180']:.1%}]"
                        )
                print(line, flush=True)
                results.append(r)
    out = {
        "variant": variant,
        "version": mi.__version__,
        "load_ms": load_ms,
        "prep_ms": prep_ms,
        "envmap_grid": [int(grid.shape[1]), int(grid.shape[0])],
        "results": results,
        "skipped": skipped,
    }
    with open(os.path.join(args.out_dir, f".mitsuba_{variant}.json"), "w") as f:
        json.dump(out, f)


# ----------------------------------------------------------------------------------------------
# Driver


def failure_reason(rc, stderr):
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    for key in ("LLVM ERROR", "Error", "error", "Exception"):
        for ln in lines:
            if key in ln:
                return f"exit status {rc}: {ln[:300]}"
    return f"exit status {rc}: {lines[-1][:300] if lines else 'no output'}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", required=True, help="lat-long map, PFM (as written by hdrflow)")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--counts", default="16,64,256,1024,4096", help="samples per pixel")
    ap.add_argument("--view", default="90,90", help="theta,phi in degrees")
    ap.add_argument("--albedo", default="0.8", help="one value or r,g,b")
    ap.add_argument("--seed", type=int, default=1, help="the seed when --seeds is not given")
    ap.add_argument("--seeds", help="comma-separated seeds, one image each (the first is timed); overrides --seed")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--variants", default="scalar_rgb,llvm_ad_rgb")
    ap.add_argument("--samplers", default="independent,ldsampler")
    ap.add_argument("--env-upsample", type=int, default=1, help="aligned resampling factor K; 0 = naive roll")
    ap.add_argument(
        "--budget-s", type=float, default=60.0, help="fewer repeats when repeats x warm-up time would exceed this"
    )
    ap.add_argument(
        "--max-render-s",
        type=float,
        default=300.0,
        help="skip a count whose render is predicted (from the previous count) to take longer than this",
    )
    ap.add_argument(
        "--warmup-below-s",
        type=float,
        default=10.0,
        help="no untimed warm-up render when the render is predicted to take longer than this",
    )
    ap.add_argument("--threads", type=int, help="Dr.Jit worker threads (default: one per core)")
    ap.add_argument("--child-timeout-s", type=float, default=7200.0)
    ap.add_argument("--check", action="store_true", help="compare with the exact reference (small maps)")
    ap.add_argument(
        "--scalar-max-spp",
        type=int,
        default=256,
        help="when an LLVM variant works, scalar_rgb renders only counts up to this (0: no limit)",
    )
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--worker-max-spp", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()

    if args.worker:
        worker(args)
        return

    os.makedirs(args.out_dir, exist_ok=True)
    if args.check:
        env = pc.read_pfm(args.env)
        if env.shape[2] == 1:
            env = np.repeat(env, 3, axis=2)
        ref = pc.reference_sphere(
            env[:, :, :3], args.size, pc.sphere_view(*pc.parse_pair(args.view)), pc.parse_triple(args.albedo)
        )
        pc.write_pfm(os.path.join(args.out_dir, "reference.pfm"), ref)

    version = None
    results, skipped, meta = [], [], {}
    variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    # LLVM variants first: when one renders, scalar_rgb (same images, ~12x slower) is limited to
    # counts <= --scalar-max-spp.
    variants.sort(key=lambda v: not v.startswith("llvm"))
    llvm_rendered = False
    for variant in variants:
        cmd = [sys.executable, os.path.abspath(__file__), "--worker", variant] + sys.argv[1:]
        if variant.startswith("scalar") and llvm_rendered and args.scalar_max_spp > 0:
            cmd += ["--worker-max-spp", str(args.scalar_max_spp)]
        side = os.path.join(args.out_dir, f".mitsuba_{variant}.json")
        if os.path.exists(side):
            os.remove(side)
        try:
            proc = subprocess.run(cmd, stdout=None, stderr=subprocess.PIPE, text=True, timeout=args.child_timeout_s)
            rc, err = proc.returncode, proc.stderr
        except subprocess.TimeoutExpired as e:
            rc, err = "timeout", (e.stderr or b"").decode(errors="replace") if isinstance(e.stderr, bytes) else ""
        # Progress lines from the child's stderr (not the LLVM dumps) go to ours.
        for ln in err.splitlines():
            if ln.startswith("mitsuba "):
                pc.eprint(ln)
        if rc == 0 and os.path.exists(side):
            with open(side) as f:
                part = json.load(f)
            os.remove(side)
            version = part["version"]
            results += part["results"]
            skipped += part["skipped"]
            meta[variant] = {k: part[k] for k in ("load_ms", "prep_ms", "envmap_grid")}
            llvm_rendered = llvm_rendered or (variant.startswith("llvm") and bool(part["results"]))
        else:
            why = failure_reason(rc, err)
            if variant.startswith("llvm"):
                why += " (LLVM variants need libLLVM >= 19: apt-get install libllvm19)"
            pc.eprint(f"mitsuba {variant}: skipped: {why}")
            skipped.append({"variant": variant, "why": why})

    if version is None:
        try:
            import mitsuba as mi

            version = mi.__version__
        except Exception as e:  # noqa: BLE001
            version = f"unavailable ({e})"
    out = {
        "peer": "mitsuba",
        "version": version,
        "env_upsample": args.env_upsample,
        "seeds": pc.parse_seeds(args.seeds, args.seed),
        "variants": meta,
        "results": results,
        "skipped": skipped,
    }
    if args.check:
        out["reference"] = "reference.pfm"
    pc.write_results(args.out_dir, out)


if __name__ == "__main__":
    main()
