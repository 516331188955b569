import io

from gateway.daemon.progress import ERASE_LINE, ProgressLine, bar


def test_bar_is_clamped_and_fixed_width():
    assert bar(0.0) == "[" + "." * 24 + "]   0%"
    assert bar(0.5).startswith("[" + "#" * 12 + "." * 12 + "]")
    assert bar(7.0) == "[" + "#" * 24 + "] 100%"
    assert bar(-1.0) == bar(0.0)


def test_tty_redraws_in_place_throttled_by_the_wall_clock_and_ends_the_line():
    out, wall = io.StringIO(), [0.0]
    line = ProgressLine(out, tty=True, redraw_s=0.1, clock=lambda: wall[0])
    line.update(1.0, "t=1 s", fraction=0.25)
    line.update(2.0, "t=2 s")  # same wall instant: skipped
    wall[0] = 0.2
    line.update(3.0, "t=3 s")
    line.close()
    assert out.getvalue() == (ERASE_LINE + "[" + "#" * 6 + "." * 18 + "]  25% t=1 s"
                              + ERASE_LINE + "t=3 s\n")


def test_plain_output_prints_whole_lines_every_period_of_simulated_time():
    out = io.StringIO()
    line = ProgressLine(out, tty=False, plain_period_s=10.0, clock=lambda: 0.0)
    for t in range(0, 35):
        line.update(float(t), f"t={t} s", fraction=t / 35)
    line.update(35.0, "done", force=True)
    line.close()
    assert out.getvalue() == "t=0 s\nt=10 s\nt=20 s\nt=30 s\ndone\n"
    assert "\r" not in out.getvalue() and "#" not in out.getvalue()


def test_a_stream_that_is_not_a_terminal_gets_plain_lines():
    assert ProgressLine(io.StringIO()).tty is False
