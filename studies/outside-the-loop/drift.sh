#!/usr/bin/env bash
# A crowd that drifts (plan.md, section 5): per world, three graphs (baseline,
# sr-heuristic, sr-crowd under the default crowd model) grown from that world's start;
# each round publishes the three (no renders), lets learner.py play 30 sessions on each
# and upload them, then grows each graph to the round's size. After the last growth a
# final round plays the last versions, so every size is played (see drift.md).
#
# usage: drift.sh OUT_DIR [options]     (srg on PATH; SRG_VAR_DIR names the database)
#   --worlds "20 21 22"          world seeds, one learner (state file) per world
#   --sizes "1000 2000 3000 5000"  the rounds' sizes in frames (grown to, in turn)
#   --dynamics liquid --preset tiny --fluid low
#   --toy                        the toy dynamics, sizes "200 400" unless --sizes is given
#   --sessions 30  --seed 0  --port 8766  --name drift  --threshold T (default: the one
#                                srg analytics reports for the graphs' dynamics)
# A rerun with the same OUT_DIR goes on where it stopped: a round whose lines are in
# OUT_DIR is not played again, and a graph already at a round's size is not grown.
set -euo pipefail
usage() { awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0" >&2; exit 2; }
[ $# -ge 1 ] || usage
out=$1; shift
worlds="20 21 22"; sizes=""; dynamics=liquid; preset=tiny; fluid=low; toy=0
sessions=30; seed=0; port=8766; name=drift; threshold=""
while [ $# -gt 0 ]; do
  case $1 in
    --worlds) worlds=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --dynamics) dynamics=$2; shift 2 ;;
    --preset) preset=$2; shift 2 ;;
    --fluid) fluid=$2; shift 2 ;;
    --toy) toy=1; dynamics=toy; shift ;;
    --sessions) sessions=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --port) port=$2; shift 2 ;;
    --name) name=$2; shift 2 ;;
    --threshold) threshold=$2; shift 2 ;;
    *) usage ;;
  esac
done
if [ -z "$sizes" ]; then
  if [ "$toy" = 1 ]; then sizes="200 400"; else sizes="1000 2000 3000 5000"; fi
fi
: "${SRG_VAR_DIR:?set SRG_VAR_DIR to a directory outside any work tree, e.g. /var/tmp/srg-drift}"
if [ -n "${SRG_DATABASE_URL:-}" ]; then
  echo "SRG_DATABASE_URL is set: unset it, the database is SRG_VAR_DIR's" >&2; exit 2
fi
mkdir -p "$SRG_VAR_DIR" "$out"
if git -C "$SRG_VAR_DIR" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  echo "SRG_VAR_DIR=$SRG_VAR_DIR is inside a git work tree: put it outside" >&2; exit 2
fi
export SRG_GROWTH_RENDERS=false                   # the learner plays edges, not pictures
export SRG_BATCH_SIZE=${SRG_BATCH_SIZE:-8}        # the plan: 8 blends an epoch
export SRG_UPLOADS_PER_MINUTE=${SRG_UPLOADS_PER_MINUTE:-100000}  # one player, 90 uploads a round
here=$(cd "$(dirname "$0")" && pwd)
learner="$here/learner.py"
url="http://127.0.0.1:$port"
strategies="baseline sr-heuristic sr-crowd"
if [ "$dynamics" = toy ]; then shape=(--dynamics toy)
else shape=(--dynamics "$dynamics" --preset "$preset" --fluid "$fluid"); fi
say() { echo "[$(date +%H:%M:%S)] $*"; }
json() { python -c "import json, sys; print(json.load(sys.stdin)$1)"; }
size_of() { srg status "$1" --json | json '["size_frames"]'; }
published_size() {  # frames of the graph's latest publication, -1 before the first (404)
  { curl -sf "$url/api/graphs/$1/publication" || echo '{"size_frames": -1}'; } | json '["size_frames"]'
}
log="$out/srg.log"  # what srg init, publish and grow print

say "database $SRG_VAR_DIR, out $out; ${shape[*]}; worlds $worlds; sizes $sizes; batch $SRG_BATCH_SIZE"
srg db upgrade >>"$log" 2>&1
for world in $worlds; do
  for strategy in $strategies; do
    graph="$name.$strategy.$world"
    if ! srg status "$graph" --json >/dev/null 2>&1; then
      srg init "$graph" "${shape[@]}" --strategy "$strategy" --world "$world" >>"$log" 2>&1
    fi
    model=""; [ "$strategy" = sr-crowd ] && model=", crowd model $(srg status "$graph" --json | json '["player_model"]')"
    say "$graph: $(size_of "$graph") frames$model"
  done
done
if [ -z "$threshold" ]; then
  threshold=$(srg analytics "$name.baseline.${worlds%% *}" --json | json '["threshold"]')
fi
say "high-error threshold $threshold"

if curl -s "$url/api/health" >/dev/null; then
  echo "something already answers on port $port: choose another with --port" >&2; exit 2
fi
srg serve --port "$port" >>"$out/serve.log" 2>&1 &
server=$!
trap 'kill $server 2>/dev/null' EXIT
for _ in $(seq 60); do
  kill -0 $server 2>/dev/null || { echo "srg serve stopped: see $out/serve.log" >&2; exit 1; }
  curl -sf "$url/api/health" >/dev/null && break
  sleep 1
done
curl -sf "$url/api/health" >/dev/null || { echo "srg serve did not answer in 60 s" >&2; exit 1; }

read -r -a targets <<<"$sizes"
for world in $worlds; do
  state="$out/learner.$world.json"
  graphs=(); for strategy in $strategies; do graphs+=("$name.$strategy.$world"); done
  for round in $(seq 0 "${#targets[@]}"); do
    lines="$out/rounds/$world.$round.jsonl"
    if [ ! -s "$lines" ]; then
      for graph in "${graphs[@]}"; do  # a rerun does not publish an unchanged graph again
        if [ "$(published_size "$graph")" != "$(size_of "$graph")" ]; then
          srg publish "$graph" --no-render >>"$log" 2>&1
        fi
      done
      mkdir -p "$out/rounds"
      python "$learner" "$url" "$state" "$round" "$((1000 * seed + world))" "$threshold" \
        "${graphs[@]}" --sessions "$sessions" >"$lines.tmp"
      mv "$lines.tmp" "$lines"
    fi
    summary=$(python - "$lines" <<'EOF'
import json, sys
rows = [json.loads(line) for line in open(sys.argv[1])]
figures = " ".join(f"{r['graph'].split('.')[-2]} {r['mean_error']:.4g}" for r in rows)
error = {r["graph"].split(".")[-2]: r["mean_error"] for r in rows}
ratios = (
    f"sr-crowd/sr-heuristic {error['sr-crowd'] / error['sr-heuristic']:.3f}, "
    f"sr-crowd/baseline {error['sr-crowd'] / error['baseline']:.3f}"
)
holds = " ".join(f"{h}:{p:.3f}" for h, p in rows[0]["hold_probabilities"].items())
print(f"{rows[0].get('size_frames', '?')} frames; error {figures} ({ratios}); holds {holds}")
EOF
)
    say "world $world round $round played: $summary"
    if [ "$round" -lt "${#targets[@]}" ]; then
      target=${targets[$round]}
      for graph in "${graphs[@]}"; do
        left=$((target - $(size_of "$graph")))
        if [ "$left" -gt 0 ]; then
          started=$SECONDS
          srg grow "$graph" --frames "$left" >>"$log" 2>&1
          say "$graph grown to $(size_of "$graph") frames in $((SECONDS - started)) s"
        fi
      done
    fi
  done
done
cat "$out"/rounds/*.jsonl >"$out/rounds.jsonl"
say "done: $out/rounds.jsonl"
