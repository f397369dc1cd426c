#!/usr/bin/env bash
# Sets up ./.venv and runs the main job (`srg demo`) on the embedded default:
# a SQLite file under ./var, eager Celery (no broker), PoCL on the CPU.
# Extra arguments go to `srg demo` (e.g. --checkpoints 300,1000,3000 or --fluid high).
set -euo pipefail
cd "$(dirname "$0")/.."
SRG_EXTRAS=all source infra/venv.sh
bash infra/opencl.sh
# Mitsuba's LLVM variant renders about 3x faster than scalar_rgb but needs libLLVM >= 17
# (Debian's default 14/15 crash in it); without it rendering falls back to scalar_rgb.
if ! ls /usr/lib/*/libLLVM.so.19* >/dev/null 2>&1 && command -v apt-get >/dev/null; then
  source infra/apt.sh
  apt_install libllvm19 || echo "no libllvm19: rendering with scalar_rgb" >&2
fi
srg db upgrade
srg demo "$@"
