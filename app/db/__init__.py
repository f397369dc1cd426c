"""The database: engines and sessions from Settings, srg's migrations, and what a
database error means to the user.

:mod:`.engines` makes the engines (SQLite set up to behave like a server database, the
embedded default migrated on first use); :mod:`.sessions` opens the unit of work that
callers own; :mod:`.migrations` finds Alembic's migrations in a checkout or a wheel and
checks a database is at their head; a run of them keeps every row and value or changes
nothing (:mod:`.data_loss`), with SQLite's foreign keys off around it and checked after
(:mod:`.foreign_keys`); :mod:`.errors` says when a database error means the database
cannot serve, in one line for the CLI and a 503 for the API.
"""
