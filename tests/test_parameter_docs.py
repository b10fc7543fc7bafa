"""The docs' parameter tables are the declarations (:mod:`lgvtool.declared`), as ``lgvtool config
--parameters --markdown`` prints them: a setting added, renamed or given another default, unit or
range without its table following fails here. ``python tests/test_parameter_docs.py`` rewrites
the tables from the code."""

from __future__ import annotations

import sys
from pathlib import Path

from lgvtool.app.config_job import parameter_groups
from lgvtool.declared import declarations, markdown_table

ROOT = Path(__file__).resolve().parents[1]
BEGIN = ("<!-- parameters: generated from the declarations by `lgvtool config --parameters "
         "--markdown` (python tests/test_parameter_docs.py rewrites them) -->")
END = "<!-- end of parameters -->"

#: doc -> the groups whose tables it holds (a group name, or a prefix ending in '.')
DOCS: dict[str, tuple[str, ...]] = {
    "docs/config.md": ("vehicle", "area", "reference", "reflectors"),
    "docs/filter.md": ("estimators.",),
    "docs/simulator.md": ("simulator.",),
}


def _tables(wanted: tuple[str, ...]) -> str:
    blocks = [f"#### `[{group}]`\n\n{markdown_table(cls)}\n" for group, cls in parameter_groups()
              if group in wanted or any(w.endswith(".") and group.startswith(w) for w in wanted)]
    return "\n".join(blocks)


def _region(text: str, doc: str) -> tuple[int, int]:
    start, end = text.find(BEGIN), text.find(END)
    assert start >= 0 and end > start, f"{doc} has no generated parameters region"
    return start + len(BEGIN), end


def test_every_table_is_the_declarations() -> None:
    for doc, wanted in DOCS.items():
        text = (ROOT / doc).read_text(encoding="utf-8")
        a, b = _region(text, doc)
        assert text[a:b].strip() == _tables(wanted).strip(), (
            f"{doc}: the parameter tables differ from the code; python "
            "tests/test_parameter_docs.py rewrites them")


def test_every_group_is_in_a_doc_and_documented() -> None:
    for group, cls in parameter_groups():
        assert any(group in w or any(x.endswith(".") and group.startswith(x) for x in w)
                   for w in DOCS.values()), group
        for d in declarations(cls):
            assert d.doc.strip(), f"{group}.{d.name} has no documentation"


def _write() -> None:
    for doc, wanted in DOCS.items():
        path = ROOT / doc
        text = path.read_text(encoding="utf-8")
        a, b = _region(text, doc)
        path.write_text(text[:a] + "\n\n" + _tables(wanted) + "\n" + text[b:], encoding="utf-8")
        print(f"rewrote the parameter tables of {doc}")


def test_the_parameter_listing_is_toml_of_the_defaults() -> None:
    import tomllib

    from lgvtool.app.config_job import parameters

    data = tomllib.loads(parameters().text)
    assert data["estimators"]["pf"]["particles"] > 0
    assert data["simulator"]["site"]["survey_sigma_mm"] == 10.0
    assert data["simulator"]["scenario"]["speed"] == 0.36  # the circle scenarios' block


if __name__ == "__main__":
    _write()
    sys.exit(0)
