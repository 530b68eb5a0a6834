#!/bin/bash
# The seven rows every OneFit network is compared on in docs/benchmarks.md:
# `onefit eval` (network against the reference drape, one thread) on the
# suit's walk, hop and dance, the skirt's walk, the held-out sport suit's
# walk, and the suit's walk on two unseen body shapes; two rows at a time.
#
#   bash docs/scripts/onefit_eval_rows.sh MODEL OUT [BUILD_DIR] [-- EVAL_FLAGS...]
#
# EVAL_FLAGS go to every row's `onefit eval` (e.g. --strain-limit 3).
# Writes OUT/ROW/eval.md (and the rest of `onefit eval`'s outputs) per row
# and prints one line per row (the network's row of eval.md, relaxed by
# default; not "the network as predicted"): eps_c raw, post-processed and by area,
# eps_e and eps_a post-processed, the mean distance to the reference drape
# (mm) and eps_e raw. Run from the repository's
# root; the data is taken from ../shared/data/drape.
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 MODEL OUT [BUILD_DIR] [-- EVAL_FLAGS...]" >&2
  exit 2
fi
model=$1
out=$2
build=build
if [ $# -ge 3 ] && [ "$3" != "--" ]; then build=$3; fi
onefit=$build/bin/onefit
flags=()
for ((i = 3; i <= $#; ++i)); do
  if [ "${!i}" = "--" ]; then flags=("${@:i+1}"); break; fi
done
data=../shared/data/drape
garments=$data/garments/makehuman_cc0
suit=$garments/male_casualsuit02.mhclo
walk=$data/motion/02_01.bvh
for path in "$model" "$onefit" "$suit" "$walk"; do
  [ -e "$path" ] || { echo "$0: $path does not exist" >&2; exit 1; }
done
mkdir -p "$out"

row() {
  local name=$1
  shift
  "$onefit" eval --model "$model" "${flags[@]}" --body $data/body --threads 1 --out "$out/$name" "$@" >"$out/$name.log" 2>&1 ||
    echo "$name failed: see $out/$name.log" >&2
}

row walk --garment $suit --motion $walk &
row hop --garment $suit --motion $data/motion/131_03.bvh &
wait
row skirt --garment $garments/skirthelper.mhclo --motion $walk &
row dance --garment $suit --motion $data/motion/05_06.bvh &
wait
row sport --garment $garments/female_sportsuit01.mhclo --motion $walk &
row shapeA --garment $suit --motion $walk --shape gender=0.2,weight=0.9 &
wait
row shapeB --garment $suit --motion $walk --shape gender=0.8,weight=0.15,height=0.9,muscle=0.8

echo "row: eps_c % | eps_c % post | eps_c % area | eps_e % | eps_a % | to reference mm (max frame) | eps_e % raw"
for name in walk hop skirt dance sport shapeA shapeB; do
  line=$(grep -E '^\| network' "$out/$name/eval.md" 2>/dev/null | cut -d'|' -f3-8,11 || true)
  echo "$name:${line:- (no result)}"
done
