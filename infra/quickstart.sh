#!/usr/bin/env bash
# Sets up ./.venv and runs the main job (`srg demo`) on the embedded default:
# a SQLite file under ./var, eager Celery (no broker), PoCL on the CPU.
# Extra arguments go to `srg demo` (e.g. --rounds 5 --budget 600).
set -euo pipefail
cd "$(dirname "$0")/.."
source infra/venv.sh
srg db upgrade
srg demo "$@"
