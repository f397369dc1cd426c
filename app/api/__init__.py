"""The HTTP API and the web client (DESIGN section 6)."""
