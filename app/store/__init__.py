"""Translate between the database / artifact files and core types.

Every function takes the caller's ``session`` and never commits: the task, route or
CLI command that calls it owns the transaction.
"""
