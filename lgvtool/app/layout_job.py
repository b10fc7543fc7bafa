"""Reflector layout files (``lgvtool layout``): lgvtool's ``[[reflectors]]`` TOML and SICK's
``.imk`` (:mod:`lgvtool.layout_file`)."""

from __future__ import annotations

from dataclasses import dataclass

from lgvtool.app.job_output import JobOutput


@dataclass(frozen=True, slots=True)
class LayoutConvertOptions:
    """What :func:`convert_layout` converts, and into what (``lgvtool layout convert``)."""

    source: str
    """The layout file to read: SICK's ``.imk`` by its suffix, else lgvtool's TOML
    ``[[reflectors]]`` (x, y, radius m)."""
    output: str
    """The layout file to write, in the format its suffix names (``.imk``: SICK's, sizes in
    mm; anything else: lgvtool's TOML, m); an existing one is replaced only with
    :attr:`force`, the source never."""
    layer: int | None = None
    """Only the reflectors of this layer (0-255); None: all."""
    force: bool = False
    """Replace an existing :attr:`output`."""


def convert_layout(options: LayoutConvertOptions) -> JobOutput:
    """Read the ``options``' source layout file and write its reflectors (those of its
    layer, or all) to its output, each in the format its suffix names (see
    :class:`LayoutConvertOptions`). The document holds the counts and paths; the text is one
    line.

    :raises InputError: (exit 2) an unreadable or malformed source, no reflector in ``layer``,
        or a refused output (the source itself, an existing file without ``force``).
    """
    from pathlib import Path

    from lgvtool.errors import InputError
    from lgvtool.layout_file import read_layout, write_layout
    from lgvtool.outputs import guard_output

    source, output, layer = options.source, options.output, options.layer
    guard_output(output, [source], force=options.force)
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
