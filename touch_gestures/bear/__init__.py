"""Sensate Bear recognisers (knight2009 V.C-V.E): sensor level, touch subtypes, symbolic gestures.

Pure classes with no graph code, in the order of the paper's processing paths (Fig. 5):

- :mod:`.sensor_level`: the ring buffer of the last N cycles of every channel and the active set
  named through the body map (V.C);
- :mod:`.features`: per-sensor buffer features (peak amplitude, base frequency, spectral spread,
  duration) for all channels at once (V.D, Table II);
- :mod:`.subtype`: the paper's rule (V.D pseudocode) and a trainable eight-subtype classifier
  (Table I), one subtype per sensor, with change events;
- :mod:`.symbolic`: locational filters and priority logic from ``config/bear_gestures.yaml`` (V.E);
- :mod:`.pipeline`: the three paths run together, one call per scan cycle;
- :mod:`.gate`: the no-touch gate in front of the trained model;
- :mod:`.node`: ``bear_gestures``, the recognisers on the graph.

Simulated people are in :mod:`touch_sim.bear`; evaluation, benchmark, reports and training in
:mod:`touch_lab.bear`.
"""
