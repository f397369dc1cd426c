#!/usr/bin/env bash
# Makes sure an OpenCL CPU device can compile kernels here (run after infra/venv.sh).
# The PoCL that pip installs carries LLVM 14, which does not know CPUs newer than it (AMD
# Zen 5 reads as 'generic' and every build fails); Debian's PoCL picks its kernel library
# by the CPU's features instead, so it is installed beside it when the probe fails
# (docs/runtime.md, "The OpenCL device").
set -euo pipefail
cd "$(dirname "$0")/.."
probe() { .venv/bin/python -c "from app.kernels.context import select_device; select_device('')" 2>/dev/null; }
if probe; then exit 0; fi
if ! command -v apt-get >/dev/null; then
  echo "no OpenCL device compiles for this CPU; install a PoCL built with a newer LLVM" >&2
  exit 1
fi
echo "installing Debian's PoCL: pip's cannot compile for this CPU (apt-get)" >&2
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends pocl-opencl-icd >/dev/null 2>&1 \
  || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends pocl-opencl-icd >/dev/null; }
probe || { .venv/bin/python -c "from app.kernels.context import select_device; select_device('')"; exit 1; }
