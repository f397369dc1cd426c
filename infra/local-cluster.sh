#!/usr/bin/env bash
# Start (or stop) a growth cluster on this machine against the local PostgreSQL and Redis:
# 2 Celery workers, beat and Flower. PID files and logs go to var/cluster.
#
#   infra/local-cluster.sh start      # SRG_BROKER_URL etc. default to the local services
#   infra/local-cluster.sh status
#   infra/local-cluster.sh stop
#
# Environment: SRG_BROKER_URL, SRG_RESULT_BACKEND (default redis://127.0.0.1:6379/0),
# SRG_DATABASE_URL (default postgresql+psycopg://postgres@127.0.0.1:5432/srg),
# SRG_CLUSTER_DIR (default var/cluster), SRG_WORKERS (default 2), SRG_FLOWER_PORT (5555).
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${SRG_CLUSTER_DIR:-var/cluster}
workers=${SRG_WORKERS:-2}
export SRG_BROKER_URL=${SRG_BROKER_URL:-redis://127.0.0.1:6379/0}
export SRG_RESULT_BACKEND=${SRG_RESULT_BACKEND:-$SRG_BROKER_URL}
export SRG_DATABASE_URL=${SRG_DATABASE_URL:-postgresql+psycopg://postgres@127.0.0.1:5432/srg}
export FLOWER_UNAUTHENTICATED_API=${FLOWER_UNAUTHENTICATED_API:-true}
srg=${SRG_COMMAND:-$(dirname "$(command -v python)")/srg}

say() { echo "local-cluster: $*"; }

running() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

start_one() {  # name, then the srg command and its arguments
  local name=$1; shift
  if running "$dir/$name.pid"; then say "$name already running (pid $(cat "$dir/$name.pid"))"; return; fi
  setsid "$srg" "$@" >>"$dir/$name.log" 2>&1 &
  echo $! >"$dir/$name.pid"
  say "$name started (pid $!, log $dir/$name.log)"
}

stop_one() {
  local pidfile=$1 pid
  running "$pidfile" || { rm -f "$pidfile"; return; }
  pid=$(cat "$pidfile")
  kill -TERM -- "-$pid" 2>/dev/null || kill -TERM "$pid"
  for _ in $(seq 1 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
  if kill -0 "$pid" 2>/dev/null; then kill -KILL -- "-$pid" 2>/dev/null || true; fi
  rm -f "$pidfile"
  say "stopped $(basename "$pidfile" .pid) (pid $pid)"
}

case "${1:-start}" in
  start)
    mkdir -p "$dir"
    for i in $(seq 1 "$workers"); do
      start_one "worker$i" worker --concurrency 1 --hostname "worker$i@%h"
    done
    start_one beat beat --schedule "$dir/celerybeat-schedule"
    start_one flower flower --port "${SRG_FLOWER_PORT:-5555}" --address 127.0.0.1
    ;;
  stop)
    for pidfile in "$dir"/*.pid; do [ -e "$pidfile" ] && stop_one "$pidfile"; done
    say "stopped"
    ;;
  status)
    for pidfile in "$dir"/*.pid; do
      [ -e "$pidfile" ] || continue
      if running "$pidfile"; then say "$(basename "$pidfile" .pid) running (pid $(cat "$pidfile"))"
      else say "$(basename "$pidfile" .pid) dead"; fi
    done
    ;;
  *) echo "usage: $0 [start|stop|status]" >&2; exit 2 ;;
esac
