"""``calibench discover``: the engine's front end, one plug-in per instrument, the concealed-effect
suite and the twin written back."""
