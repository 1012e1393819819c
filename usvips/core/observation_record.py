"""The observation record of a measured object, in EventMeasure's and CheckEM's terms: the taxon (family,
genus, species and its code, from the project's species list), the number of individuals, the life stage,
the activity and a comment. Plain values, validated; stored by the project, typed in by the workstation."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from usvips.core.errors import InvalidParameterError

#: Life stages as EventMeasure codes them (free text is accepted as well).
STAGES = ("AD", "J", "F", "M", "U")


def _clean(name: str, value: object) -> str:
    text = str(value).strip()
    if "\t" in text or "\n" in text or "\r" in text:
        raise InvalidParameterError(name, "must be one line without tabs (the exported tables are tab separated)")
    return text


#: the longest maximum length a species list may give (metres: a blue whale is about 30 m)
MAX_LENGTH_M = 40.0


@dataclass(frozen=True)
class Species:
    """One entry of a species list: ``genus`` and ``species`` (the epithet; ``spp`` for unidentified
    species of a genus), its ``family`` and ``code`` (e.g. a CAAB code), and the species' maximum
    length ``max_length_m`` (metres; None when the list gives none) that a measured length is checked
    against (CheckEM's rule)."""

    family: str
    genus: str
    species: str
    code: str = ""
    max_length_m: float | None = None

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name != "max_length_m":
                object.__setattr__(self, f.name, _clean(f.name, getattr(self, f.name)))
        if not self.genus:
            raise InvalidParameterError("genus", "must not be empty")
        if self.max_length_m is not None:
            value = self.max_length_m
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise InvalidParameterError("max_length", f"must be a positive length, got {value!r}")
            if value > MAX_LENGTH_M:
                raise InvalidParameterError("max_length", f"{value:g} m is longer than any animal (at most "
                                            f"{MAX_LENGTH_M:g} m; is the unit right?)")
            object.__setattr__(self, "max_length_m", float(value))

    @property
    def name(self) -> str:
        """``Genus species``, the form typed and shown."""
        return f"{self.genus} {self.species}".strip()


@dataclass(frozen=True)
class ObservationRecord:
    """What was seen: taxon fields (all empty when not identified), ``number`` of individuals (≥ 1),
    ``stage``, ``activity`` and ``comment`` (one line each)."""

    family: str = ""
    genus: str = ""
    species: str = ""
    code: str = ""
    number: int = 1
    stage: str = ""
    activity: str = ""
    comment: str = ""

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name != "number":
                object.__setattr__(self, f.name, _clean(f.name, getattr(self, f.name)))
        number = self.number
        if isinstance(number, bool) or not isinstance(number, int) or number < 1:
            raise InvalidParameterError("number", f"must be a whole number of individuals ≥ 1, got {number!r}")

    @classmethod
    def of(cls, species: Species | None, **values: object) -> ObservationRecord:
        """A record for ``species`` (None: not identified) with the other fields given."""
        taxon = {} if species is None else {"family": species.family, "genus": species.genus,
                                            "species": species.species, "code": species.code}
        return cls(**taxon, **values)

    @property
    def name(self) -> str:
        return f"{self.genus} {self.species}".strip()
