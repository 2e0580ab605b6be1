"""Virtual Sensate Bear: the device model behind ``bearsim://`` and simulated people (synthetic)."""
