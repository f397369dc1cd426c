"""Translate between the database / artifact files and core types.

Every SQL statement of the use cases lives here, and so does the graph lock
(:mod:`app.store.locks`). Every function takes the caller's ``session``, and all but one
leave the commit to the task, route or CLI command that calls them, which owns the
transaction. The one that commits is :func:`app.store.transactions.in_transaction`, the
routes' way to write: it runs the work it is given and commits it, and on SQLite's
"database is locked" rolls back and runs the work again, which only the owner of the
whole transaction can do (the lock error can come from the commit itself).
"""
