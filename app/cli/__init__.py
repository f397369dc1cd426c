"""The command line: one module per command group, one for output (``app.cli.output``)."""
