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
- :mod:`.scene`: simulated people (Table II statistics) scripting labelled interactions (synthetic);
- :mod:`.chain`, :mod:`.evaluate`, :mod:`.bench`, :mod:`.report`, :mod:`.cli`, :mod:`.train`: evaluation,
  benchmark, reports, the `social-touch eval bear` command and model training.
"""
