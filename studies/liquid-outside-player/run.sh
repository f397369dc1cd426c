#!/usr/bin/env bash
# Rounds of the outside player on two liquid `tiny` graphs (baseline, sr-crowd) grown
# side by side: publish both (no renders), 30 sessions on each, grow both by 800 frames.
# usage: run.sh OUT_DIR [ROUNDS] [PORT] [REPEAT] [FLUID]   (srg on PATH; SRG_VAR_DIR names
# the database; REPEAT, 0 by default, draws other sessions: round r plays seeds
# 100 REPEAT + r; FLUID low, the default, or high)
set -euo pipefail
export SRG_GROWTH_RENDERS=false  # the player plays edges, not pictures
out=$1; rounds=${2:-4}; port=${3:-8765}; repeat=${4:-0}; fluid=${5:-low}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
srg db upgrade >/dev/null
for strategy in baseline sr-crowd; do
  srg init "outside-$strategy" --dynamics liquid --preset tiny --fluid "$fluid" --strategy "$strategy" >/dev/null
done
srg serve --port "$port" >"$out/serve.log" 2>&1 &
server=$!
trap 'kill $server' EXIT
sleep 8
for round in $(seq 1 "$rounds"); do
  for strategy in baseline sr-crowd; do
    srg publish "outside-$strategy" --no-render >/dev/null
    python "$here/player.py" "http://127.0.0.1:$port" "outside-$strategy" 30 $((100 * repeat + round)) \
      >>"$out/rounds.jsonl"
  done
  if [ "$round" -lt "$rounds" ]; then
    for strategy in baseline sr-crowd; do srg grow "outside-$strategy" --frames 800 >/dev/null; done
  fi
done
