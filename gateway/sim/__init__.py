"""The simulation on one simulated clock: Simulation and VehicleLink, scenarios, run logs, saved
parameters. No sockets, no wall clock."""
