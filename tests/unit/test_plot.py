"""`cornet plot`: three valid, non-empty PNGs from a lockstep run's flight logs."""

import struct

from gateway.ci.lockstep import Sim, mission_item
from gateway.ci.plot import OUTPUTS, main, plot
from gateway.sim.scenario import NetworkConfig
from vehicles.plan_types import MavCmd
from vehicles.types import PX4_SITL_HOME

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == PNG_SIGNATURE and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_three_pngs_from_a_short_mission(tmp_path):
    run = tmp_path / "runs" / "run-1"
    net = NetworkConfig.from_flags(latency_ms=30, jitter_ms=5, loss=0.05, seed=2)
    with Sim(1, net, log_dir=run) as sim:
        g = PX4_SITL_HOME.offset_ned(15, 5, 0)
        sim.run_until(lambda: sim.status().position_valid, 5)
        sim.api().upload_mission([mission_item(MavCmd.NAV_TAKEOFF, g.lat_deg, g.lon_deg, 4),
                                  mission_item(MavCmd.NAV_WAYPOINT, g.lat_deg, g.lon_deg, 4),
                                  mission_item(MavCmd.NAV_LAND, g.lat_deg, g.lon_deg, 0)])
        sim.api().arm()
        sim.api().start_mission()
        sim.advance(12.0)
    paths = plot(tmp_path / "runs")  # a base directory: its newest run is plotted
    assert [p.name for p in paths] == list(OUTPUTS)
    for p in paths:
        data = p.read_bytes()
        width, height = png_size(data)
        assert width >= 400 and height >= 300 and len(data) > 10_000
        assert p.parent == run


def test_no_log_exits_2(tmp_path, capsys):
    assert main(tmp_path) == 2
    assert "no flight log" in capsys.readouterr().err
