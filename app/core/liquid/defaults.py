"""The liquid's default preset and fluid, by name: what a command uses where none is named,
kept apart from the scenes so that the CLI names them without importing the numerics."""

#: the fluid wherever none is named: water; its scenes and calibrations carry no suffix
DEFAULT_FLUID = "low"
#: the liquid preset wherever none is named (`srg init`, `srg experiment`, `srg calibrate`,
#: `srg validate`, a stored graph without one): the one calibrated and validated in full
#: (docs/liquid.md)
DEFAULT_LIQUID_PRESET = "small"
#: the preset of the runs meant to take minutes on a laptop: `srg demo` and the liquid
#: runs of `srg bench grow` (1.9k particles: the two strategies part within 1.5k frames)
QUICK_LIQUID_PRESET = "tiny"
