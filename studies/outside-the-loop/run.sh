#!/usr/bin/env bash
# The study's runs exactly as plan.md gives them, from a checkout of the plan's commit of
# its own (made here when missing), database and artifacts outside any work tree.
#   bash studies/outside-the-loop/run.sh           start (through 10k, the first milestone)
#   bash studies/outside-the-loop/run.sh resume    go on to the end (or: resume --through N)
# Further arguments go to `srg experiment`. SRG_STUDY_CODE names another checkout to run
# (run-worlds.sh starts the experiment from its own, with --only-seeds).
set -euo pipefail
repo=$(git -C "$(dirname "$0")" rev-parse --show-toplevel)
home=${SRG_STUDY_DIR:-/var/tmp/srg-outside}
plan_commit=3b1f6198c271f2009eac97cf5c84720fe09b96bc
code=${SRG_STUDY_CODE:-$home/code}
mkdir -p "$home"
if [ ! -d "$code" ]; then
  git -C "$repo" worktree add --detach "$code" "$plan_commit"
fi
cd "$code"
export PYTHONPATH=$PWD SRG_VAR_DIR=$home PATH=$repo/.venv/bin:$PATH
srg db upgrade
if [ "${1:-}" = resume ]; then
  shift
  exec srg experiment --resume --name outside-the-loop --jobs 2 "$@"
fi
exec srg experiment --dynamics liquid --preset tiny --fluid low \
  --strategies baseline,sr-heuristic,sr-crowd --player-model mixed-error \
  --bots goal-directed,hesitant,avoider --pooled --shares 0.5,0.3,0.2 \
  --fresh-judges --judges heuristic,random \
  --seeds 20,21,22,23,24,25,26,27,28,29 \
  --checkpoints 1000,2000,3000,5000,7000,10000,20000 --sessions 30 \
  --preregistration studies/outside-the-loop/plan.md \
  --name outside-the-loop --jobs 2 --through 10000 "$@"
