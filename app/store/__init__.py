"""Translate between the database / artifact files and core types.

Every SQL statement of the use cases lives here, and so does the graph lock
(:mod:`app.store.locks`). Every function takes the caller's ``session`` and never
commits: the task, route or CLI command that calls it owns the transaction.
"""
