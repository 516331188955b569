"""The gateway: what makes simulated vehicles look like PX4 SITL instances on the wire.

Rooms (docs/architecture.md), each importing only from the ones listed after it:
  cli.py       the single entry point (`cornet ...`)
  ci/          the CI kit: lockstep API (`gateway.testing.Sim`), pytest plugin, `cornet fly`, plots
  daemon/      the asyncio shell: UDP endpoints, the pacer (the only wall clock), systemd notify,
               metrics, sharding, the status line
  bus/         the state bus on ZeroMQ (publisher, `cornet watch`)
  sim/         the simulation on one simulated clock: Simulation, VehicleLink, scenarios, run logs,
               saved parameters
  mavlink/     the sans-IO MAVLink protocol: one Session per (vehicle, link), one module per service
  data/        the shipped files: scenarios, example plans, the systemd unit and its configuration
Below them all: vehicles/ (physics and autopilot) and netsim/ (event kernel and network).
"""
