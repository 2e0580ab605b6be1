"""Optoelectronic skin: trace datasets, evaluation, benchmark, reports and the codebook recorder."""
