"""Reflector layout files (``lgvtool layout``): lgvtool's ``[[reflectors]]`` TOML and SICK's
``.imk`` (:mod:`lgvtool.layout_file`)."""

from __future__ import annotations

from lgvtool.app.job_output import JobOutput


def convert_layout(source: str, output: str, *, layer: int | None = None,
                   force: bool = False) -> JobOutput:
    """Read the layout file ``source`` and write its reflectors (those of ``layer``, or all)
    to ``output``, each in the format its suffix names (``.imk``: SICK's; anything else:
    lgvtool's TOML). The document holds the counts and paths; the text is one line.

    :raises InputError: (exit 2) an unreadable or malformed source, no reflector in ``layer``,
        or a refused output (the source itself, an existing file without ``force``).
    """
    from pathlib import Path

    from lgvtool.errors import InputError
    from lgvtool.layout_file import read_layout, write_layout
    from lgvtool.outputs import guard_output

    guard_output(output, [source], force=force)
    reflectors = read_layout(source)
    if layer is not None:
        reflectors = tuple(r for r in reflectors if r.layer == layer)
        if not reflectors:
            raise InputError(f"layout convert: {source} has no reflector in layer {layer}")
    write_layout(output, reflectors, comment=f"reflector layout converted from "
                                             f"{Path(source).name}")
    fmt = "SICK .imk" if Path(output).suffix.lower() == ".imk" else "lgvtool TOML"
    document = {"input": source, "output": output, "reflectors": len(reflectors),
                "format": fmt}
    return JobOutput(document, f"{len(reflectors)} reflectors -> {output} ({fmt})")
