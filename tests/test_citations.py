"""Every citation in the package can be followed from the repository alone: a
"spec §N" (or "spec section N") names a section of docs/design.md, the papers 000,
002, 003 and the other sources named in docstrings have an entry in
docs/references.md."""

import re
from pathlib import Path

import inins

ROOT = Path(inins.__file__).resolve().parents[1]
DESIGN = ROOT / "docs" / "design.md"
REFERENCES = ROOT / "docs" / "references.md"
SOURCES = (  # names a docstring may cite -> the text their entry starts with
    ("IS-GPS-200", "**IS-GPS-200**"),
    ("Goshen-Meskin", "**Goshen-Meskin & Bar-Itzhack 1992**"),
    ("Savage", "**Savage 2007**"),
    ("Groves", "**Groves 2013**"),
    ("Titterton", "**Titterton & Weston 2004**"),
    ("Bar-Shalom", "**Bar-Shalom, Li & Kirubarajan 2001**"),
    ("Van Loan", "**Van Loan 1978**"),
    ("Ham & Brown", "**Ham & Brown 1983**"),
    ("Higham", "**Higham 2005**"),
    ("Wedin", "**Wedin 1972**"),
    ("Saastamoinen", "**Saastamoinen 1972**"),
    ("Klobuchar", "**Klobuchar 1987**"),
    ("RINEX", "**RINEX**"),
    ("WGS84", "**WGS 84**"),
    ("IEEE Std 952", "**IEEE Std 952-1997**"),
    ("Greenhall", "**Greenhall & Riley 2003**"),
    ("SP 1065", "**NIST SP 1065**"),
    ("Stable32", "**Stable32**"),
    ("Tedaldi", "**Tedaldi et al. 2014**"),
    ("Rauch-Tung-Striebel", "**Rauch, Tung & Striebel 1965**"),
    ("Galileo OS SIS ICD", "**Galileo OS SIS ICD**"),
    ("BDS-SIS-ICD", "**BDS-SIS-ICD**"),
    ("GLONASS ICD", "**GLONASS ICD**"),
    ("Kalibr", "**Kalibr**"),
)


def _sources():
    return {p: p.read_text(encoding="utf-8") for p in (ROOT / "inins").rglob("*.py")}


def _design_sections():
    return set(re.findall(r"^## §(\w+)", DESIGN.read_text(encoding="utf-8"), re.M))


def test_every_cited_spec_section_is_in_the_design_notes():
    sections = _design_sections()
    assert {"1", "2", "6", "6a", "7"} <= sections
    cited = {}
    for path, text in _sources().items():
        for match in re.finditer(r"spec (?:§|section )(\d+[a-z]?)", text):
            cited.setdefault(match.group(1), set()).add(path.name)
    assert cited, "no spec citation found: the pattern is broken"
    missing = {s: sorted(files) for s, files in cited.items() if s not in sections}
    assert missing == {}


def test_the_papers_and_named_sources_have_entries():
    refs = REFERENCES.read_text(encoding="utf-8")
    for paper in ("000", "002", "003"):
        assert f"**{paper}**" in refs, paper
    text = "\n".join(_sources().values())
    named = [(name, entry) for name, entry in SOURCES if name in text]
    assert len(named) >= 8  # the package cites most of them
    missing = [name for name, entry in named if entry not in refs]
    assert missing == []


def test_paper_citations_use_the_three_numbers_only():
    """'NNN eq. 12' / 'NNN §3.2' cite one of the three papers (no stray numbers)."""
    found = set()
    for text in _sources().values():
        text = text.replace("IS-GPS-200", "").replace("Std 952", "")  # not paper numbers
        found.update(re.findall(r"\b(\d{3}) (?:eqs?\.|§|Table|Fig\.)", text))
    assert found and found <= {"000", "002", "003"}, found
