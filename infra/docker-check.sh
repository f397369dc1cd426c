#!/usr/bin/env bash
# Builds the Dockerfile's image and checks it: every installed package at its pin in
# requirements/constraints.txt, `srg --version`, and the OpenCL probe of infra/opencl.sh
# (a PoCL device, pip's or Debian's, that builds kernels on this CPU).
#
#   bash infra/docker-check.sh     # image srg:check; SRG_CONTAINER=podman to use podman
#
# Where no container engine answers (`docker info`), it says so and exits 0: skipped, not
# passed. Not part of infra/test.sh: a build downloads the base image, Debian's packages and
# every wheel (minutes); docs/operations.md, "The image", says when to run it.
set -euo pipefail
cd "$(dirname "$0")/.."
engine=${SRG_CONTAINER:-docker}
image=srg:check
if ! command -v "$engine" >/dev/null || ! "$engine" info >/dev/null 2>&1; then
  echo "docker-check: skipped: no container engine answers here ($engine info)"
  exit 0
fi
# host networking: the build's apt-get and pip reach their registries without a bridge
"$engine" build --network host --tag "$image" .
# the pinned packages at their pins (what the base image brings beside them is not ours)
"$engine" run --rm "$image" pip freeze --all | python3 -c '
import re, sys
def pin(line):
    name, _, version = line.strip().partition("==")
    return re.sub(r"[-_.]+", "-", name).lower(), version
pins = dict(pin(line) for line in open("requirements/constraints.txt") if line[0].isalnum())
off = [line.strip() for line in sys.stdin if pin(line)[0] in pins and pin(line) not in pins.items()]
if off:
    sys.exit("docker-check: off the pins of requirements/constraints.txt: " + ", ".join(off))
'
"$engine" run --rm "$image" srg --version
"$engine" run --rm "$image" \
  python -c "from app.kernels.context import select_device; print(select_device(''))"
echo "docker-check: $image built; its packages are the pinned ones, srg runs, an OpenCL device builds kernels"
