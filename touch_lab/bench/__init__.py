"""Benchmarks behind ``social-touch bench``: medians of repeated runs on this machine."""
