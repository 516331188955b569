"""cli_args.writable_dir: a directory is made if need be and probed with a file of its own, so
processes checking the same directory at once (the ranks of a sharded run) never trip over one
another's probe; nothing is left behind."""

import argparse
import threading

import pytest

from gateway.cli_args import writable_dir


def test_concurrent_checks_of_one_directory_all_pass_and_leave_nothing(tmp_path):
    parser = argparse.ArgumentParser()
    target = tmp_path / "logs"
    errors: list[BaseException] = []

    def check() -> None:
        try:
            for _ in range(200):
                writable_dir(parser, target, "--log-dir")
        except BaseException as exc:  # parser.error raises SystemExit
            errors.append(exc)

    threads = [threading.Thread(target=check) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert list(target.iterdir()) == []


def test_a_file_in_the_way_is_exit_2(tmp_path, capsys):
    (tmp_path / "f").write_text("")
    with pytest.raises(SystemExit) as exc:
        writable_dir(argparse.ArgumentParser(), tmp_path / "f", "--log-dir")
    assert exc.value.code == 2
    assert "--log-dir" in capsys.readouterr().err
