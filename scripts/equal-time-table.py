#!/usr/bin/env python3
"""The equal-time table of BENCHMARKS.md from `scripts/gpu-bench.sh ... equal-time` output.

    scripts/equal-time-table.py OUTDIR SCENE...

Reads OUTDIR/stats-SCENE-G-nee-N.json (`rlpt render --stats`) for G in off / octant /
sphere and N in on / off, and prints one markdown row per run: relMSE at 1 s (the
first frame at or past 1 s of GPU time, where `rlpt render` measures it), at 10 s
(the run's last frame, the first at or past 10 s),
samples per pixel and zero-radiance fraction at the last frame, and the ratio of the
relMSE to the best unguided setting's (NEE on or off) at the same times. Where the
runs were measured against a reference with its variance (`--reference-variance`),
a second line per scene and setting gives the same with the relMSE less the
reference's variance (`rel_mse_debiased`), the error against the true image.
"""
import json
import sys


def load(path):
    with open(path) as f:
        frames = json.load(f)["frames"]
    measured = [fr for fr in frames if fr.get("rel_mse") is not None]
    if not measured:
        sys.exit(f"{path}: no frame has a relMSE (was --reference given?)")
    at_1s = [fr for fr in measured if fr["elapsed_ms"] >= 1000.0]
    if not at_1s:
        sys.exit(f"{path}: no relMSE at or past 1 s")
    last = frames[-1]
    if last.get("rel_mse") is None:
        sys.exit(f"{path}: the last frame has no relMSE")
    return {
        "r1": at_1s[0]["rel_mse"],
        "r10": last["rel_mse"],
        "d1": at_1s[0].get("rel_mse_debiased"),
        "d10": last.get("rel_mse_debiased"),
        "spp": last["spp"],
        "zero": last.get("zero_fraction"),
    }


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out, scenes = sys.argv[1], sys.argv[2:]
    for scene in scenes:
        runs = {}
        for nee in ("on", "off"):
            for g in ("off", "octant", "sphere"):
                runs[(nee, g)] = load(f"{out}/stats-{scene}-{g}-nee-{nee}.json")
        debiased = all(r["d1"] is not None and r["d10"] is not None for r in runs.values())
        for k1, k10, what in [("r1", "r10", "")] + ([("d1", "d10", " (less the reference's variance)")] if debiased else []):
            best1 = min(runs[("on", "off")][k1], runs[("off", "off")][k1])
            best10 = min(runs[("on", "off")][k10], runs[("off", "off")][k10])
            for nee in ("on", "off"):
                for g in ("off", "octant", "sphere"):
                    r = runs[(nee, g)]
                    ratio = "" if g == "off" else f"{r[k1] / best1:.2f} / {r[k10] / best10:.2f}"
                    zero = "" if r["zero"] is None else f"{r['zero']:.3f}"
                    print(
                        f"| {scene}{what} | {nee} | {g} | {r[k1]:.3e} | {r[k10]:.3e} | {r['spp']} | {zero} | {ratio} |"
                    )


if __name__ == "__main__":
    main()
