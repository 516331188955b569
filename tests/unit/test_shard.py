import importlib
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from gateway.daemon.app import RunConfig
from gateway.daemon.shard import ShardError, check, in_mpi_job, mpiexec_command, split
from gateway.sim.scenario import NetworkConfig
from gateway.sim.simulation import Simulation


def test_split_is_contiguous_and_balanced():
    assert split(5, 2) == [(0, 3), (3, 2)]
    assert split(200, 2) == [(0, 100), (100, 100)]
    assert split(3, 3) == [(0, 1), (1, 1), (2, 1)]
    parts = split(101, 4)
    assert sum(n for _, n in parts) == 101 and max(n for _, n in parts) - min(
        n for _, n in parts) <= 1


@pytest.mark.parametrize("changes, words", [
    ({"shards": 0}, "at least 1"),
    ({"shards": 3, "vehicles": 2}, "more than --vehicles"),
    ({"shards": 2, "vehicles": 2, "network": NetworkConfig(backend="ns3")}, "embedded"),
])
def test_what_cannot_run_sharded_is_named(changes, words):
    assert words in check(replace(RunConfig(), **changes))


def test_one_shard_and_plain_sharding_are_fine():
    assert check(RunConfig()) is None
    assert check(RunConfig(vehicles=4, shards=2)) is None
    assert check(RunConfig(vehicles=4, shards=2, zmq_pub="tcp://127.0.0.1:5556",
                           metrics_port=9464, web=("127.0.0.1", 8080))) is None


def test_a_shard_simulates_its_block_and_its_network_sees_the_others():
    sim = Simulation(2, first_index=3)
    try:
        assert sim.indices == [3, 4]
        assert [int(v.params["MAV_SYS_ID"]) for v in sim.vehicles] == [4, 5]
        assert set(sim.vehicle_positions_ned_m()) == {"v4", "v5"}
        reported = []
        sim.on_sync = lambda t, pos: reported.append((t, sorted(pos)))
        sim.remote_positions = {"v1": (100.0, 0.0, -10.0)}
        sim.run(until=0.05)
        assert reported[0] == (0.0, ["v4", "v5"]) and len(reported) == 3
        assert sim.backend.mobility.positions["v1"] == (100.0, 0.0, -10.0)
        assert set(sim.backend.mobility.positions) >= {"v1", "v4", "v5"}
        assert {name[:3] for name in sim.link_stats()} == {"v4/", "v5/"}
    finally:
        sim.close()


def test_a_process_started_by_an_mpi_launcher_is_a_rank():
    assert in_mpi_job({"PMI_RANK": "0", "PMI_SIZE": "3"})  # MPICH's hydra, Intel MPI
    assert in_mpi_job({"OMPI_COMM_WORLD_RANK": "2"})  # Open MPI
    assert not in_mpi_job({"PATH": "/usr/bin"})


def test_the_launcher_runs_the_same_command_line_in_k_plus_one_ranks():
    command = mpiexec_command(3, ["run", "--vehicles", "6", "--shards", "3"])
    assert Path(command[0]).name == "mpiexec" and command[1:3] == ["-n", "4"]
    assert command[3:] == [sys.executable, "-m", "gateway.entry",
                           "run", "--vehicles", "6", "--shards", "3"]


def test_without_mpi4py_the_launcher_says_how_to_get_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "mpi4py", None)
    with pytest.raises(ShardError, match=r"pip install 'cornet\[mpi\]'") as caught:
        mpiexec_command(2, ["run", "--shards", "2"])
    assert caught.value.code == 2


def test_a_rank_that_fails_ends_the_job(monkeypatch, capsys):
    """end_job_if_rank: in a rank, a refused flag (SystemExit 2) aborts the job with 2 and an
    exception with 1 (its traceback printed); outside an MPI job, or on exit 0, nothing."""
    import importlib

    launch = importlib.import_module("gateway.daemon.shard.launch")  # the module, not launch()
    aborted: list[int] = []
    monkeypatch.setattr(launch, "abort_job", aborted.append)
    for name in launch.MPI_RANK_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    launch.end_job_if_rank(SystemExit(2))
    assert aborted == []
    monkeypatch.setenv("PMI_RANK", "1")
    launch.end_job_if_rank(SystemExit(0))
    launch.end_job_if_rank(SystemExit(2))
    launch.end_job_if_rank(ValueError("boom"))
    assert aborted == [2, 1]
    assert "ValueError: boom" in capsys.readouterr().err


class _Job:
    def __init__(self) -> None:
        self.sent: list[int] = []

    def send_signal(self, signum: int) -> None:
        self.sent.append(signum)


def test_the_launcher_holds_signals_until_every_rank_is_armed(tmp_path, monkeypatch):
    """launch._Relay: a signal that comes while a rank is still starting waits until every rank
    has said (mark_armed) that its handlers are in place, then goes out in order; a SIGHUP goes
    out as SIGUSR1 once the reload flag counts it; afterwards signals go out at once."""
    import signal

    L = importlib.import_module("gateway.daemon.shard.launch")  # the module, not launch()

    armed = tmp_path / "armed"
    armed.mkdir()
    flag = str(tmp_path / "reload")
    relay = L._Relay(3, flag, str(armed))
    relay.job = job = _Job()
    relay._on_signal(signal.SIGHUP, None)
    relay._on_signal(signal.SIGINT, None)
    relay.poll()
    assert job.sent == [] and not (tmp_path / "reload").exists()
    for pid in (11, 12, 12):  # a rank that says it twice counts once
        monkeypatch.setattr(L.os, "getpid", lambda pid=pid: pid)
        L.mark_armed({L.ARMED_DIR_VARIABLE: str(armed)})
    relay.poll()
    assert job.sent == []  # two of three
    monkeypatch.setattr(L.os, "getpid", lambda: 13)
    L.mark_armed({L.ARMED_DIR_VARIABLE: str(armed)})
    relay.poll()
    assert job.sent == [signal.SIGUSR1, signal.SIGINT]
    assert (tmp_path / "reload").read_text() == "1"
    relay._on_signal(signal.SIGHUP, None)
    assert job.sent[-1] == signal.SIGUSR1 and (tmp_path / "reload").read_text() == "2"
    L.mark_armed({})  # outside a launched job: nothing
    assert len(list(armed.iterdir())) == 3


def test_a_second_ctrl_c_goes_out_at_once_with_what_was_held(tmp_path):
    import signal

    L = importlib.import_module("gateway.daemon.shard.launch")  # the module, not launch()

    relay = L._Relay(3, str(tmp_path / "reload"), str(tmp_path))
    relay.job = job = _Job()
    relay._on_signal(signal.SIGUSR1, None)
    relay._on_signal(signal.SIGTERM, None)
    assert job.sent == []
    relay._on_signal(signal.SIGINT, None)
    assert job.sent == [signal.SIGUSR1, signal.SIGTERM, signal.SIGINT]
