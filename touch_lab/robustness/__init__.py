"""Robustness cases and figures of the whole stack, and ``social-touch report robustness`` (docs/robustness.md)."""
