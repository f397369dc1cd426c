# The srg image of infra/compose.yaml: the migration, workers, beat, Flower and the API
# all run it. `bash infra/docker-check.sh` builds it and runs its OpenCL probe where a
# Docker engine answers (docs/operations.md, "The image").
# Debian 13 (trixie): its libllvm19 is the libLLVM Mitsuba's LLVM variant runs with
FROM python:3.11-slim-trixie

# without libLLVM renders fall back to the scalar variant, about 3x slower
# (app/render/mitsuba_scene.py looks for Debian's libLLVM.so.19.1). Debian's PoCL beside
# pip's, as infra/opencl.sh installs it: the image runs on CPUs not known when it is
# built, and pip's PoCL (LLVM 14) builds no kernel on a CPU newer than its LLVM, where
# Debian's picks its kernel library by the CPU's features (docs/runtime.md, "The OpenCL
# device"); app/kernels/context.py takes the first of the two that builds its probe.
RUN apt-get update \
    && apt-get install -y --no-install-recommends libllvm19 pocl-opencl-icd \
    && rm -rf /var/lib/apt/lists/*

# a normal install, every extra, at the versions of requirements/constraints.txt (the ones
# the tests passed with; infra/lock.sh refreshes them): the distribution carries the
# package data and the migrations, so nothing runs from the source tree, which is removed
COPY . /tmp/srg-src
RUN pip install --no-cache-dir -c /tmp/srg-src/requirements/constraints.txt pip hatchling \
    && pip install --no-cache-dir -c /tmp/srg-src/requirements/constraints.txt "/tmp/srg-src[all]" \
    && rm -rf /tmp/srg-src

# not root; /data made here, so that a fresh named volume mounted on /data/artifacts
# starts owned by srg (Docker copies the ownership of the image's directory)
RUN useradd --create-home --uid 1000 --user-group srg \
    && mkdir -p /data/artifacts \
    && chown -R srg:srg /data
USER srg
WORKDIR /data
ENV SRG_VAR_DIR=/data
CMD ["srg", "--help"]
