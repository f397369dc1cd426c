"""The HTTP API and the web client (docs/design.md, "Play")."""
