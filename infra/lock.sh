#!/usr/bin/env bash
# Refreshes requirements/constraints.txt: the version of every package that srg and its
# extras need (pyproject.toml, every extra), with pip and hatchling
# (requirements/installers.in), resolved by uv for CPython 3.11 on Linux x86_64.
# infra/venv.sh (so the README's commands and CI) and the Dockerfile install with it.
#
#   infra/lock.sh                          pin what is new, keep every other pin
#   infra/lock.sh --upgrade                every pin to the newest release allowed
#   infra/lock.sh --upgrade-package NAME   one package (and what it needs)
#
# uv keeps the pins already in the file unless told to upgrade them, so adding a
# requirement to pyproject.toml and running this changes nothing else. After a change,
# run the tests on the new pins: `rm -rf .venv && bash infra/test.sh`.
set -euo pipefail
cd "$(dirname "$0")/.."
uv_version=0.13.9
tools=var/lock-tools
if [ "$("$tools/bin/uv" --version 2>/dev/null)" != "uv $uv_version" ]; then
  rm -rf "$tools"
  python3 -m venv "$tools"
  "$tools/bin/python" -m pip install -q "uv==$uv_version"
fi
"$tools/bin/uv" pip compile pyproject.toml requirements/installers.in --all-extras \
  --python-version 3.11 --python-platform x86_64-unknown-linux-gnu \
  --custom-compile-command infra/lock.sh --output-file requirements/constraints.txt "$@"
