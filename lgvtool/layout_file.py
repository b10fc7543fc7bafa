"""The reflector layout file: one format for the whole tool, and SICK's ``.imk`` beside it.

lgvtool's layout file is the configuration's ``[[reflectors]]`` TOML (``id``, ``x``, ``y`` m,
``radius`` m, ``layer``): a configuration file is a layout file, and a file of only
``[[reflectors]]`` tables is one too. ``record --write-layout`` takes either, ``record
--map-layout`` writes one, ``lgvtool layout convert`` turns one into the other.

SICK's layout file (``.imk``, written by SOPAS ET and read by SICK's own NAV350 driver) is one
landmark a line, ``globID x_mm y_mm type subtype size_mm layer [layer ...]``, with ``#``
comments and a header line starting ``globID``. Read here: the global id becomes the reflector's
id, the size (the reflector's diameter, mm) twice its radius, the first layer its layer (a
landmark in several layers is read once, in its first). Written here: type 1, subtype 1 (the
values lgvtool's NAV350 writer sends; their codes are not documented).

Pure apart from :func:`read_layout` and :func:`write_layout`, which read and write one file.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Sequence
from pathlib import Path

from lgvtool.config import Reflector, reflectors_from_tables
from lgvtool.errors import ConfigError

__all__ = ["MERGE_RADIUS_M", "format_imk", "format_toml", "merge_mapped", "parse_imk",
           "read_layout", "write_layout"]

#: A mapped landmark this close (m) to a layout reflector is that reflector.
MERGE_RADIUS_M = 0.25


def parse_imk(text: str, where: str = "layout") -> tuple[Reflector, ...]:
    """The reflectors of an ``.imk`` text (see the module docstring).

    :raises ConfigError: a line that is not ``globID x_mm y_mm type subtype size_mm layer...``
        of integers, or duplicate ids.
    """
    items = []
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#") or line.startswith("globID"):
            continue
        fields = line.split()
        try:
            values = [int(f) for f in fields]
        except ValueError:
            raise ConfigError(f"{where}: line {n}: not a landmark line (globID x_mm y_mm type "
                              f"subtype size_mm layer...): {line[:60]!r}") from None
        if len(values) < 7:
            raise ConfigError(f"{where}: line {n}: {len(values)} fields, a landmark line has "
                              "at least 7 (globID x_mm y_mm type subtype size_mm layer...)")
        gid, x_mm, y_mm, _typ, _sub, size_mm, layer = values[:7]
        items.append({"id": gid, "x": x_mm / 1000.0, "y": y_mm / 1000.0,
                      "radius": size_mm / 2000.0, "layer": layer})
    return reflectors_from_tables(items)


def format_imk(reflectors: Sequence[Reflector]) -> str:
    """``reflectors`` as an ``.imk`` text (mm rounded to the nearest; type 1, subtype 1)."""
    lines = ["globID x_mm y_mm type subtype size_mm layer"]
    for r in reflectors:
        lines.append(f"{r.id} {round(r.x * 1000)} {round(r.y * 1000)} 1 1 "
                     f"{max(1, round(r.radius * 2000))} {r.layer}")
    return "\n".join(lines) + "\n"


def format_toml(reflectors: Sequence[Reflector], comment: str = "") -> str:
    """``reflectors`` as ``[[reflectors]]`` tables (m to 0.1 mm), with an optional leading
    comment."""
    out = [f"# {line}" for line in comment.splitlines()]
    for r in reflectors:
        out += ["", "[[reflectors]]", f"id = {r.id}", f"x = {r.x:.4f}", f"y = {r.y:.4f}",
                f"radius = {r.radius:.4f}", f"layer = {r.layer}"]
    return "\n".join(out).lstrip("\n") + "\n"


def read_layout(path: str | Path) -> tuple[Reflector, ...]:
    """The reflectors of a layout file: ``.imk`` by its suffix, else TOML (a configuration or
    a file of ``[[reflectors]]`` tables).

    :raises ConfigError: unreadable, not TOML, no ``[[reflectors]]``, or a bad value.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: cannot read the layout file: {exc}") from None
    if p.suffix.lower() == ".imk":
        return parse_imk(text, str(p))
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not a TOML layout file ({exc}); SICK's layout files end in "
                          ".imk") from None
    if "reflectors" not in data:
        raise ConfigError(f"{p}: no [[reflectors]] tables in the layout file")
    try:
        return reflectors_from_tables(data["reflectors"])
    except ConfigError as exc:
        raise ConfigError(f"{p}: {exc}") from None


def write_layout(path: str | Path, reflectors: Sequence[Reflector], comment: str = "") -> None:
    """Write ``reflectors`` to ``path``: ``.imk`` by its suffix, else TOML; written beside and
    renamed when complete (the old file stays as it was if this fails)."""
    from lgvtool.outputs import atomic_output

    p = Path(path)
    text = format_imk(reflectors) if p.suffix.lower() == ".imk" else format_toml(
        reflectors, comment)
    with atomic_output(p) as tmp:
        tmp.write_text(text, encoding="utf-8")


def merge_mapped(layout: Sequence[Reflector], found: Sequence[tuple[float, float]], *,
                 layer: int = 0, radius: float = 0.04,
                 merge_radius: float = MERGE_RADIUS_M) -> tuple[Reflector, ...]:
    """``layout`` with the landmarks ``found`` by a mapping run (x, y m) merged in: a landmark
    within ``merge_radius`` m of a reflector of ``layer`` moves it to the mean of the two
    positions (each stand counts once); the others are added with new ids (after the largest),
    ``radius`` m and ``layer``. The nearest pairs are matched first, each reflector at most
    once."""
    out = list(layout)
    pairs = sorted((math.hypot(r.x - x, r.y - y), i, j)
                   for i, r in enumerate(out) if r.layer == layer
                   for j, (x, y) in enumerate(found))
    used_r: set[int] = set()
    used_f: set[int] = set()
    for d, i, j in pairs:
        if d > merge_radius:
            break
        if i in used_r or j in used_f:
            continue
        used_r.add(i)
        used_f.add(j)
        r = out[i]
        x, y = found[j]
        out[i] = Reflector(r.id, 0.5 * (r.x + x), 0.5 * (r.y + y), r.radius, r.layer)
    next_id = max((r.id for r in out), default=0) + 1
    for j, (x, y) in enumerate(found):
        if j not in used_f:
            out.append(Reflector(next_id, x, y, radius, layer))
            next_id += 1
    return tuple(out)
