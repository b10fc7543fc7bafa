"""A command whose extra is missing says which one to install, in one line, with the command
that installs it the way this lgvtool was installed (README.md: ``pip install '.[NAME]'`` in
the project folder)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from lgvtool import extras
from lgvtool.cli import main
from lgvtool.errors import InputError
from lgvtool.extras import available, install_hint, install_source, require

REPO = Path(__file__).resolve().parents[1]


def test_require_names_the_missing_module_and_the_extra() -> None:
    require("x", "fleet", "json")  # present: nothing raised
    assert available("json") and not available("no_such_module_for_lgvtool")
    with pytest.raises(InputError) as exc:
        require("y", "calibrate", "json", "no_such_module_for_lgvtool")
    assert str(exc.value) == ("y needs no_such_module_for_lgvtool (not installed): "
                              + install_hint("calibrate"))


def test_the_hint_matches_how_lgvtool_was_installed(monkeypatch: pytest.MonkeyPatch) -> None:
    # the tests run from a source checkout: the hint is README's command, from its folder
    folder, _ = install_source()
    assert folder == REPO
    assert "'.[fleet]' from the project folder" in install_hint("fleet")
    monkeypatch.setattr(extras, "install_source", lambda: (Path("/src/lgvtool"), False))
    assert install_hint("ros2") == "pip install '.[ros2]' from the project folder (/src/lgvtool)"
    monkeypatch.setattr(extras, "install_source", lambda: (Path("/src/lgvtool"), True))
    assert install_hint("ros2") == ("pip install -e '.[ros2]' from the project folder "
                                    "(/src/lgvtool)")
    # a package from an index or a wheel, its source folder unknown
    monkeypatch.setattr(extras, "install_source", lambda: (None, False))
    assert install_hint("live") == "pip install 'lgvtool[live]'"


def test_a_non_editable_install_from_a_folder_names_that_folder(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """``pip install .`` (README's install) runs lgvtool from site-packages; the folder comes
    from the distribution's direct_url.json."""
    site = tmp_path / "site-packages" / "lgvtool"
    site.mkdir(parents=True)
    project = tmp_path / "my checkout"
    project.mkdir()
    (project / "pyproject.toml").write_text('[project]\nname = "lgvtool"\n')
    monkeypatch.setattr(extras, "__file__", str(site / "extras.py"))
    monkeypatch.setattr(extras, "_direct_url", lambda: {
        "url": project.as_uri(), "dir_info": {}})
    assert install_source() == (project.resolve(), False)
    monkeypatch.setattr(extras, "_direct_url", lambda: {
        "url": "https://example.invalid/lgvtool.whl", "archive_info": {}})
    assert install_source() == (None, False)
    assert install_hint("fleet") == "pip install 'lgvtool[fleet]'"


def test_calibrate_without_scipy_is_one_line(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "scipy" else real(name, *a))
    log = REPO / "sample_logs" / "paper-circle.mcap"
    with pytest.raises(SystemExit) as exc:
        main(["calibrate", str(log), "-o", str(tmp_path / "v.toml"),
              "--no-progress"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and install_hint("calibrate") in err[0]
    assert "'.[calibrate]'" in err[0] and "lgvtool[calibrate]" not in err[0]
