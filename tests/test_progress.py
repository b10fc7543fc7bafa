"""The one progress bar: lines on a pipe at each tenth, nothing when disabled or quick."""

from __future__ import annotations

import io

from lgvtool.progress import Progress


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_pipe_gets_a_line_per_tenth_and_the_end() -> None:
    out = io.StringIO()
    with Progress(100, "work", stream=out, unit="s") as bar:
        for _ in range(100):
            bar.advance()
    lines = out.getvalue().splitlines()
    assert len(lines) == 11 and lines[-1].startswith("work [") and "100/100 s" in lines[-1]
    assert "\r" not in out.getvalue()


def test_terminal_redraws_in_place_and_ends_with_a_newline() -> None:
    out = Tty()
    with Progress(10, "t", stream=out, interval_s=0.0) as bar:
        for _ in range(10):
            bar.advance()
    text = out.getvalue()
    assert text.count("\r") >= 10 and text.endswith("\n") and text.count("\n") == 1


def test_disabled_and_delayed_bars_draw_nothing() -> None:
    for kw in ({"enabled": False}, {"delay_s": 60.0}):
        out = io.StringIO()
        with Progress(10, "x", stream=out, **kw) as bar:
            for _ in range(10):
                bar.advance()
            bar.stage("next", 5)
            bar.set(5)
        assert out.getvalue() == ""
        assert bar.done == 5 and bar.label == "next"


def test_stages_count_afresh_and_a_stopped_bar_says_so() -> None:
    out = io.StringIO()
    bar = Progress(4, "read", stream=out)
    bar.advance(4)
    bar.stage("write", 10)
    bar.advance(3)
    bar.close()
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("read [") and "4/4" in lines[0]
    assert lines[-1].startswith("write [") and "3/10" in lines[-1]
    assert lines[-1].endswith("(stopped)")


def test_a_bar_stopped_by_an_error_leaves_the_error_the_last_line() -> None:
    out = io.StringIO()
    try:
        with Progress(0, "calibrate", stream=out) as bar:
            bar.stage("read", 2)
            bar.advance()
            raise ValueError("bad input")
    except ValueError:
        pass
    lines = out.getvalue().splitlines()
    assert len(lines) == 1 and "1/2" in lines[0] and "(stopped)" not in lines[0]
    quiet = io.StringIO()
    with Progress(3, "read", stream=quiet) as bar:
        bar.stage("read", 3)  # nothing done yet: no line
    assert quiet.getvalue() == ""


def test_every_long_command_takes_no_progress(run_cli) -> None:
    for cmd in (["evaluate"], ["import", "mrclam"], ["replay"], ["sweep"], ["view"],
                ["calibrate"]):
        res = run_cli(*cmd, "--help", timeout=60)
        assert res.returncode == 0 and "--no-progress" in res.stdout, cmd


def test_no_progress_keeps_stderr_quiet(run_cli, tmp_path) -> None:
    log = tmp_path / "c.mcap"
    assert run_cli("simulate", "-s", "paper-circle", "--duration", "40", "-o", log,
                   timeout=120).returncode == 0
    res = run_cli("evaluate", log, "-o", tmp_path / "r", "--no-progress", timeout=300)
    assert res.returncode == 0, res.stderr
    assert "[#" not in res.stderr and "[." not in res.stderr


def test_a_delayed_bar_waits_longer_on_a_pipe_than_on_a_terminal() -> None:
    from lgvtool.progress import PIPE_DELAY_S

    assert Progress(5, "x", stream=io.StringIO(), delay_s=1.0).delay_s == PIPE_DELAY_S
    assert Progress(5, "x", stream=Tty(), delay_s=1.0).delay_s == 1.0
    assert Progress(5, "x", stream=io.StringIO()).delay_s == 0.0
