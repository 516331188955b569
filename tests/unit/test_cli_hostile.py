"""Hostile flag values: each makes `cornet` exit 2 with one line naming the flag and what to fix,
before anything starts (no traceback, no daemon on a bad value, no flight lost to a bad report
path)."""

from __future__ import annotations

import pytest

from gateway.cli import main


def outcome(argv: list[str], capsys) -> tuple[int, str]:
    try:
        rc = main(argv)
    except SystemExit as exc:
        rc = exc.code if isinstance(exc.code, int) else 1
    return rc, capsys.readouterr().err


@pytest.fixture(autouse=True)
def _elsewhere(tmp_path, monkeypatch):
    # A regression that accepted a value would start a run: let it write nowhere that matters.
    monkeypatch.chdir(tmp_path)


@pytest.fixture
def garbage(tmp_path):
    path = tmp_path / "garbage.plan"
    path.write_bytes(b"\x00\xff\xfe garbage")
    return path


@pytest.mark.parametrize("argv, flag", [
    # one link's delay is at most netsim.models.base.MAX_DELAY_S: refused by the flag, not by a
    # ValueError from the link model once the daemon builds its network
    (["run", "--latency-ms", "inf"], "--latency-ms"),
    (["run", "--latency-ms", "1e308"], "--latency-ms"),
    (["run", "--jitter-ms", "60001"], "--jitter-ms"),
    (["fly", "square", "--no-log", "--latency-ms", "inf"], "--latency-ms"),
    (["fly", "square", "--no-log", "--jitter-ms", "1e308"], "--jitter-ms"),
    (["sweep", "square", "--latency-ms", "0,1e308"], "--latency-ms"),
    # an empty path is pathlib's "." (the working directory): never what was meant
    (["run", "--state-dir", ""], "--state-dir"),
    (["run", "--log-dir", ""], "--log-dir"),
    (["run", "--packet-trace", ""], "--packet-trace"),
    (["run", "--config", ""], "--config"),
    (["run", "--signing-key", ""], "--signing-key"),
    (["fly", "square", "--log-dir", ""], "--log-dir"),
    (["fly", ""], "PLAN"),
    (["plot", ""], "LOGDIR"),
    (["check", ""], "FILE|NAME"),
    (["sweep", "square", "--out", ""], "--out"),
    # an endpoint that is none: an empty one used to turn the publisher off silently
    (["run", "--zmq-pub", ""], "--zmq-pub"),
    (["run", "--zmq-pub", "garbage"], "--zmq-pub"),
    (["watch", "--zmq", "garbage"], "--zmq"),
    (["stats", "--zmq", ""], "--zmq"),
    # a file to write that is a directory, or in none
    (["run", "--packet-trace", "/"], "--packet-trace"),
    (["fly", "square", "--no-log", "--junit-xml", "/"], "--junit-xml"),
    (["fly", "square", "--no-log", "--summary", "/proc/no-such-dir/s.md"], "--summary"),
    # a path that opens but takes no write (even for root): refused at the start, not at the
    # first datagram; a file given as a directory
    (["run", "--packet-trace", "/proc/version", "--duration", "0.5", "--speed", "max"],
     "--packet-trace"),
    (["run", "--packet-trace", "/dev/full", "--duration", "0.5", "--speed", "max"],
     "--packet-trace"),
    (["fly", "square", "--no-log", "--junit-xml", "/dev/full"], "--junit-xml"),
    (["run", "--log-dir", "/proc/version"], "--log-dir"),
    (["run", "--state-dir", "/proc"], "--state-dir"),
])
def test_a_hostile_flag_exits_2_naming_it(argv, flag, capsys):
    rc, err = outcome(argv, capsys)
    assert rc == 2, err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert flag in last, err


def test_a_plan_that_is_not_text_is_refused_naming_the_file(garbage, capsys):
    rc, err = outcome(["fly", str(garbage), "--no-log"], capsys)
    assert rc == 2 and "Traceback" not in err
    assert str(garbage) in err and "UTF-8" in err


def test_a_bind_address_of_another_machine_names_bind(capsys):
    # 192.0.2.1 (TEST-NET-1, RFC 5737) is no address of this machine: EADDRNOTAVAIL
    rc, err = outcome(["run", "--bind", "192.0.2.1", "--duration", "1", "--speed", "max"],
                      capsys)
    assert rc == 2 and "Traceback" not in err
    assert "--bind" in err.strip().splitlines()[-1]


@pytest.mark.parametrize("argv, says", [
    (["run", "--packet-trace", "/proc/version"], "; give a file you can write"),
    (["run", "--log-dir", "/proc/version"], "is a file, not a directory; give a directory"),
])
def test_the_refusal_says_what_to_fix(argv, says, capsys):
    rc, err = outcome(argv + ["--duration", "0.5", "--speed", "max"], capsys)
    assert rc == 2 and says in err.strip().splitlines()[-1], err


def test_the_write_probe_leaves_files_as_they_were(tmp_path):
    import argparse

    from gateway.cli_args import writable_file

    parser = argparse.ArgumentParser()
    kept = tmp_path / "kept.txt"
    kept.write_text("old trace\n")
    writable_file(parser, kept, "--packet-trace")
    writable_file(parser, tmp_path / "new.txt", "--packet-trace")
    assert kept.read_text() == "old trace\n" and not (tmp_path / "new.txt").exists()
