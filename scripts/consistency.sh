#!/usr/bin/env bash
# Does rlpt agree with itself? Every shipped scene at its own size, rendered for
# the same GPU time by each estimator (guiding off / octant / sphere, NEE on /
# off, the guided kernels also with the portable ballot loop in place of
# subgroupPartitionNV), each with independent random numbers and its per-pixel
# variance; then every pair that must agree is compared over the whole image
# and 16 regions, per channel (`rlpt compare --image-variance`). An unbiased
# renderer gives |z| of a few at most; the bar is 5, with each deviation given a
# floor of 1e-4 of the mean (f32 rounding along a path; the closed furnace has
# almost no noise), and the worst |z| against the noise alone is listed too.
# The CPU renderer does the same at a quarter of each side, and is compared with
# the GPU there.
#
#   scripts/consistency.sh RLPT OUTDIR [SECONDS_GPU] [SECONDS_CPU] [SCENE...]
#
# SECONDS_GPU (default 5) per GPU render, SECONDS_CPU (default 20) per CPU
# render, or 8192 frames, whichever comes first; scenes default to every scenes/*.toml. Writes OUTDIR/consistency.md
# (one row per pair: the global mean difference per channel, its z-scores, the
# worst of the 16 regions) and each render's EXR, variance and compare output.
set -euo pipefail
rlpt=$1
out=$2
t_gpu=${3:-5}
t_cpu=${4:-20}
shift 4 || shift $#
mkdir -p "$out"
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
    for f in scenes/*.toml; do scenes+=("$(basename "$f" .toml)"); done
fi

seed=100
# At most 8192 frames: on a fast GPU a small scene's frames take microseconds,
# and per-frame work on the host would make "3 s of GPU time" minutes of wall time.
max_spp=$((64 * 8192))
# render NAME SCENEFILE DEVICE SECONDS ARGS...: OUT/NAME.exr and .var.exr, each
# render with a seed of its own (independent random numbers).
render() {
    local name=$1 file=$2 device=$3 secs=$4
    shift 4
    seed=$((seed + 1))
    if ! "$rlpt" render "$file" -o "$out/$name.exr" --variance "$out/$name.var.exr" --device "$device" \
        --spp "$max_spp" --time "$secs" --seed "$seed" "$@" >"$out/$name.log" 2>&1; then
        cat "$out/$name.log" >&2
        exit 1
    fi
}

rows=()
# pair A B: compare two renders, add a row.
pair() {
    local a=$1 b=$2
    local txt="$out/compare-$a--$b.txt"
    "$rlpt" compare "$out/$a.exr" "$out/$b.exr" --image-variance "$out/$a.var.exr" \
        --reference-variance "$out/$b.var.exr" >"$txt"
    local diff z region worst
    diff=$(sed -n 's/^mean difference (R G B): \(.*\)  z .*/\1/p' "$txt")
    z=$(sed -n 's/^mean difference (R G B): .*  z \(.*\)/\1/p' "$txt")
    region=$(sed -n 's/^16 regions: worst z \([^ ]*\).*/\1/p' "$txt")
    worst=$(sed -n 's/^worst |z| \(.*\)/\1/p' "$txt")
    local flag=""
    awk -v w="$worst" 'BEGIN { exit !(w >= 5) }' && flag=" **over 5**"
    # The same against the noise alone (no floor): what the renders resolve.
    local worst0
    worst0=$("$rlpt" compare "$out/$a.exr" "$out/$b.exr" --image-variance "$out/$a.var.exr" \
        --reference-variance "$out/$b.var.exr" --floor 0 | sed -n 's/^worst |z| \(.*\)/\1/p')
    rows+=("| $a | $b | $diff | $z | $region | $worst$flag | $worst0 |")
    echo "$a vs $b: worst |z| $worst (noise alone $worst0)" >&2
}

for s in "${scenes[@]}"; do
    f="scenes/$s.toml"
    for nee in on off; do
        for g in off octant sphere; do
            render "$s-$g-$nee" "$f" gpu "$t_gpu" --guiding "$g" --nee "$nee"
        done
        RLPT_SUBGROUP_PARTITION=0 render "$s-sphere-$nee-ballot" "$f" gpu "$t_gpu" --guiding sphere --nee "$nee"
    done
    # A second unguided render with NEE on: how far two renders of one estimator differ.
    render "$s-off-on-2" "$f" gpu "$t_gpu" --guiding off --nee on
    pair "$s-off-on" "$s-off-on-2"
    pair "$s-off-on" "$s-off-off"
    for nee in on off; do
        pair "$s-octant-$nee" "$s-off-$nee"
        pair "$s-sphere-$nee" "$s-off-$nee"
        pair "$s-sphere-$nee-ballot" "$s-off-$nee"
    done
    # The CPU renderer, at a quarter of each side.
    w=$(sed -n 's/^width *= *\([0-9]*\).*/\1/p' "$f")
    h=$(sed -n 's/^height *= *\([0-9]*\).*/\1/p' "$f")
    small=(--width $(((w + 3) / 4)) --height $(((h + 3) / 4)))
    render "$s-cpu-off-on" "$f" cpu "$t_cpu" --guiding off --nee on "${small[@]}"
    render "$s-cpu-off-off" "$f" cpu "$t_cpu" --guiding off --nee off "${small[@]}"
    render "$s-cpu-sphere-on" "$f" cpu "$t_cpu" --guiding sphere --nee on "${small[@]}"
    render "$s-gpu-small-off-on" "$f" gpu "$t_gpu" --guiding off --nee on "${small[@]}"
    pair "$s-cpu-off-on" "$s-cpu-off-off"
    pair "$s-cpu-sphere-on" "$s-cpu-off-on"
    pair "$s-cpu-off-on" "$s-gpu-small-off-on"
done

{
    echo "GPU renders of $t_gpu s each, CPU renders of $t_cpu s (a quarter of each side); seeds differ."
    echo "z against the noise and a floor of 1e-4 of the mean (\`rlpt compare --floor\`, the bar);"
    echo "the last column against the noise alone."
    echo
    echo "| A | B | mean difference (R G B) | z (R G B) | worst region z | worst \|z\| | noise alone |"
    echo "|---|---|---|---|---|---|---|"
    printf '%s\n' "${rows[@]}"
} >"$out/consistency.md"
cat "$out/consistency.md"
