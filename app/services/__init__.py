"""Use cases shared by the CLI, the Celery tasks and the HTTP API."""
