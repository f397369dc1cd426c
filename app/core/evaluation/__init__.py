"""Evaluation: what players met on a publication, and strategies compared over worlds."""
