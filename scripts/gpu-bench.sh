#!/usr/bin/env bash
# The measurements behind BENCHMARKS.md, in one go on a GPU machine.
#
#   scripts/gpu-bench.sh RLPT OUTDIR [timing|equal-time SCENE...|settings SCENE...|learning-rate SCENE...|
#                                     deep-guiding [SCENE...]|counters|q-targets SCENE...|floor SCENE...|
#                                     learning-frames SCENE...|never-worse [SCENE:WxH...]]
#
# timing:     `rlpt bench` (GPU timestamps) of the seed's three experiments and
#             door.toml, guiding off / octant / sphere, NEE on; 32 measured
#             frames of 64 spp at the scene's size after 640 warm-up frames, past
#             the last change of the recording stride (guide::RecordSchedule) on
#             every scene here but door, whose default table with roulette (20x40
#             bins) changes stride last at frame 2048 (3840 before recording
#             started at stride 8) and is measured after 3872
#             (bench-S-G); and, guided, after 8 (bench-early-S-G), where more rows
#             record.
# equal-time: for each SCENE, a reference (unguided, NEE on, 40 s of GPU time)
#             with its per-pixel variance, then 10 s of GPU time for each of off /
#             octant / sphere x NEE on / off with --stats against it (relMSE frame
#             by frame, and less the reference's variance: read at 1 s and 10 s),
#             and a plot.
# settings:   for each SCENE, a reference (unguided, NEE on, 30 s), then 2 s of
#             GPU time per guiding setting (guided fraction, bins, and for door
#             the grid), NEE on, with --stats against it: which settings pay.
# learning-rate: for each SCENE, what equal-time runs, and every guided setting
#             again with Q's learning-rate exponent 1 and 0.75 (stats-wW-...),
#             against the same reference.
# deep-guiding: for each SCENE (default door and smallpt, the scenes with Russian
#             roulette), a reference with its variance, then 10 s each, NEE on, of:
#             unguided; sphere guiding at the defaults (with roulette every vertex
#             guided, 20x40 bins since 79fb864, 12x24 before); the former defaults (the first 2 vertices, 8x16
#             bins); every vertex at 8x16 and at 16x32 bins; and their frame times
#             (bench after 3872 warm-up frames, past door's last change of stride).
# counters:   `rlpt bench` of the four scenes with --counters on, paths (the
#             kernel `render --stats` runs) and off, guiding off and sphere: what
#             the frame counters cost a frame (door guided after 3872 warm-up frames).
# q-targets:  for each SCENE, a reference with its variance (as equal-time), then
#             10 s each, NEE on, of unguided and of octant and sphere guiding with
#             MIS-weighted and with full Q-learning targets (--q-targets mis|full,
#             stats-S-G-T), against it; and the same settings' frame times
#             (bench-q-S-G-T, after 640 warm-up frames, 1408 for smallpt, 3872 for door).
# floor:      for each SCENE, a reference with its variance (as equal-time), then
#             10 s each, NEE on, of unguided and of sphere guiding at every
#             exploration floor in $FLOORS (default "0.25 0.15 0.1 0.05") for each
#             bin layout in $BINS (default "default", the scene's; e.g. "default
#             16x32"), stats-S-B-fF, against it.
# learning-frames: for each SCENE, a reference with its variance (as equal-time),
#             then 10 s each, NEE on, of unguided and of sphere guiding with the
#             image started after each count of learning frames in $LEARNING
#             (default "0 4 8"; 4 is the default with roulette), stats-S-lN.
# never-worse: for each SCENE:WxH (default: every shipped scene at 64x40 and at
#             its own size, the furnaces at 64x64), a reference (unguided, seed
#             77, 2 s of GPU time below 100000 pixels, else 6 s, or $REF_TIME) with its
#             variance, or the one in $REFS (a former OUTDIR) where there is one;
#             one 0.2 s render per mode to warm the GPU; then $TIME s (default 1) each, the
#             seeds in $SEEDS (default "1 2"), of every mode in $MODES (default "off sphere"; "auto" and
#             "never" are sphere with --unguided-frames auto and never; sphere
#             alone takes render's default), stats-S-WxH-M-K.json. With
#             $RLPT_B, a second binary renders the modes in $MODES_B (default
#             "sphere") right after each seed's, as modes bM (stats-S-WxH-bM-K),
#             against the same reference: an A/B in one run. Scene files come
#             from $SCENES (default scenes/). Table: scripts/never-worse-table.py OUTDIR.
set -euo pipefail
rlpt=$1
out=$2
stage=${3:-timing}
shift 3 || true
mkdir -p "$out"
# The reference of SCENE with its per-pixel variance: unguided, NEE on, 40 s of
# GPU time, seed 7 ($out/ref-SCENE.exr and .var.exr).
reference() {
    "$rlpt" render "scenes/$1.toml" -o "$out/ref-$1.exr" --spp 100000000 --time 40 --seed 7 \
        --variance "$out/ref-$1.var.exr"
}
case "$stage" in
timing)
    "$rlpt" devices >"$out/devices.txt"
    for s in seed-exp1 seed-exp2 seed-exp3 door; do
        warmup=640
        [ "$s" = door ] && warmup=3872
        for g in off octant sphere; do
            "$rlpt" bench "scenes/$s.toml" --frames 32 --warmup "$warmup" --guiding "$g" --nee on \
                --json "$out/bench-$s-$g.json" | tee "$out/bench-$s-$g.txt"
        done
        for g in octant sphere; do
            "$rlpt" bench "scenes/$s.toml" --frames 32 --warmup 8 --guiding "$g" --nee on \
                --json "$out/bench-early-$s-$g.json" | tee "$out/bench-early-$s-$g.txt"
        done
    done
    ;;
equal-time)
    for s in "$@"; do
        reference "$s"
        stats=()
        for nee in on off; do
            for g in off octant sphere; do
                "$rlpt" render "scenes/$s.toml" -o "$out/$s-$g-nee-$nee.exr" --spp 100000000 --time 10 \
                    --guiding "$g" --nee "$nee" --reference "$out/ref-$s.exr" \
                    --reference-variance "$out/ref-$s.var.exr" --stats "$out/stats-$s-$g-nee-$nee.json"
                stats+=("$out/stats-$s-$g-nee-$nee.json")
            done
        done
        "$rlpt" plot "${stats[@]}" -o "$out/convergence-$s.png"
    done
    ;;
settings)
    for s in "$@"; do
        "$rlpt" render "scenes/$s.toml" -o "$out/ref-$s.exr" --spp 100000000 --time 30 --seed 7
        run() { # NAME SCENEFILE ARGS...
            local name=$1 file=$2
            shift 2
            "$rlpt" render "$file" -o "$out/out.exr" --spp 100000000 --time 2 --reference "$out/ref-$s.exr" \
                --stats "$out/settings-$s-$name.json" "$@"
        }
        run off-nee-on "scenes/$s.toml" --guiding off --nee on
        run off-nee-off "scenes/$s.toml" --guiding off --nee off
        run octant "scenes/$s.toml" --guiding octant
        run sphere "scenes/$s.toml" --guiding sphere
        for f in 0.65 0.8 0.9; do run "sphere-f$f" "scenes/$s.toml" --guiding sphere --guided-fraction "$f"; done
        for b in 4x8 12x24 16x32; do run "sphere-b$b" "scenes/$s.toml" --guiding sphere --bins "$b"; done
        run sphere-b16x32-f0.8 "scenes/$s.toml" --guiding sphere --bins 16x32 --guided-fraction 0.8
        if [ "$s" = door ]; then
            # door's default grid is 16x6x11 cells: about half, 1.5x and 2x that.
            for r in "8, 3, 5" "24, 8, 16" "32, 11, 21"; do
                { cat "scenes/$s.toml"; printf '\n[guiding]\nresolution = [%s]\n' "$r"; } >"$out/$s-grid.toml"
                run "sphere-r${r%%,*}" "$out/$s-grid.toml" --guiding sphere
            done
        fi
    done
    ;;
learning-rate)
    for s in "$@"; do
        "$rlpt" render "scenes/$s.toml" -o "$out/ref-$s.exr" --spp 100000000 --time 40 --seed 7
        for nee in on off; do
            "$rlpt" render "scenes/$s.toml" -o "$out/$s-off-nee-$nee.exr" --spp 100000000 --time 10 \
                --guiding off --nee "$nee" --reference "$out/ref-$s.exr" --stats "$out/stats-$s-off-nee-$nee.json"
            for g in octant sphere; do
                for w in 1 0.75; do
                    "$rlpt" render "scenes/$s.toml" -o "$out/$s-$g-nee-$nee-w$w.exr" --spp 100000000 --time 10 \
                        --guiding "$g" --nee "$nee" --learning-rate-exponent "$w" --reference "$out/ref-$s.exr" \
                        --stats "$out/stats-w$w-$s-$g-nee-$nee.json"
                done
            done
        done
    done
    ;;
deep-guiding)
    [ $# -gt 0 ] || set -- door smallpt
    for s in "$@"; do
        reference "$s"
        run() { # NAME ARGS...
            local name=$1
            shift
            "$rlpt" render "scenes/$s.toml" -o "$out/out.exr" --spp 100000000 --time 10 --reference "$out/ref-$s.exr" \
                --reference-variance "$out/ref-$s.var.exr" --stats "$out/deep-$s-$name.json" "$@"
            "$rlpt" bench "scenes/$s.toml" --frames 32 --warmup 3872 --json "$out/bench-deep-$s-$name.json" "$@" \
                | tee "$out/bench-deep-$s-$name.txt"
        }
        run off --guiding off
        run sphere --guiding sphere
        run sphere-former --guiding sphere --guided-vertices 2 --bins 8x16
        for b in 8x16 16x32; do run "sphere-all-$b" --guiding sphere --bins "$b"; done
    done
    ;;
counters)
    for s in seed-exp1 seed-exp2 seed-exp3 door; do
        for g in off sphere; do
            warmup=640
            [ "$s" = door ] && [ "$g" = sphere ] && warmup=3872
            for c in on paths off; do
                "$rlpt" bench "scenes/$s.toml" --frames 32 --warmup "$warmup" --guiding "$g" --counters "$c" \
                    --json "$out/bench-counters-$c-$s-$g.json" | tee "$out/bench-counters-$c-$s-$g.txt"
            done
        done
    done
    ;;
q-targets)
    for s in "$@"; do
        reference "$s"
        warmup=640
        case "$s" in door) warmup=3872 ;; smallpt) warmup=1408 ;; esac
        runs=("off mis" "sphere mis" "sphere full" "octant mis" "octant full")
        for run in "${runs[@]}"; do
            read -r g t <<<"$run"
            name="$g-$t"
            [ "$g" = off ] && name=off
            args=(--guiding "$g")
            [ "$g" = off ] || args+=(--q-targets "$t")
            "$rlpt" render "scenes/$s.toml" -o "$out/$s-$name.exr" --spp 100000000 --time 10 "${args[@]}" \
                --reference "$out/ref-$s.exr" --reference-variance "$out/ref-$s.var.exr" \
                --stats "$out/stats-$s-$name.json"
            "$rlpt" bench "scenes/$s.toml" --frames 32 --warmup "$warmup" "${args[@]}" \
                --json "$out/bench-q-$s-$name.json" | tee "$out/bench-q-$s-$name.txt"
        done
    done
    ;;
floor)
    for s in "$@"; do
        reference "$s"
        check=(--reference "$out/ref-$s.exr" --reference-variance "$out/ref-$s.var.exr")
        "$rlpt" render "scenes/$s.toml" -o "$out/$s-off.exr" --spp 100000000 --time 10 --guiding off \
            "${check[@]}" --stats "$out/stats-$s-off.json"
        for b in ${BINS:-default}; do
            bins=()
            [ "$b" = default ] || bins=(--bins "$b")
            for f in ${FLOORS:-0.25 0.15 0.1 0.05}; do
                "$rlpt" render "scenes/$s.toml" -o "$out/$s-$b-f$f.exr" --spp 100000000 --time 10 \
                    --guiding sphere "${bins[@]}" --exploration-floor "$f" "${check[@]}" \
                    --stats "$out/stats-$s-$b-f$f.json"
            done
        done
    done
    ;;
learning-frames)
    # Equal time with the image started after 0, 4 (the default with roulette) or
    # 8 learning frames ($LEARNING to choose), against unguided.
    for s in "$@"; do
        reference "$s"
        check=(--reference "$out/ref-$s.exr" --reference-variance "$out/ref-$s.var.exr")
        "$rlpt" render "scenes/$s.toml" -o "$out/$s-off.exr" --spp 100000000 --time 10 --guiding off \
            "${check[@]}" --stats "$out/stats-$s-off.json"
        for n in ${LEARNING:-0 4 8}; do
            "$rlpt" render "scenes/$s.toml" -o "$out/$s-l$n.exr" --spp 100000000 --time 10 \
                --guiding sphere --learning-frames "$n" "${check[@]}" --stats "$out/stats-$s-l$n.json"
        done
    done
    ;;
never-worse)
    dir=${SCENES:-scenes}
    # The flags of a mode.
    mode() {
        case $1 in
        off) echo --guiding off ;;
        sphere) echo --guiding sphere ;;
        auto) echo --guiding sphere --unguided-frames auto ;;
        never) echo --guiding sphere --unguided-frames never ;;
        esac
    }
    for m in ${MODES:-off sphere} ${MODES_B:-}; do
        case $m in off | sphere | auto | never) ;; *) echo "unknown mode $m: off, sphere, auto or never" >&2 && exit 2 ;; esac
    done
    # Each binary and mode as "BINARY NAME MODE".
    runs=()
    for m in ${MODES:-off sphere}; do runs+=("$rlpt $m $m"); done
    if [ -n "${RLPT_B:-}" ]; then
        for m in ${MODES_B:-sphere}; do runs+=("$RLPT_B b$m $m"); done
    fi
    cases=("$@")
    if [ ${#cases[@]} -eq 0 ]; then
        cases=(furnace-open:64x64 furnace-closed:64x64)
        for s in door bunny-door smallpt seed-exp1 seed-exp2 seed-exp3 cornell-box suzanne bmw-m6; do
            own=$(awk '$1 == "width" { w = $3 } $1 == "height" { h = $3 } END { print w "x" h }' "$dir/$s.toml")
            cases+=("$s:64x40" "$s:$own")
        done
    fi
    for c in "${cases[@]}"; do
        s=${c%%:*} size=${c#*:}
        w=${size%x*} h=${size#*x} tag=$s-$size
        args=("$dir/$s.toml" --width "$w" --height "$h" --spp 100000000)
        ref=${REFS:-$out}/ref-$tag
        if [ ! -f "$ref.exr" ]; then
            ref=$out/ref-$tag
            t=2
            [ $((w * h)) -ge 100000 ] && t=6
            t=${REF_TIME:-$t}
            "$rlpt" render "${args[@]}" -o "$ref.exr" --time "$t" --seed 77 --variance "$ref.var.exr"
        fi
        for r in "${runs[@]}"; do
            read -r bin name m <<<"$r"
            # shellcheck disable=SC2046
            "$bin" render "${args[@]}" -o "$out/warm.exr" --time 0.2 $(mode "$m") >/dev/null
        done
        for k in ${SEEDS:-1 2}; do
            for r in "${runs[@]}"; do
                read -r bin name m <<<"$r"
                # shellcheck disable=SC2046
                "$bin" render "${args[@]}" -o "$out/$tag-$name-$k.exr" --time "${TIME:-1}" --seed "$k" $(mode "$m") \
                    --reference "$ref.exr" --reference-variance "$ref.var.exr" --stats "$out/stats-$tag-$name-$k.json"
            done
        done
    done
    ;;
*)
    echo "unknown stage $stage: timing, equal-time, settings, learning-rate, deep-guiding, counters, q-targets," \
        "floor, learning-frames or never-worse" >&2
    exit 2
    ;;
esac
