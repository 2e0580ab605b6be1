"""Textile patch: dataset readers, evaluation, benchmark, reports and training."""
