"""The effective configuration (``lgvtool config``)."""

from __future__ import annotations

from lgvtool.app.job_output import JobOutput


def effective_config(file: str | None) -> JobOutput:
    """The defaults, ``file`` (TOML) over them, or, when ``file`` is a log (MCAP), the
    configuration its replay uses (:meth:`~lgvtool.log.LogReader.config`), checked: the
    document is the configuration as a dict, the text its TOML (lengths in m, angles in rad
    unless the key ends in _deg), which ``--config`` takes back.

    :raises ConfigError: (exit 2) the file is not valid TOML or holds a bad value.
    :raises LogFormatError: (exit 2) the log is unreadable or its stored configuration bad.
    """
    from lgvtool.config import load_config, to_toml
    from lgvtool.log.mcap_records import starts_with_magic
    from lgvtool.outputs import printable

    if file is not None and starts_with_magic(file):
        from lgvtool.log import LogReader

        cfg = LogReader(file).config()
    else:
        cfg = load_config(file)
    return JobOutput(cfg.to_dict(), printable(to_toml(cfg.to_dict())))
