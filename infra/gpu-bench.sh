#!/usr/bin/env bash
# The GPU check of the solver (docs/sph.md, "On a GPU"): `python -m app.bench.gpu` on an
# NVIDIA GPU through NVIDIA's OpenCL, on a machine that has Python 3.12, NumPy and SciPy
# but neither the project's environment nor a network. Prints one JSON report: a `paper`
# frame's seconds (high fluid), `small` batches of 12 against clips alone, identities,
# the profile of a substep, and which bars are met. A few minutes on a GPU.
#
#   bash infra/gpu-bench.sh --fetch   # online, here: the wheels it needs into .whl/
#   bash infra/gpu-bench.sh           # on the GPU machine, .whl/ copied beside
#   bash infra/gpu-bench.sh tiny tiny # a quick trial on any OpenCL device (presets of
#                                     # the frame time and of the batches)
set -euo pipefail
cd "$(dirname "$0")/.."
python=${PYTHON:-python3}
wheels=.whl
# PyOpenCL and what it needs beyond NumPy, at the versions the tests pass with
pins=$(grep -E '^(pyopencl|pytools|platformdirs|siphash24)==' requirements/constraints.txt)

if [ "${1:-}" = --fetch ]; then
  platforms=""
  for tag in manylinux_2_28 manylinux_2_27 manylinux_2_17 manylinux2014 manylinux1; do
    platforms="$platforms --platform ${tag}_x86_64"
  done
  # shellcheck disable=SC2086
  python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 \
    --implementation cp $platforms -d "$wheels" $pins
  ls "$wheels"
  exit 0
fi

if ! "$python" -c "import pyopencl" 2>/dev/null; then
  if ! ls "$wheels"/*.whl >/dev/null 2>&1; then
    echo "gpu-bench: no pyopencl and no wheels in $wheels/ (run: bash infra/gpu-bench.sh --fetch)" >&2
    exit 2
  fi
  "$python" -m pip install -q --no-index --no-deps --no-compile --target /tmp/srg-gpu-site \
    "$wheels"/*.whl
  export PYTHONPATH=/tmp/srg-gpu-site
fi

# NVIDIA's OpenCL driver, registered with the ICD loader beside the image's own where
# the image did not: by its full path, since a driver mounted into a container is often
# outside ld.so's cache
if ! grep -qs nvidia /etc/OpenCL/vendors/*.icd; then
  lib=$(ldconfig -p 2>/dev/null | awk '/libnvidia-opencl\.so\.1/ {print $NF; exit}' || true)
  if [ -z "$lib" ]; then
    lib=$(find /usr/local/nvidia /usr/lib /usr/lib64 -name 'libnvidia-opencl.so.1' \
      2>/dev/null | head -n1 || true)
  fi
  if [ -n "$lib" ]; then
    mkdir -p /tmp/srg-icd
    cp /etc/OpenCL/vendors/*.icd /tmp/srg-icd/ 2>/dev/null || true
    echo "$lib" >/tmp/srg-icd/nvidia.icd
    export OCL_ICD_VENDORS=/tmp/srg-icd
  fi
  echo "gpu-bench: NVIDIA's OpenCL library: ${lib:-none found}" >&2
fi

export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
export SRG_OPENCL_DEVICE=${SRG_OPENCL_DEVICE-NVIDIA}
exec "$python" -m app.bench.gpu "$@"
