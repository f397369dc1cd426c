#!/usr/bin/env bash
# The one test command: venv with the test extras, services up, lint, types, tests.
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
echo "test: pytest"
pytest -q "$@"
