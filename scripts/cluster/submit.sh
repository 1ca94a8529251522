#!/bin/bash
# Renders SCENE split into N parts by a Slurm job array, and merges them into OUT
# by a job that waits for every part (docs/cluster.md).
# Usage: submit.sh SCENE N SPP OUT.exr|png [render options...]
# RLPT names the rlpt binary where it is not on the nodes' PATH.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
scene=$1 n=$2 spp=$3 out=$4
shift 4
dir="${out%.*}.parts"
mkdir -p "$dir"
# Task K of the array renders part K/N; each writes $dir/part-K.exr.
array=$(sbatch --parsable --job-name=rlpt-part --array=0-$((n - 1)) --output="$dir/part-%a.log" \
    "$here/part.sbatch" "$scene" "$n" "$spp" "$dir" "$@")
array=${array%%;*}
# The merge starts once every task succeeded; where one fails it is cancelled, and
# the parts written stay in $dir (docs/cluster.md, "When a part fails").
merge=$(sbatch --parsable --job-name=rlpt-merge --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    --output="$dir/merge.log" "$here/merge.sbatch" "$dir" "$n" "$out")
echo "parts: job $array ($n tasks), merge: job ${merge%%;*} -> $out"
