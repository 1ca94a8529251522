#!/usr/bin/env bash
# The measurements behind BENCHMARKS.md, in one go on a GPU machine.
#
#   scripts/gpu-bench.sh RLPT OUTDIR [timing|equal-time SCENE...]
#
# timing:     `rlpt bench` (GPU timestamps) of the seed's three experiments and
#             door.toml, guiding off / octant / sphere, NEE on; 8 warm-up frames
#             (guiding learns), 32 measured frames of 64 spp at the scene's size.
# equal-time: for each SCENE, a reference (unguided, NEE on, 40 s of GPU time),
#             then 10 s of GPU time for each of off / octant / sphere x NEE on /
#             off with --stats against it (relMSE frame by frame: read at 1 s and
#             10 s), and a plot.
set -euo pipefail
rlpt=$1
out=$2
stage=${3:-timing}
shift 3 || true
mkdir -p "$out"
case "$stage" in
timing)
    "$rlpt" devices >"$out/devices.txt"
    for s in seed-exp1 seed-exp2 seed-exp3 door; do
        for g in off octant sphere; do
            "$rlpt" bench "scenes/$s.toml" --frames 32 --warmup 8 --guiding "$g" --nee on \
                --json "$out/bench-$s-$g.json" | tee "$out/bench-$s-$g.txt"
        done
    done
    ;;
equal-time)
    for s in "$@"; do
        "$rlpt" render "scenes/$s.toml" -o "$out/ref-$s.exr" --spp 100000000 --time 40 --seed 7
        stats=()
        for nee in on off; do
            for g in off octant sphere; do
                "$rlpt" render "scenes/$s.toml" -o "$out/$s-$g-nee-$nee.exr" --spp 100000000 --time 10 \
                    --guiding "$g" --nee "$nee" --reference "$out/ref-$s.exr" \
                    --stats "$out/stats-$s-$g-nee-$nee.json"
                stats+=("$out/stats-$s-$g-nee-$nee.json")
            done
        done
        "$rlpt" plot "${stats[@]}" -o "$out/convergence-$s.png"
    done
    ;;
*)
    echo "unknown stage $stage: timing or equal-time" >&2
    exit 2
    ;;
esac
