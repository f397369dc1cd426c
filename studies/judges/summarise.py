"""sr-crowd / sr-heuristic of what the outside player met, per seed and over seeds
(geometric mean, Student t interval on the log ratios), from outside_player.py's lines
read in pairs (sr-heuristic's graph, then sr-crowd's) on stdin."""

import json
import sys

import numpy as np
from scipy import stats

lines = [json.loads(line) for line in sys.stdin if line.strip()]
pairs = list(zip(lines[0::2], lines[1::2], strict=True))
ratios = np.array([crowd["mean_error"] / heuristic["mean_error"] for heuristic, crowd in pairs])
logs = np.log(ratios)
half = stats.t.ppf(0.975, logs.size - 1) * logs.std(ddof=1) / np.sqrt(logs.size)
for (heuristic, crowd), ratio in zip(pairs, ratios, strict=True):
    print(
        f"{crowd['graph']} ({crowd['size_frames']} frames): error {crowd['mean_error']:.5f} "
        f"against {heuristic['mean_error']:.5f}, ratio {ratio:.2f}; visibly wrong "
        f"{crowd['high_error_fraction']:.3f} against {heuristic['high_error_fraction']:.3f}"
    )
print(
    f"sr-crowd / sr-heuristic: {np.exp(logs.mean()):.2f} "
    f"[{np.exp(logs.mean() - half):.2f}, {np.exp(logs.mean() + half):.2f}] "
    "(geometric mean over seeds, 95 % Student t on log ratios)"
)
