#!/usr/bin/env bash
# Serve an experiment's database and let the outside player judge sr-crowd against
# sr-heuristic on each world seed's latest publications (docs/experiment.md, "Judges").
#   bash studies/judges/judge.sh EXPERIMENT CROWD_MIDDLE THRESHOLD PORT [SEEDS...]
# CROWD_MIDDLE is the part of sr-crowd's graph name between "sr-crowd." and the seed
# ("" for a pooled or one-crowd plan). The database is the settings' (SRG_DATABASE_URL).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
experiment=$1 middle=$2 threshold=$3 port=$4; shift 4
seeds=${*:-0 1 2}
srg serve --port "$port" >/dev/null 2>&1 &
server=$!
trap 'kill $server' EXIT
for _ in $(seq 60); do curl -sf "http://127.0.0.1:$port/api/health" >/dev/null && break; sleep 1; done
for seed in $seeds; do
  crowd="$experiment.sr-crowd.${middle:+$middle.}$seed"
  python "$here/outside_player.py" "http://127.0.0.1:$port" "$threshold" "$seed" \
    "$experiment.sr-heuristic.$seed" "$crowd"
done | python "$here/summarise.py"
