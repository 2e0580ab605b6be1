"""The lab: evaluation, reports, benchmarks, training, dataset readers and the codebook recorder.

A robot does not need this package at run time. It imports the runtime and the simulation
(lab -> sim -> runtime), never the other way round.
"""
