# Runs one of the lighting-estimation protocol's sphere scripts (DiffusionLight-evaluation's
# stylelight/{mirror,matte_silver,diffuse}.py) headless on one map, unchanged except for what a CPU
# build of Blender needs:
#
#   blender --background --factory-startup --python bench/peers/blender_probe_setup.py -- \
#       STYLELIGHT_DIR MATERIAL PERCENT SAMPLES MAP.exr OUT_DIR [SEED]
#
# STYLELIGHT_DIR is the protocol's `stylelight/` folder (with `utils/`); MATERIAL is mirror,
# matte_silver or diffuse. The script renders MAP at PERCENT of 1920 x 1080 with SAMPLES samples per
# pixel and writes OUT_DIR/MATERIAL/<map name up to its first '-'>.exr, as the protocol does.
#
# What is changed, through `utils.set_cycles_renderer` (the function every script calls):
# - `prefer_cuda_use=False`: the protocol asks for CUDA; the CPU renders.
# - `use_denoising=False`: Debian's Blender is built without OpenImageDenoise ("Build without
#   OpenImageDenoiser"), so the denoised renders of the protocol cannot be reproduced; the peer
#   renders are the path tracer's own, and their noise is measured from two seeds.
# - `scene.cycles.seed = SEED` (default 0, Cycles' default), so two runs can differ only by noise.
# Everything else (scene, camera, sphere, materials, world) is the script's own code.
import os
import runpy
import sys
import tempfile

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
stylelight, material, percent, samples, map_path, out_dir = args[:6]
seed = int(args[6]) if len(args) > 6 else 0
if material not in ("mirror", "matte_silver", "diffuse"):
    raise SystemExit("MATERIAL must be mirror, matte_silver or diffuse, not %r" % material)

sys.path.insert(0, os.path.abspath(stylelight))
import utils  # noqa: E402  (the protocol's package, as its scripts import it)

original = utils.set_cycles_renderer


def set_cycles_renderer_cpu(scene, camera_object, num_samples, use_denoising=True, use_motion_blur=False,
                            use_transparent_bg=False, prefer_cuda_use=True, use_adaptive_sampling=False):
    original(scene, camera_object, num_samples, use_denoising=False, use_motion_blur=use_motion_blur,
             use_transparent_bg=use_transparent_bg, prefer_cuda_use=False,
             use_adaptive_sampling=use_adaptive_sampling)
    scene.cycles.device = "CPU"
    scene.cycles.seed = seed


utils.set_cycles_renderer = set_cycles_renderer_cpu

# The scripts render every .exr of a folder: give them a folder holding only this map.
with tempfile.TemporaryDirectory() as maps:
    name = os.path.basename(map_path)
    os.symlink(os.path.abspath(map_path), os.path.join(maps, name))
    script = os.path.join(os.path.abspath(stylelight), material + ".py")
    sys.argv = [script, "--", str(int(percent)), str(int(samples)), maps, os.path.abspath(out_dir), "0", "1"]
    runpy.run_path(script, run_name="__main__")
print("blender_probe_setup: rendered", material, "of", map_path, "at", percent, "% with", samples,
      "samples, seed", seed, "Blender", bpy.app.version_string)
