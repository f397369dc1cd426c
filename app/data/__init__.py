"""Reference data sets shipped with the package (read with importlib.resources)."""
