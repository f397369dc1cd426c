"""The liquid as a pluggable dynamics: the adapter and the devices it runs on, its
calibration (with the visible-error threshold study) and its validation."""
