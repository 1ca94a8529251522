#!/usr/bin/env bash
# Several GPUs in one process (`--gpus`): frames per second on 1, 2 and 4 GPUs
# (as many as the machine has) of door.toml and the large-mesh BMW scene at
# 1920x1080, guiding off and sphere, NEE on; and, with the stage equal-time,
# the relMSE each reaches in the same GPU time.
#
#   scripts/multi-gpu-bench.sh RLPT OUTDIR [bench|equal-time|all]
#
# bench:      `rlpt bench --gpus 0,..,N-1 --json` for each scene, guiding and N,
#             $WARMUP warm-up frames (default 64) then $FRAMES measured frames
#             (default 256), into OUTDIR/bench-SCENE-GUIDING-gN.json; the JSON has
#             `frames_per_second` (all frames over the rounds' time: per round the
#             busiest device's GPU time plus the slowest learning pass),
#             `wall_frames_per_second` (over the wall clock) and `devices` (each
#             device's frames and frames per second). N = 1 runs `--gpus 0`, which
#             is the one-GPU renderer and writes the one-GPU report
#             (`msamples_per_s`, `passes`). Then OUTDIR/summary.json: one row per
#             run, {scene, guiding, gpus, frames_per_second, wall_frames_per_second,
#             speedup} (speedup over the same scene and guiding on 1 GPU).
# ($WIDTH and $HEIGHT change the size, for a try on a small machine.)
# equal-time: for each scene and guiding, a reference (unguided, all GPUs,
#             $REF_TIME s of GPU time, default 120), then $TIME s (default 10) on
#             each N with --stats against it (OUTDIR/stats-SCENE-GUIDING-gN.json,
#             relMSE round by round); summary-equal-time.json has the last relMSE
#             of each and its ratio to 1 GPU's.
#
# $SCENES (default scenes) is the folder of door.toml and bmw-m6.toml: on a
# machine without ../shared, a copy whose bmw-m6.toml points at its geometry.
# The BMW scene needs its geometry (scenes/bmw-m6.toml says where); it is left
# out, with a note, where the geometry is missing. Run from the repository root.
set -euo pipefail
rlpt=$1
out=$2
stage=${3:-bench}
mkdir -p "$out"
WARMUP=${WARMUP:-64}
FRAMES=${FRAMES:-256}
TIME=${TIME:-10}
REF_TIME=${REF_TIME:-120}
size=(--width "${WIDTH:-1920}" --height "${HEIGHT:-1080}")

# The usable devices' indices, from `rlpt devices` ("[i] NAME ..." then "usable by rlpt").
mapfile -t usable < <("$rlpt" devices | awk '/^\[[0-9]+\]/ { i = substr($1, 2, length($1) - 2) } /usable by rlpt/ { print i }')
total=${#usable[@]}
if [ "$total" -eq 0 ]; then
    echo "no usable GPU: see \`$rlpt devices\`" >&2
    exit 1
fi
counts=()
for n in 1 2 4; do
    [ "$n" -le "$total" ] && counts+=("$n")
done
echo "$total usable GPU(s) (${usable[*]}); measuring on ${counts[*]}" >&2
# `--gpus` of the first N usable devices.
gpus() {
    local IFS=,
    echo "${usable[*]:0:$1}"
}

scenes=(door)
SCENES=${SCENES:-scenes}
if "$rlpt" info "$SCENES/bmw-m6.toml" >/dev/null 2>&1; then
    scenes+=(bmw-m6)
else
    echo "note: $SCENES/bmw-m6.toml's geometry is missing (scripts/make_bmw_scene.py): measuring door alone" >&2
fi

bench() {
    for scene in "${scenes[@]}"; do
        for guiding in off sphere; do
            for n in "${counts[@]}"; do
                echo "bench $scene guiding $guiding on $n GPU(s)" >&2
                "$rlpt" bench "$SCENES/$scene.toml" "${size[@]}" --guiding "$guiding" --gpus "$(gpus "$n")" \
                    --warmup "$WARMUP" --frames "$FRAMES" --json "$out/bench-$scene-$guiding-g$n.json"
            done
        done
    done
    python3 - "$out" "${scenes[@]}" <<'PY'
import json, sys, os
out, scenes = sys.argv[1], sys.argv[2:]
rows = []
for scene in scenes:
    for guiding in ("off", "sphere"):
        base = None
        for n in (1, 2, 4):
            path = os.path.join(out, f"bench-{scene}-{guiding}-g{n}.json")
            if not os.path.exists(path):
                continue
            r = json.load(open(path))
            if "frames_per_second" in r:  # several GPUs
                fps, wall = r["frames_per_second"], r["wall_frames_per_second"]
            else:  # one GPU: samples per second over the measured frames' time
                fps = r["msamples_per_s"] * 1e6 / r["samples_per_frame"]
                wall = None
            base = base or fps
            rows.append({"scene": scene, "guiding": guiding, "gpus": n, "frames_per_second": fps,
                         "wall_frames_per_second": wall, "speedup": fps / base})
json.dump(rows, open(os.path.join(out, "summary.json"), "w"), indent=2)
for r in rows:
    print(f"{r['scene']:8} {r['guiding']:6} {r['gpus']} GPU(s): {r['frames_per_second']:8.2f} frames/s, x{r['speedup']:.2f}")
PY
}

equal_time() {
    for scene in "${scenes[@]}"; do
        ref="$out/ref-$scene.exr"
        echo "reference of $scene: $REF_TIME s on all $total GPU(s)" >&2
        "$rlpt" render "$SCENES/$scene.toml" "${size[@]}" -o "$ref" --variance "$out/ref-$scene.var.exr" \
            --spp 100000000 --time "$REF_TIME" --seed 7 --gpus "$(gpus "$total")"
        for guiding in off sphere; do
            for n in "${counts[@]}"; do
                echo "equal time: $scene guiding $guiding, $TIME s on $n GPU(s)" >&2
                "$rlpt" render "$SCENES/$scene.toml" "${size[@]}" -o "$out/eq-$scene-$guiding-g$n.exr" \
                    --guiding "$guiding" --spp 100000000 --time "$TIME" --gpus "$(gpus "$n")" \
                    --reference "$ref" --reference-variance "$out/ref-$scene.var.exr" \
                    --stats "$out/stats-$scene-$guiding-g$n.json"
            done
        done
    done
    python3 - "$out" "${scenes[@]}" <<'PY'
import json, sys, os
out, scenes = sys.argv[1], sys.argv[2:]
rows = []
for scene in scenes:
    for guiding in ("off", "sphere"):
        base = None
        for n in (1, 2, 4):
            path = os.path.join(out, f"stats-{scene}-{guiding}-g{n}.json")
            if not os.path.exists(path):
                continue
            last = json.load(open(path))["frames"][-1]
            e = last["rel_mse_debiased"] if last["rel_mse_debiased"] is not None else last["rel_mse"]
            base = base or e
            rows.append({"scene": scene, "guiding": guiding, "gpus": n, "elapsed_ms": last["elapsed_ms"],
                         "spp": last["spp"], "rel_mse": e, "of_one_gpu": e / base})
json.dump(rows, open(os.path.join(out, "summary-equal-time.json"), "w"), indent=2)
for r in rows:
    print(f"{r['scene']:8} {r['guiding']:6} {r['gpus']} GPU(s): relMSE {r['rel_mse']:.3e} ({r['of_one_gpu']:.2f} of 1 GPU's), {r['spp']} spp")
PY
}

case $stage in
bench) bench ;;
equal-time) equal_time ;;
all) bench && equal_time ;;
*) echo "unknown stage $stage: bench, equal-time or all" >&2; exit 2 ;;
esac
