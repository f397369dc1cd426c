# The srg image of infra/compose.yaml: the migration, workers, beat, Flower and the API
# all run it. (Not built in CI: no Docker engine there.)
# Debian 13 (trixie): its libllvm19 is the libLLVM Mitsuba's LLVM variant runs with
FROM python:3.11-slim-trixie

# without libLLVM renders fall back to the scalar variant, about 3x slower
# (app/render/mitsuba_scene.py looks for Debian's libLLVM.so.19.1)
RUN apt-get update \
    && apt-get install -y --no-install-recommends libllvm19 \
    && rm -rf /var/lib/apt/lists/*

# a normal install, every extra: the distribution carries the package data and the
# migrations, so nothing runs from the source tree, which is removed
COPY . /tmp/srg-src
RUN pip install --no-cache-dir "/tmp/srg-src[all]" && rm -rf /tmp/srg-src

# not root; /data made here, so that a fresh named volume mounted on /data/artifacts
# starts owned by srg (Docker copies the ownership of the image's directory)
RUN useradd --create-home --uid 1000 --user-group srg \
    && mkdir -p /data/artifacts \
    && chown -R srg:srg /data
USER srg
WORKDIR /data
ENV SRG_VAR_DIR=/data
CMD ["srg", "--help"]
