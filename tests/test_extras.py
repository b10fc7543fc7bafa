"""A command whose extra is missing says which one to install, in one line."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from lgvtool.cli import main
from lgvtool.errors import InputError
from lgvtool.extras import available, require


def test_require_names_the_missing_module_and_the_extra() -> None:
    require("x", "fleet", "json")  # present: nothing raised
    assert available("json") and not available("no_such_module_for_lgvtool")
    with pytest.raises(InputError, match=r"y needs no_such_module_for_lgvtool \(not installed\): "
                                         r"pip install 'lgvtool\[calibrate\]'"):
        require("y", "calibrate", "json", "no_such_module_for_lgvtool")


def test_calibrate_without_scipy_is_one_line(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "scipy" else real(name, *a))
    log = Path(__file__).resolve().parents[1] / "sample_logs" / "paper-circle.mcap"
    with pytest.raises(SystemExit) as exc:
        main(["calibrate", str(log), "-o", str(tmp_path / "v.toml"),
              "--no-progress"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "pip install 'lgvtool[calibrate]'" in err[0]
