#!/usr/bin/env bash
# The runs to the plan's end two worlds at a time (deviations.md, "grown world by world"):
# for each pair of worlds without a play file in plays/, every run of the pair is grown
# to 20k (`srg experiment --resume --only-seeds`, the stored plan's options), the
# tilt-holder plays its versions from 5k over HTTP, and the pair's play file
# (`srg results export --only-seeds`, the tilt-holder's lines kept in it) is written and
# committed. A machine that is lost loses at most the pair it was growing; on the next
# one this starts the experiment again (the plan's command, `run.sh`, its first pair only)
# and goes on with the pairs not yet committed.
#   bash studies/outside-the-loop/run-worlds.sh [PAIR ...]     (default: every pair)
set -euo pipefail
repo=$(git -C "$(dirname "$0")" rev-parse --show-toplevel)
home=${SRG_STUDY_DIR:-/var/tmp/srg-outside}
plays=$repo/studies/outside-the-loop/plays
#: the experiment's high-error threshold, as stored with its plan (scoreboard-10k.json)
threshold=0.03567540683636545
port=8795
code=$home/head-$(git -C "$repo" rev-parse --short HEAD)
[ -d "$code" ] || git -C "$repo" worktree add --detach "$code" HEAD
export PYTHONPATH=$code SRG_VAR_DIR=$home PATH=$repo/.venv/bin:$PATH
cd "$code"
mkdir -p "$plays"
pairs=("$@")
[ ${#pairs[@]} -gt 0 ] || pairs=(20,21 22,23 24,25 26,27 28,29)
stored='from app.config import get_settings as s; from app.services.experiment.plan import stored_plan
stored_plan(s(), "outside-the-loop")'
if ! python -c "$stored" 2> /dev/null; then
  first=$(for pair in "${pairs[@]}"; do
    [ -f "$plays/worlds-${pair/,/-}.npz" ] || { echo "$pair"; break; }; done)
  [ -n "$first" ] || exit 0
  SRG_STUDY_CODE=$code bash "$repo/studies/outside-the-loop/run.sh" --only-seeds "$first"
fi
for pair in "${pairs[@]}"; do
  file=$plays/worlds-${pair/,/-}.npz
  [ -f "$file" ] && continue
  echo "[$(date -u +%H:%M:%S)] worlds $pair: growing to the plan's end"
  srg experiment --resume --name outside-the-loop --jobs 2 --only-seeds "$pair" \
    --out "$home/report-$pair"
  echo "[$(date -u +%H:%M:%S)] worlds $pair: the tilt-holder"
  srg serve --port $port > "$home/serve-$pair.log" 2>&1 &
  server=$!
  trap 'kill $server 2>/dev/null || true' EXIT
  until curl -sf "http://127.0.0.1:$port/api/health" > /dev/null; do sleep 1; done
  python studies/outside-the-loop/tilt_holder.py "http://127.0.0.1:$port" $threshold \
    outside-the-loop "$pair" --from-frames 5000 > "$home/tilt-$pair.jsonl"
  kill $server && wait $server || true
  srg results export outside-the-loop "$file" --only-seeds "$pair" \
    --outside "$home/tilt-$pair.jsonl"
  cp "$home/tilt-$pair.jsonl" "$plays/tilt-holder-${pair/,/-}.jsonl"
  git -C "$repo" add "$file" "$plays/tilt-holder-${pair/,/-}.jsonl"
  until git -C "$repo" commit -q -m "outside-the-loop: worlds $pair at 20k, their play file" \
    -- "$file" "$plays/tilt-holder-${pair/,/-}.jsonl"; do sleep 5; done
  echo "[$(date -u +%H:%M:%S)] worlds $pair: committed $file"
done
