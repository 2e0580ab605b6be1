"""Sensate Bear: evaluation, benchmark, reports and training on simulated people."""
