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


def parameter_groups() -> list[tuple[str, type]]:
    """Every group of declared settings (:mod:`lgvtool.declared`), as a configuration file
    names its table: ``vehicle``, ``area``, ``reference``, ``reflectors``,
    ``estimators.<name>`` for every estimator, ``simulator.<section>`` for every section of
    the simulator, and ``simulator.scenario (<scenarios>)`` for the parameters of each kind of
    scenario (``--set`` takes the same keys without the ``estimators.``/``simulator.``
    prefix; a scenario's defaults may differ: ``fast`` drives at 0.72 m/s)."""
    from lgvtool.config import Area, Reference, Reflector, Vehicle
    from lgvtool.localize.registry import ESTIMATORS
    from lgvtool.sim.scenarios import SCENARIOS
    from lgvtool.sim.settings import SECTIONS

    groups: list[tuple[str, type]] = [("vehicle", Vehicle), ("area", Area),
                                      ("reference", Reference), ("reflectors", Reflector)]
    groups += [(f"estimators.{name}", ESTIMATORS[name].Params) for name in ESTIMATORS]
    groups += [(f"simulator.{name}", cls) for name, cls in SECTIONS.items()]
    by_type: dict[type, list[str]] = {}
    for name, scenario in SCENARIOS.items():
        by_type.setdefault(type(scenario.base), []).append(name)
    groups += [(f"simulator.scenario ({', '.join(names)})", cls)
               for cls, names in by_type.items()]
    return groups


def parameters(markdown: bool = False) -> JobOutput:
    """Every declared setting with its type, default, unit, range and meaning
    (``lgvtool config --parameters``): the document maps each group to its settings; the text
    is TOML of the defaults with the unit, range and meaning of each as a comment, or with
    ``markdown`` the tables the docs hold (one per group)."""
    from lgvtool.declared import declarations, default_text, json_value, markdown_table

    document: dict[str, list[dict[str, object]]] = {}
    blocks: list[str] = []
    tables: set[str] = set()
    for group, cls in parameter_groups():
        decls = declarations(cls)
        document[group] = [{
            "key": d.name, "type": d.kind.__name__, "default": json_value(d.default), "unit": d.unit,
            "range": d.range_text(), "required": d.required, "doc": d.doc} for d in decls]
        if markdown:
            blocks.append(f"#### `[{group}]`\n\n{markdown_table(cls)}\n")
            continue
        table, _, which = group.partition(" ")
        lines = [f"[[{table}]]" if table == "reflectors" else f"[{table}]"
                 + (f"  # {which.strip('()')}" if which else "")]
        again = table in tables  # a table TOML allows once: the later ones as comments
        tables.add(table)
        for d in decls:
            notes = "; ".join(x for x in (d.unit, d.range_text(), d.doc) if x)
            value = "# required" if d.required else default_text(d.default)
            lines.append(f"{d.name} = {value}".ljust(36) + f"  # {notes}" if not d.required
                         else f"# {d.name}: required; {notes}")
        blocks.append("\n".join(f"# {x}" if again else x for x in lines) + "\n")
    return JobOutput(document, "\n".join(blocks))
