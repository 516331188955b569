"""The CI kit: the lockstep API, the pytest plugin and its daemon launcher, `cornet fly`,
flight-log checks and plots."""
