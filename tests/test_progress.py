"""The progress display draws on a TTY only, never when quiet, and always ends its line."""

from __future__ import annotations

import io

import pytest

from mjtrack.progress import Progress, progress


class FakeTTY(io.StringIO):
    def isatty(self) -> bool:
        return True


class Clock:
    """A clock that advances 1 s per reading: every update redraws, times are exact."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 1.0
        return self.now


def test_draws_counts_and_time_on_a_tty():
    tty = FakeTTY()
    items = list(progress(range(4), label="rollouts", stream=tty, clock=Clock()))
    assert items == [0, 1, 2, 3]
    text = tty.getvalue()
    assert text.endswith("\n") and text.count("\n") == 1
    frames = [f.rstrip() for f in text.rstrip("\n").split("\r")[1:]]
    assert frames[0].startswith("rollouts  [#####---------------]  1/4   25%  ")
    assert frames[-1].startswith("rollouts  [####################]  4/4  100%  ")
    assert "~0:" in frames[0] and "left" in frames[0]  # an estimate while running


def test_unknown_total_and_note():
    tty = FakeTTY()
    with Progress(label="EKF", stream=tty, clock=Clock()) as bar:
        bar.update(3, note="NIS 1.02")
    assert "EKF  3  0:" in tty.getvalue() and "NIS 1.02" in tty.getvalue()


@pytest.mark.parametrize("quiet, stream", [(True, FakeTTY()), (False, io.StringIO())], ids=["quiet", "not-a-tty"])
def test_silent(quiet, stream):
    assert list(progress([1, 2, 3], label="x", quiet=quiet, stream=stream)) == [1, 2, 3]
    assert stream.getvalue() == ""


def test_default_stream_is_stderr_and_silent_in_tests(capsys):
    with Progress(total=2, label="x") as bar:
        bar.update(2)
    assert capsys.readouterr().err == ""  # pytest's captured stderr is not a TTY


def test_line_ends_even_on_error():
    tty = FakeTTY()
    with pytest.raises(KeyError):
        for _ in progress(range(10), stream=tty, clock=Clock()):
            raise KeyError("boom")
    assert tty.getvalue().endswith("\n")


def test_redraws_are_throttled():
    tty = FakeTTY()
    with Progress(total=1000, stream=tty, clock=lambda: 5.0, min_interval=0.1) as bar:
        for _ in range(1000):
            bar.update()
    assert tty.getvalue().count("\r") == 2  # the first update and the final state
    assert "1000/1000" in tty.getvalue()


def test_a_said_line_stands_above_the_bar_which_is_drawn_again():
    tty = FakeTTY()
    with Progress(total=10, label="calibrate", stream=tty, clock=Clock()) as bar:
        bar.update(2, note="fit")
        bar.say("calibrate: about 0:40 expected")
        bar.update(3)
    lines = tty.getvalue().split("\n")
    frame, wipe, said = lines[0].split("\r")[1:]
    assert frame.startswith("calibrate  [####------")
    assert wipe == " " * len(frame)  # the frame is wiped, not left half-overwritten
    assert said == "calibrate: about 0:40 expected"  # on a line of its own
    assert lines[1].split("\r")[-1].startswith("calibrate  [##########----------]   5/10") and lines[-1] == ""


def test_said_lines_are_silent_when_quiet_or_not_a_tty():
    for quiet, stream in ((True, FakeTTY()), (False, io.StringIO())):
        with Progress(total=2, stream=stream, quiet=quiet) as bar:
            bar.say("hello")
        assert stream.getvalue() == ""
