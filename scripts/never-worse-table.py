#!/usr/bin/env python3
"""The never-worse table of BENCHMARKS.md from `scripts/gpu-bench.sh ... never-worse` output.

    scripts/never-worse-table.py OUTDIR

Reads OUTDIR/stats-SCENE-WxH-MODE-SEED.json (`rlpt render --stats` against a
reference with its variance) and prints one markdown row per scene and size: for
each mode but `off`, its relMSE less the reference's variance over off's at 0.1 s
(the first mark at or past 100 ms of GPU time) and at the run's end (1 s), the mean
over the seeds; per sample (the ratio at the end times the mode's samples over
off's); and the samples per pixel at the end, off / mode (the first seed's).

A run whose first frames took over 1.3 times as long per frame as the other
seed's run of the same mode, or whose unguided frames after them (every frame of
`off`) took over 1.05 times as long on average (the GPU's clocks slow some runs,
at the start or on the way; timestamps time every frame), is named on stderr and
left out of its mode's means (with its off run's seed), which then say which
seeds they hold, e.g. `(seed 2)`; where no seed is left, all count and the row is
marked `slow`: rerun it.
"""
import functools
import glob
import json
import os
import re
import sys


@functools.lru_cache(maxsize=None)
def frames_of(path):
    """A stats file's frames, read once."""
    with open(path) as f:
        return json.load(f)["frames"]


def mark(path, ms):
    """(relMSE less the reference's variance, spp) at the first frame at or past `ms`, or the last."""
    frames = [fr for fr in frames_of(path) if fr.get("rel_mse_debiased") is not None]
    if not frames:
        sys.exit(f"{path}: no frame has a relMSE less the reference's variance (--reference-variance?)")
    later = [fr for fr in frames if fr["elapsed_ms"] >= ms] if ms is not None else []
    fr = later[0] if later else frames[-1]
    return fr["rel_mse_debiased"], fr["spp"]


def early_ms(path):
    """GPU time per frame over a run's first five marks."""
    frames = frames_of(path)
    fr = frames[min(4, len(frames) - 1)]
    return fr["elapsed_ms"] / max(fr.get("frame", 1), 1)


def unguided_ms(path, every):
    """Mean GPU time of a run's unguided frames past its first five marks and
    before its last (which may be cut short); `every` where all are unguided
    (off). None where it has none."""
    frames = frames_of(path)
    total, n, before = 0.0, 0, 0
    for i, fr in enumerate(frames):
        count, before = fr["frame"] - before, fr["frame"]
        if 5 <= i < len(frames) - 1 and fr.get("gpu_ms") and (every or fr.get("unguided")):
            total, n = total + fr["gpu_ms"], n + count
    return total / n if n else None


def slow_seeds(seeds, mode):
    """The seeds of {seed: path} whose first frames ran over 1.3 times another's,
    or whose unguided frames after them over 1.05 times another's."""
    ms = {k: early_ms(p) for k, p in seeds.items()}
    slow = {k for k in ms if any(ms[k] > 1.3 * ms[j] for j in ms if j != k)}
    later = {k: unguided_ms(p, mode == "off") for k, p in seeds.items()}
    later = {k: v for k, v in later.items() if v}
    slow |= {k for k in later if any(later[k] > 1.05 * later[j] for j in later if j != k)}
    return sorted(slow)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    runs = {}
    pattern = re.compile(r"stats-(.+)-(\d+x\d+)-([a-z]+)-(\d+)\.json$")
    for path in glob.glob(os.path.join(out, "stats-*.json")):
        m = pattern.search(os.path.basename(path))
        if m:
            scene, size, mode, seed = m.groups()
            runs.setdefault((scene, size), {}).setdefault(mode, {})[int(seed)] = path
    if not runs:
        sys.exit(f"{out}: no stats-SCENE-WxH-MODE-SEED.json")
    modes = sorted({m for r in runs.values() for m in r if m != "off"})
    head = " | ".join(f"{m}: 0.1 s / 1 s | {m} per sample" for m in modes)
    print(f"| scene | size | {head} | spp at 1 s, off / {' / '.join(modes)} |")
    print("|---|---|" + "---|---|" * len(modes) + "---|")
    for (scene, size), r in sorted(runs.items()):
        slow = [(m, k) for m in r for k in slow_seeds(r[m], m)]
        for m, k in slow:
            print(f"{scene} {size}: {m}, seed {k}: its frames ran slow", file=sys.stderr)
        off = r.get("off", {})
        cells, spp = [], [str(mark(off[min(off)], None)[1]) if off else "-"]
        slow_all = False
        for m in modes:
            seeds = sorted(set(r.get(m, {})) & set(off))
            fast = [k for k in seeds if (m, k) not in slow and ("off", k) not in slow]
            held = ""
            if fast and fast != seeds:
                seeds, held = fast, f" (seed {', '.join(map(str, fast))})"
            elif seeds and not fast:
                slow_all = True
            if not seeds:
                cells += ["-", "-"]
                spp.append("-")
                continue
            ratios = {}
            for at in (100.0, None):
                ratios[at] = sum(mark(r[m][k], at)[0] / mark(off[k], at)[0] for k in seeds) / len(seeds)
            per_sample = sum(
                mark(r[m][k], None)[0] / mark(off[k], None)[0] * mark(r[m][k], None)[1] / mark(off[k], None)[1]
                for k in seeds
            ) / len(seeds)
            cells += [f"{ratios[100.0]:.3f} / {ratios[None]:.3f}{held}", f"{per_sample:.2f}"]
            spp.append(str(mark(r[m][seeds[0]], None)[1]))
        mark_slow = " (slow)" if slow_all else ""
        print(f"| {scene}{mark_slow} | {size} | {' | '.join(cells)} | {' / '.join(spp)} |")


if __name__ == "__main__":
    main()
