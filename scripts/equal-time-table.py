#!/usr/bin/env python3
"""The equal-time table of BENCHMARKS.md from `scripts/gpu-bench.sh ... equal-time` output.

    scripts/equal-time-table.py OUTDIR SCENE...

Reads OUTDIR/stats-SCENE-G-nee-N.json (`rlpt render --stats`) for G in off / octant /
sphere and N in on / off, and prints one markdown row per run: relMSE at 1 s (the
first frame at or past 1 s of GPU time, where `rlpt render` measures it) / at 10 s
(the run's last frame, the first at or past 10 s); where the runs were measured
against a reference with its variance (`--reference-variance`), the same less the
reference's variance (`rel_mse_debiased`, the error against the true image);
samples per pixel and zero-radiance fraction at the last frame; and the ratio of
the relMSE to the best unguided setting's (NEE on or off) at the same times, and
of the relMSE less the reference's variance likewise.
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
        best = {k: min(runs[("on", "off")][k], runs[("off", "off")][k]) for k in ("r1", "r10", "d1", "d10")
                if all(r[k] is not None for r in runs.values())}
        for nee in ("on", "off"):
            for g in ("off", "octant", "sphere"):
                r = runs[(nee, g)]
                zero = "" if r["zero"] is None else f"{r['zero']:.3f}"
                ratio = "" if g == "off" else f"{r['r1'] / best['r1']:.2f} / {r['r10'] / best['r10']:.2f}"
                cells = [scene, nee, g, f"{r['r1']:.3e} / {r['r10']:.3e}"]
                if debiased:
                    cells.append(f"{r['d1']:.3e} / {r['d10']:.3e}")
                cells += [str(r["spp"]), zero, ratio]
                if debiased:
                    cells.append("" if g == "off" else f"{r['d1'] / best['d1']:.2f} / {r['d10'] / best['d10']:.2f}")
                print("| " + " | ".join(cells) + " |")

if __name__ == "__main__":
    main()
