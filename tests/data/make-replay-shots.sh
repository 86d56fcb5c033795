#!/usr/bin/env bash
# Regenerates the small recorded shots that CI replays end to end
# (tests/app/replay_data_sim_test.cpp): two shots at the thesis' imaging
# (240 x 192 pixels, 1000 frames/s), fired on the simulated rig, with their
# ground truth, images compressed (shuffle + deflate 9; sensor noise limits
# how small they get, about 1.6 MB each).
#   tests/data/make-replay-shots.sh [path/to/collide]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
collide="${1:-$here/../../build/app/collide}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$collide" campaign --rig "$here/../../config/sim-thesis.toml" --shots 2 --seed 7 \
  --angle-min-deg 25 --angle-max-deg 55 --out "$tmp"
n=0
for f in "$tmp"/*.h5; do
  n=$((n + 1))
  h5repack -f /frames/images:SHUF -f /frames/images:GZIP=9 "$f" "$here/replay-thesis-$n.h5"
done
echo "wrote $n shots into $here"
