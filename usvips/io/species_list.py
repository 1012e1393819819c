"""Species lists (CSV): one taxon a line with the columns ``family``, ``genus``, ``species`` and
``code`` — the columns of EventMeasure's and CheckEM's species lists (header names are matched without
case; ``caab``, ``caab_code`` and ``species_code`` are read as ``code``, which may be missing). Lines
starting with ``#`` (after white space) and blank lines are ignored; every line is read as every CSV
table's (:func:`usvips.io.tables.split_line`) and has the header's number of fields, or stops after its
last required one (the optional fields after it empty). A taxon is one however its names are
capitalised. Every error names the file and the line.

An optional column gives each species' maximum length, its unit in the header: ``max_length_mm``,
``max_length_cm``, ``max_length_m`` (or ``length_max_mm`` …), or ``fb_length_max`` (FishBase's, in cm).
An empty cell is a species without a maximum; a header ``max_length`` without a unit is refused."""

from __future__ import annotations

import math
from pathlib import Path

from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.observation_record import Species
from usvips.core.plain_numbers import plain_number
from usvips.io.file_errors import not_a_file
from usvips.io.tables import separator_hint, split_line
from usvips.io.text_lines import not_utf8, refuse_control_characters, split_lines

ALIASES = {"family": "family", "genus": "genus", "species": "species", "code": "code", "caab": "code",
           "caab_code": "code", "species_code": "code", "speciescode": "code"}
REQUIRED = ("family", "genus", "species")
#: maximum-length columns and their unit (metres per unit)
MAX_LENGTH = {"max_length_mm": 0.001, "length_max_mm": 0.001, "maximum_length_mm": 0.001,
              "max_length_cm": 0.01, "length_max_cm": 0.01, "maximum_length_cm": 0.01, "fb_length_max": 0.01,
              "max_length_m": 1.0, "length_max_m": 1.0, "maximum_length_m": 1.0}


#: the shortest maximum length (m) a list may give: a copepod's; shorter is a unit slip. (Checked here, where a
#: list comes in, not in :class:`Species`, so that a project stored before it still reads.)
MIN_LENGTH_M = 1e-4
#: the longest family, genus, species or code a list may give (characters; the longest binomials are about 60)
MAX_TAXON_TEXT = 200


def read_species_list(path: str | Path) -> list[Species]:
    """The species of a list file, in file order (a genus and species, or a code, given twice refused)."""
    path = Path(path)
    if not path.is_file():
        raise not_a_file(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        raise not_utf8(str(path), error.object, error.start, "species list (CSV)") from None
    except OSError as error:
        raise InputFileError(str(path), f"cannot read the file: {error.strerror or error}") from None
    refuse_control_characters(str(path), text)
    # each line read as every CSV table's (strict quoting, no NUL, fields and lines of a bounded length)
    rows = [(n, fields) for n, line in enumerate(split_lines(text), 1)
            if (fields := split_line(path, n, line)) is not None]
    if not rows:
        raise InputFileError(str(path), "is empty: expected a header family,genus,species,code and one line a taxon")
    header_line, header = rows[0]
    columns: dict[str, int] = {}
    for i, h in enumerate(header):
        name = ALIASES.get(h.strip().lower())
        if name in columns:
            raise InputFileError(str(path), f"the columns {header[columns[name]]!r} and {h!r} both give the "
                                 f"{name}: keep one", header_line)
        if name is not None:
            columns[name] = i
    lowered = [h.strip().lower() for h in header]
    unitless = [h for h in lowered if h in ("max_length", "length_max", "maximum_length")]
    if unitless:
        raise InputFileError(str(path), f"the column {unitless[0]!r} needs its unit: name it {unitless[0]}_mm, "
                             f"{unitless[0]}_cm or {unitless[0]}_m", header_line)
    odd_unit = [header[i] for i, h in enumerate(lowered) if h not in MAX_LENGTH
                and h.startswith(("max_length_", "length_max_", "maximum_length_", "fb_length_max_"))]
    if odd_unit:
        raise InputFileError(str(path), f"the column {odd_unit[0]!r} gives a maximum length in a unit this list "
                             "does not read: name it with _mm, _cm or _m", header_line)
    lengths = [(i, MAX_LENGTH[h]) for i, h in enumerate(lowered) if h in MAX_LENGTH]
    if len(lengths) > 1:
        raise InputFileError(str(path), f"{len(lengths)} maximum-length columns ("
                             f"{', '.join(header[i] for i, _ in lengths)}): keep one", header_line)
    maximum = lengths[0] if lengths else None
    missing = [c for c in REQUIRED if c not in columns]
    if missing:
        shown = ", ".join(header)[:80].replace("\t", " ")
        raise InputFileError(str(path), f"the header lacks {', '.join(missing)} (has {shown})"
                             f"{separator_hint(header)}", header_line)
    species: list[Species] = []
    seen: dict[str, int] = {}
    codes: dict[str, int] = {}
    needed = max(columns[name] for name in REQUIRED) + 1  # a row may stop after its last required field
    for number, row in rows[1:]:
        if not needed <= len(row) <= len(header):  # a value with a comma, or a column slipped
            raise InputFileError(str(path), f"{len(row)} fields but the header has {len(header)} "
                                 f"({','.join(header)[:80]})", number)
        row = row + [""] * (len(header) - len(row))  # the optional fields a spreadsheet left off: empty
        values = {name: row[i] for name, i in columns.items()}
        max_length = None
        if maximum is not None and row[maximum[0]]:
            text = row[maximum[0]]
            try:
                given = plain_number(text)
            except ValueError:
                raise InputFileError(str(path), f"the maximum length {text!r} is not a number", number) from None
            if not (math.isfinite(given) and given > 0):
                raise InputFileError(str(path), f"the maximum length {text} ({header[maximum[0]]}) must be a "
                                     "positive number", number)
            max_length = given * maximum[1]
            if max_length < MIN_LENGTH_M:
                raise InputFileError(str(path), f"the maximum length {text} ({header[maximum[0]]}) is shorter than "
                                     f"any organism's maximum (at least {MIN_LENGTH_M * 1000:g} mm; is the unit "
                                     "right?)", number)
        too_long = next((name for name, value in values.items() if len(value) > MAX_TAXON_TEXT), None)
        if too_long is not None:
            raise InputFileError(str(path), f"the {too_long} is {len(values[too_long]):,} characters long: a taxon's "
                                 f"name or code has at most {MAX_TAXON_TEXT} (a column slipped?)", number)
        try:
            entry = Species(values["family"], values["genus"], values["species"], values.get("code", ""), max_length)
        except UsvipsError as error:
            raise InputFileError(str(path), str(error), number) from None
        key = entry.name.casefold()  # "Chrysophrys auratus" and "chrysophrys Auratus" are one taxon
        if key in seen:
            raise InputFileError(str(path), f"{entry.name} is listed twice (also on line {seen[key]})", number)
        seen[key] = number
        if entry.code:
            if entry.code in codes:
                raise InputFileError(str(path), f"the code {entry.code!r} is given to two taxa (also on line "
                                     f"{codes[entry.code]})", number)
            codes[entry.code] = number
        species.append(entry)
    if not species:  # it would replace the project's list with nothing
        raise InputFileError(str(path), "lists no species, only its header (a list replaces the project's whole "
                             "list: give at least one taxon)", header_line)
    return species
