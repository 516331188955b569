"""The sans-IO MAVLink protocol: one Session per (vehicle, link), one module per microservice."""
