"""Benchmarks (`srg bench ...`): shells beside the CLI that measure the layers below."""
