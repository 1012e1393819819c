"""Which species a person typed, free of Qt: the Observation form's type-ahead and the toolbar's
attribute (a default for the record) both resolve text here, against the project's species list.

Text matches, in order: the whole name (``Gadus morhua``), the code, the form's own label (``Gadus
morhua — Gadidae (COD)``); failing those, every entry whose name, family or code CONTAINS the text (any
case). One such entry is the species (typing ``morh`` and Tab or Enter takes *Gadus morhua*); several
are named so that the person types more; none is an error naming the text.
"""

from __future__ import annotations

from collections.abc import Iterable

from usvips.core.errors import UsvipsError
from usvips.core.observation_record import Species


def species_label(species: Species) -> str:
    """How the form lists an entry: ``Gadus morhua — Gadidae (COD)``."""
    return f"{species.name} — {species.family}" + (f" ({species.code})" if species.code else "")


def candidates(text: str, species: Iterable[Species]) -> list[Species]:
    """The entries ``text`` stands for: the one it names exactly, else all that contain it."""
    entries = list(species)
    text = text.strip()
    if not text:
        return []
    key = text.split(" — ")[0].strip().lower()
    exact = [s for s in entries if key in (s.name.lower(), s.code.lower()) or text.lower() == species_label(s).lower()]
    if exact:
        return exact[:1]
    return [s for s in entries
            if key in s.name.lower() or key in s.family.lower() or (s.code and key in s.code.lower())]


def species_of_attribute(attribute: str, species: Iterable[Species]) -> Species | None:
    """The species a toolbar attribute names (exactly, or as the one entry containing it), else None:
    the default species of a new object's record."""
    try:
        return choose_species(attribute, species)
    except UsvipsError:
        return None


def choose_species(text: str, species: Iterable[Species]) -> Species | None:
    """The species ``text`` stands for; None for blank text (not identified). Several or no matches
    raise one line saying which (up to five are named) or that the list lacks it."""
    entries = list(species)
    if not text.strip():
        return None
    found = candidates(text, entries)
    if len(found) == 1:
        return found[0]
    shown = text.strip()
    if not found:
        raise UsvipsError(f"species {shown!r} is not in the project's species list (File › Import species "
                          "list…); leave it blank if not identified")
    names = ", ".join(s.name for s in found[:5]) + (f" and {len(found) - 5} more" if len(found) > 5 else "")
    raise UsvipsError(f"{shown!r} matches {len(found)} species ({names}): type more of the name")
