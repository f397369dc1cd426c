"""The calibrations of the liquid presets, one JSON file each (read by
:mod:`app.liquid.calibration`); a package so that the wheel carries them as package data."""
