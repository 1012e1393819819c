"""Species lists (CSV): one taxon a line with the columns ``family``, ``genus``, ``species`` and
``code`` — the columns of EventMeasure's and CheckEM's species lists (header names are matched without
case; ``caab``, ``caab_code`` and ``species_code`` are read as ``code``, which may be missing). Lines
starting with ``#`` and blank lines are ignored. Every error names the file and the line."""

from __future__ import annotations

import csv
from pathlib import Path

from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.observation_record import Species

ALIASES = {"family": "family", "genus": "genus", "species": "species", "code": "code", "caab": "code",
           "caab_code": "code", "species_code": "code", "speciescode": "code"}
REQUIRED = ("family", "genus", "species")


def read_species_list(path: str | Path) -> list[Species]:
    """The species of a list file, in file order (duplicates of genus and species refused)."""
    path = Path(path)
    if not path.is_file():
        raise InputFileError(str(path), "no such file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise InputFileError(str(path), f"cannot be read as UTF-8 text: {error}") from None
    lines = [(n, line) for n, line in enumerate(text.splitlines(), 1) if line.strip() and not line.startswith("#")]
    if not lines:
        raise InputFileError(str(path), "is empty: expected a header family,genus,species,code and one line a taxon")
    header_line, header = lines[0][0], next(csv.reader([lines[0][1]]))
    columns = {ALIASES.get(h.strip().lower()): i for i, h in enumerate(header) if ALIASES.get(h.strip().lower())}
    missing = [c for c in REQUIRED if c not in columns]
    if missing:
        raise InputFileError(str(path), f"the header lacks {', '.join(missing)} (has {', '.join(header)})",
                             header_line)
    species: list[Species] = []
    seen: dict[str, int] = {}
    for number, line in lines[1:]:
        row = next(csv.reader([line]))
        values = {name: (row[i] if i < len(row) else "") for name, i in columns.items()}
        try:
            entry = Species(values["family"], values["genus"], values["species"], values.get("code", ""))
        except UsvipsError as error:
            raise InputFileError(str(path), str(error), number) from None
        if entry.name in seen:
            raise InputFileError(str(path), f"{entry.name} is listed twice (also on line {seen[entry.name]})",
                                 number)
        seen[entry.name] = number
        species.append(entry)
    if not species:  # it would replace the project's list with nothing
        raise InputFileError(str(path), "lists no species, only its header (a list replaces the project's whole "
                             "list: give at least one taxon)", header_line)
    return species
