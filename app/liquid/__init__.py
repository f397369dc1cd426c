"""The liquid as a pluggable dynamics: the adapter, its calibration and its validation."""
