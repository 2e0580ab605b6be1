"""Virtual textile patch: the device model behind ``patchsim://`` and simulated people (synthetic)."""
