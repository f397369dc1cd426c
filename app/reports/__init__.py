"""Reports for people: PNG plots (matplotlib) and markdown."""
