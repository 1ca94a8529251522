"""Mitsuba 3 on the large-mesh benchmark scene of BENCHMARKS.md: the BMW M6's
PLYs as they are (world space), every mesh diffuse with albedo 0.5, a uniform
sky of radiance 1, the camera of bmw-m6.pbrt, 8 bounces, no Russian roulette.

    python3 scripts/mitsuba_bmw.py GEOMETRY_DIR OUT.exr [--spp 64] [--frames 5] [--width 1400 --height 1000]

Prints the time of each 64-spp frame (warm: the first, which compiles kernels,
is reported apart) and Msamples/s; writes the last frame's image, which
compares with rlpt's pixel for pixel (`rlpt compare`).
"""
import argparse
import glob
import json
import os
import sys
import time

import drjit as dr
import mitsuba as mi

ap = argparse.ArgumentParser()
ap.add_argument("geometry")
ap.add_argument("out")
ap.add_argument("--spp", type=int, default=64)
ap.add_argument("--frames", type=int, default=5)
ap.add_argument("--width", type=int, default=1400)
ap.add_argument("--height", type=int, default=1000)
ap.add_argument("--bounces", type=int, default=8)
ap.add_argument("--json", default=None)
args = ap.parse_args()

mi.set_variant("cuda_ad_rgb")
plys = sorted(glob.glob(os.path.join(args.geometry, "*.ply")))
if not plys:
    sys.exit(f"no .ply files in {args.geometry}")
scene = {
    "type": "scene",
    "integrator": {
        "type": "path",
        # Mitsuba's max_depth counts the camera ray's vertex: 8 bounces are depth 9.
        "max_depth": args.bounces + 1,
        "rr_depth": 10000,
    },
    "sensor": {
        "type": "perspective",
        "fov": 30.0,
        "fov_axis": "y",
        "to_world": mi.ScalarTransform4f().look_at(origin=[-11, 0.8, 5], target=[-2, -0.5, 0], up=[0, 1, 0]),
        "film": {"type": "hdrfilm", "width": args.width, "height": args.height, "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": args.spp},
    },
    "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
}
# Two-sided, as rlpt's materials reflect on both sides (Mitsuba's diffuse is black from behind).
grey = {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}}}
for i, p in enumerate(plys):
    scene[f"mesh{i}"] = {"type": "ply", "filename": p, "bsdf": grey, "face_normals": True}
t0 = time.perf_counter()
s = mi.load_dict(scene)
load_s = time.perf_counter() - t0
times = []
img = None
for f in range(args.frames + 1):
    dr.sync_thread()
    t0 = time.perf_counter()
    img = mi.render(s, spp=args.spp, seed=f)
    dr.eval(img)
    dr.sync_thread()
    times.append(time.perf_counter() - t0)
samples = args.width * args.height * args.spp
warm = times[1:]
best = min(warm)
mean = sum(warm) / len(warm)
print(f"mitsuba {mi.__version__} cuda_ad_rgb path: load {load_s:.2f} s, first frame {times[0]*1e3:.1f} ms (compiles)")
print(f"  warm {args.spp}-spp frames: mean {mean*1e3:.1f} ms, best {best*1e3:.1f} ms, "
      f"{samples/mean/1e6:.1f} Msamples/s")
arr = mi.TensorXf(img).numpy()[:, :, :3]
mi.Bitmap(arr.copy()).write(args.out)
if args.json:
    with open(args.json, "w") as fh:
        json.dump({"mitsuba": mi.__version__, "spp": args.spp, "width": args.width, "height": args.height,
                   "frame_ms": [t * 1e3 for t in times], "warm_mean_ms": mean * 1e3, "warm_best_ms": best * 1e3,
                   "msamples_per_s": samples / mean / 1e6, "load_s": load_s}, fh, indent=1)
