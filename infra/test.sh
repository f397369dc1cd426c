#!/usr/bin/env bash
# The one test command: venv with the test extras, services up, lint, types, the docs
# site, tests. Two tiers (CONTRIBUTING.md, "Tests"):
#   bash infra/test.sh            the full suite, what CI runs
#   bash infra/test.sh fast       unit, kernels and core services: no real workers,
#                                 browser or liquid growth, for while you work
# Further arguments go to pytest (e.g. infra/test.sh fast -k store -x). Both print the
# slowest tests and fail a test that runs past its limit (SRG_TEST_TIMEOUT seconds).
set -euo pipefail
cd "$(dirname "$0")/.."
tier=full
if [ "${1:-}" = fast ]; then tier=fast; shift; fi
SRG_EXTRAS=all,test source infra/venv.sh
bash infra/opencl.sh
bash infra/services.sh
echo "test: ruff"
ruff check app tests studies
echo "test: mypy"
mypy
echo "test: docs"  # a broken link, anchor or page fails here (mkdocs.yml)
NO_MKDOCS_2_WARNING=1 mkdocs build --strict  # not --quiet: it hides the warnings strict counts
site_bytes=$(du -sb var/site | cut -f1)  # the manual, none of the studies' bulk
if [ "$site_bytes" -ge 10000000 ]; then echo "test: the built site is $site_bytes bytes, 10 MB at most"; exit 1; fi
echo "test: pytest ($tier)"
limits=(--durations=25 --timeout="${SRG_TEST_TIMEOUT:-2400}")
if [ "$tier" = fast ]; then
  pytest -q "${limits[@]}" -m "not slow" tests/unit tests/kernels tests/api "$@"
else
  pytest -q "${limits[@]}" "$@"
fi
