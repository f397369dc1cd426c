"""The paper's evaluation (section 7; docs/design.md, "Evaluation") on stored graphs, resumable.

An experiment grows one stored graph per run from the same initial tree through the
checkpoints: one for a strategy that reads no traces (every seed's bots of every crowd
play it), one per crowd and seed for sr-crowd (that seed's bots of its own crowd play
it). At each checkpoint the graph is published (pre-publish relinking, no renders: bots
play edges, not pictures), STATERANK predicts play on that publication from the
strategy's player model (for sr-crowd, learned from the traces of earlier checkpoints
only), the run's bots play it, and the numbers of Figs. 5-9 and section 7.1 are taken;
the bots' traces are stored, so sr-crowd learns from them as it grows on. The
publication, the traces and the checkpoint's rows commit together, so a checkpoint is
either complete or absent; growth commits step by step and is a deterministic function
of the stored graph and traces. Hence ``--resume`` after an interruption gives the
numbers of an uninterrupted run (docs/experiment.md).

The rooms: :mod:`.plan` (what an experiment runs, stored once), :mod:`.runs` (the runs
through their checkpoints, in parallel processes), :mod:`.checkpoint` (one checkpoint's
publication, prediction, play and figures) and :mod:`.results` (the stored rows read
back, the summary, and sr-crowd against baseline per crowd with its interval).
"""
