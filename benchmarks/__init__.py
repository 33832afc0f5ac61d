"""Benchmarks: peers compared in the same run, ratios printed."""
