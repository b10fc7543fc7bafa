"""The effective configuration (``lgvtool config``)."""

from __future__ import annotations

from lgvtool.app.job_output import JobOutput


def effective_config(file: str | None) -> JobOutput:
    """The defaults, or ``file`` (TOML) over them, checked: the document is the configuration
    as a dict, the text its TOML (lengths in m, angles in rad unless the key ends in _deg).

    :raises ConfigError: (exit 2) the file is not valid TOML or holds a bad value.
    """
    from lgvtool.config import load_config, to_toml
    from lgvtool.outputs import printable

    cfg = load_config(file)
    return JobOutput(cfg.to_dict(), printable(to_toml(cfg.to_dict())))
