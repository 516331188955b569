"""The asyncio shell: UDP endpoints, the pacer (the only reader of the wall clock), systemd
notify, metrics, sharding, the status line."""
