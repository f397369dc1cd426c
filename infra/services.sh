#!/usr/bin/env bash
# Makes sure the services the tests and the distributed runtime need are up on 127.0.0.1:
# PostgreSQL (trust auth for user postgres over TCP), Redis, and Debian's chromium for the
# browser tests. Idempotent: installs only what is missing, starts only what is down.
set -euo pipefail

say() { echo "services: $*"; }

source "$(dirname "$0")/apt.sh"

pg_trust_works() { psql -h 127.0.0.1 -U postgres -w -d postgres -Atqc 'select 1' >/dev/null 2>&1; }

ensure_postgres() {
  if pg_isready -q -h 127.0.0.1 2>/dev/null; then
    say "PostgreSQL is accepting connections on 127.0.0.1"
  else
    if ! command -v pg_ctlcluster >/dev/null; then apt_install postgresql; fi
    local version
    version=$(ls /etc/postgresql | sort -V | tail -n 1)
    say "starting PostgreSQL $version"
    pg_ctlcluster --skip-systemctl-redirect "$version" main start || true
    for _ in $(seq 1 30); do pg_isready -q -h 127.0.0.1 && break; sleep 1; done
    pg_isready -h 127.0.0.1
  fi
  if pg_trust_works; then
    say "trust auth for postgres@127.0.0.1 works"
    return
  fi
  local hba
  hba=$(su postgres -c "psql -Atqc 'show hba_file'")
  say "setting trust auth for 127.0.0.1/32 and ::1 in $hba"
  sed -i -E 's/^(host[[:space:]]+all[[:space:]]+all[[:space:]]+(127\.0\.0\.1\/32|::1\/128)[[:space:]]+)[a-z0-9-]+/\1trust/' "$hba"
  grep -Eq '^host[[:space:]]+all[[:space:]]+postgres[[:space:]]+127\.0\.0\.1/32[[:space:]]+trust' "$hba" \
    || sed -i '1i host all postgres 127.0.0.1/32 trust\nhost all postgres ::1/128 trust' "$hba"
  su postgres -c "psql -Atqc 'select pg_reload_conf()'" >/dev/null
  pg_trust_works || { say "trust auth still fails"; exit 1; }
}

ensure_redis() {
  if redis-cli -h 127.0.0.1 -p 6379 ping 2>/dev/null | grep -q PONG; then
    say "Redis answers on 127.0.0.1:6379"
    return
  fi
  if ! command -v redis-server >/dev/null; then apt_install redis-server; fi
  say "starting Redis on 127.0.0.1:6379"
  redis-server --daemonize yes --bind 127.0.0.1 --port 6379 --save "" --appendonly no
  for _ in $(seq 1 10); do redis-cli -h 127.0.0.1 ping 2>/dev/null | grep -q PONG && return; sleep 1; done
  say "Redis did not start"; exit 1
}

ensure_chromium() {
  if [ -x /usr/bin/chromium ]; then
    say "chromium is installed"
  else
    apt_install chromium
  fi
}

ensure_postgres
ensure_redis
ensure_chromium
