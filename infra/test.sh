#!/usr/bin/env bash
# The one test command: venv with the test extras, services up, lint, types, the docs
# site, tests.
# Extra arguments go to pytest (e.g. infra/test.sh -k store -x).
set -euo pipefail
cd "$(dirname "$0")/.."
SRG_EXTRAS=all,test source infra/venv.sh
bash infra/opencl.sh
bash infra/services.sh
echo "test: ruff"
ruff check app tests
echo "test: mypy"
mypy
echo "test: docs"  # a broken link, anchor or page fails here (mkdocs.yml)
NO_MKDOCS_2_WARNING=1 mkdocs build --strict  # not --quiet: it hides the warnings strict counts
echo "test: pytest"
pytest -q "$@"
