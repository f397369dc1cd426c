# Sourced by the set-up scripts: makes ./.venv with Python >= 3.11, installs the project
# (editable, with the extras named in $SRG_EXTRAS: `all` for every command, `all,test` for
# the tests) and puts .venv/bin first on PATH. Every package, pip and hatchling included,
# at its version in requirements/constraints.txt (refreshed by infra/lock.sh), so every
# machine installs what the tests passed with; hatchling, srg's build backend, matters too:
# tests/integration/test_installed_wheel.py builds srg's wheel with it, offline.
python_bin=${PYTHON:-python3.11}
if ! command -v "$python_bin" >/dev/null; then python_bin=python3; fi
if [ ! -x .venv/bin/python ]; then
  if ! "$python_bin" -m venv .venv 2>/dev/null; then
    echo "installing python3-venv (Debian)" >&2
    apt-get update -qq && apt-get install -y -qq python3-venv python3.11-venv >/dev/null
    rm -rf .venv && "$python_bin" -m venv .venv
  fi
fi
constraints=requirements/constraints.txt
.venv/bin/python -m pip install -q -c "$constraints" pip hatchling >/dev/null
.venv/bin/python -m pip install -q -c "$constraints" -e ".${SRG_EXTRAS:+[$SRG_EXTRAS]}"
export PATH="$PWD/.venv/bin:$PATH"
