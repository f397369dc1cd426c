#!/usr/bin/env bash
# Makes sure an OpenCL CPU device can compile kernels here (run after infra/venv.sh).
# The PoCL that pip installs carries LLVM 14, which does not know CPUs newer than it (AMD
# Zen 5 reads as 'generic' and every build fails); Debian's PoCL picks its kernel library
# by the CPU's features instead, so it is installed beside it when the probe fails
# (docs/runtime.md, "The OpenCL device").
set -euo pipefail
cd "$(dirname "$0")/.."
source infra/apt.sh
probe=(.venv/bin/python -c "from app.kernels.context import select_device; select_device('')")
if "${probe[@]}" 2>/dev/null; then exit 0; fi
if ! command -v apt-get >/dev/null; then
  echo "no OpenCL device compiles for this CPU; install a PoCL built with a newer LLVM" >&2
  exit 1
fi
apt_install pocl-opencl-icd
if ! error=$("${probe[@]}" 2>&1); then
  echo "${error##*$'\n'}" >&2  # the last line: what is missing
  exit 1
fi
