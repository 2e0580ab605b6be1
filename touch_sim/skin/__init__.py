"""Virtual optoelectronic skin: contact model, stimuli, the device behind ``skinsim://``, simulated people
and synthetic traces, and rendering of traces through the virtual skin (synthetic)."""
