"""Which species a person typed (Qt-free): the whole name, the code or the list's label; else the ONE
entry containing the text; several or none named in one line. The toolbar attribute as a default."""

import numpy as np
import pytest

from usvips.core.errors import UsvipsError
from usvips.core.observation_record import Species
from usvips.gui.species_choice import candidates, choose_species, species_label, species_of_attribute

GENERA = ["Pagrus", "Notolabrus", "Coris", "Trachurus", "Chrysophrys", "Gadus", "Melanogrammus", "Scorpis"]
EPITHETS = ["auratus", "gymnogenis", "picta", "novaezelandiae", "morhua", "aeglefinus", "lineolata", "major"]


def species_list(rng) -> list[Species]:
    pairs = {(str(rng.choice(GENERA)), str(rng.choice(EPITHETS))) for _ in range(12)}
    return [Species(f"{g[:4]}idae", g, e, f"{37000000 + k}") for k, (g, e) in enumerate(sorted(pairs))]


@pytest.mark.parametrize("seed", range(10))
def test_every_entry_is_reached_by_its_name_code_label_and_a_unique_part(seed):
    rng = np.random.default_rng(seed)
    entries = species_list(rng)
    for entry in entries:
        for text in (entry.name, entry.name.upper(), entry.code, species_label(entry)):
            assert choose_species(text, entries) == entry
        name = entry.name.lower()
        for start in range(len(name)):
            for end in range(start + 3, len(name) + 1):
                part = name[start:end]
                found = candidates(part, entries)
                assert entry in found or any(part in (s.name.lower(), s.code.lower()) for s in found)
                if len(found) == 1:
                    assert choose_species(part, entries) == found[0]
                else:  # several: named, so that the person types more
                    with pytest.raises(UsvipsError, match=f"matches {len(found)} species"):
                        choose_species(part, entries)


def test_blank_is_not_identified_and_an_unknown_name_is_named():
    entries = [Species("Sparidae", "Pagrus", "auratus", "37353001")]
    assert choose_species("  ", entries) is None
    with pytest.raises(UsvipsError, match="'Nemo unknownus' is not in the project's species list"):
        choose_species("Nemo unknownus", entries)


def test_the_toolbar_attribute_names_a_default_species_or_none():
    entries = [Species("Sparidae", "Pagrus", "auratus", "37353001"), Species("Labridae", "Coris", "picta")]
    assert species_of_attribute("snapper auratus", entries) is None
    assert species_of_attribute("auratus", entries) == entries[0]
    assert species_of_attribute("idae", entries) is None  # two families: no default
    assert species_of_attribute("", entries) is None
