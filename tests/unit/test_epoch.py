"""Simulated t = 0 on the wall clock (the epoch) is stamped when the pacer starts time, after the
vehicles are built and their ports bound: PX4's SYSTEM_TIME carries the host's real-time clock,
so a vehicle whose clock started while the daemon was still building would run behind it."""

import asyncio
import json
import time

from pymavlink.dialects.v20 import common as mavlink2

from gateway.ci.ports import free_port_offset
from gateway.daemon.app import Daemon
from gateway.daemon.config import RunConfig
from gateway.mavlink.codec import Encoder
from gateway.mavlink.signing import MAVLINK_EPOCH_UNIX_S, TICKS_PER_S, SigningKey
from gateway.mavlink.snapshot import Snapshot
from gateway.mavlink.telemetry import system_time


def test_the_epoch_is_the_moment_time_starts_for_every_clock(tmp_path):
    d = Daemon(RunConfig(vehicles=2, log_dir=tmp_path, port_offset=free_port_offset(2),
                         signing_key=SigningKey(bytes(range(32)))))
    try:
        built = time.time()
        time.sleep(0.2)  # a daemon of many vehicles takes this long (and more) to build
        before_open = time.time()
        asyncio.run(d.open())
        after_open = time.time()
        sessions = [link.session for link in d.sim.links.values()]
        epoch = sessions[0].boot_unix_s
        assert epoch is not None and before_open <= epoch <= after_open and epoch > built + 0.1
        assert all(s.boot_unix_s == epoch for s in sessions)
        # SYSTEM_TIME at simulated t is the epoch plus t
        s = sessions[0]
        payload = system_time(s.encoder, Snapshot(s.vehicle, 2.5, s.boot_unix_s, s.samples,
                                                  s.link_telemetry))
        assert payload is not None
        assert int.from_bytes(payload[:8], "little") == int((epoch + 2.5) * 1e6)
        # the signing clock: 10 µs ticks since 2015-01-01 at simulated t = 0
        signer = s.encoder.signer
        assert signer is not None
        assert signer.clock.of(0.0) == round((epoch - MAVLINK_EPOCH_UNIX_S) * TICKS_PER_S)
        # the ULogs' names and the flight log's epoch
        assert all(logger.boot_unix_s == epoch for logger in d.logs.loggers.values())
        assert d.flightlog is not None
        meta = json.loads((d.flightlog.dir / "meta.json").read_text())
        assert meta["boot_unix_s"] == epoch
    finally:
        d.close()


def test_a_recorder_made_before_the_epoch_moves_stamps_with_the_new_one(tmp_path):
    from gateway.sim.flightlog import FlightLog, read_tlog
    from gateway.sim.simulation import Simulation

    sim = Simulation(1)
    flog = FlightLog(tmp_path, boot_unix_s=1_000.0)
    flog.attach(sim)
    kind = sim.link_kinds[0]
    record = flog.recorder("down", 0, kind)
    frame = Encoder(1, 1).pack(mavlink2.MAVLink_heartbeat_message, 2, 12, 0, 0, 3, 3)
    record([frame], 0.0)
    flog.set_epoch(2_000.0)
    record([frame], 0.0)  # the same instant: stamped with the epoch of now
    record([frame], 1.5)
    flog.close()
    stamps = [t for t, _ in read_tlog(tmp_path / next(iter(
        json.loads((tmp_path / "meta.json").read_text())["vehicles"][0]["tlogs"])))]
    assert stamps == [1_000.0, 2_000.0, 2_001.5]
    assert json.loads((tmp_path / "meta.json").read_text())["boot_unix_s"] == 2_000.0
