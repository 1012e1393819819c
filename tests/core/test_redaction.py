"""The one redaction: no password survives it, whatever characters it holds, and nothing else is lost."""

from __future__ import annotations

from urllib.parse import quote

import numpy as np
import pytest

from usvips.core.redaction import HIDDEN, redact, remember_secret, split_user_information

#: characters a password may hold that a URL gives a meaning to
SPECIAL = "#@/:?&=%[]+ ;'\\"


@pytest.mark.parametrize("seed", range(40))
def test_a_password_of_any_characters_leaves_no_trace_in_a_url_and_the_rest_is_kept(seed):
    rng = np.random.default_rng(seed)
    alphabet = list("abcXYZ0189-_.~") + list(SPECIAL.replace(" ", ""))
    password = "Q" + "".join(rng.choice(alphabet, size=int(rng.integers(3, 16))))
    encoded = bool(rng.integers(2))
    written = quote(password, safe="") if encoded else password
    host = str(rng.choice(["db.example.org", "10.1.2.3", "[::1]", ""]))
    port = str(rng.choice(["", ":5432", ":6543"]))
    url = f"postgresql://ann:{written}@{host}{port}/survey_{seed}?media=/data/x"
    text = f"[1/3] ok {url} -> out.csv (4 objects)"
    shown = redact(text)
    assert written not in shown and password not in shown
    assert f"postgresql://ann@{host}{port}/survey_{seed}?media=/data/x" in shown
    assert shown.startswith("[1/3] ok ") and shown.endswith(" -> out.csv (4 objects)")
    user_information, rest = split_user_information(url[len("postgresql://"):])
    assert user_information == f"ann:{written}" and rest.startswith(f"{host}{port}/survey_{seed}")


def test_password_values_of_queries_and_connection_strings_and_remembered_secrets_are_hidden():
    assert redact("postgresql:///db?host=/tmp/s&password=Tops3cret") == f"postgresql:///db?host=/tmp/s&password={HIDDEN}"
    assert redact("host=x password='a b' dbname=y") == f"host=x password={HIDDEN} dbname=y"
    remember_secret("Zebra#Crossing@42")
    assert redact("server said: bad password Zebra#Crossing@42 or Zebra%23Crossing%4042") == (
        f"server said: bad password {HIDDEN} or {HIDDEN}")
    remember_secret("ab")  # too short to search free text for: 'about' stays readable
    assert redact("about a cab") == "about a cab"


def test_text_without_a_secret_is_unchanged():
    for text in ("/home/ann/cod survey/project.usvips: no object 5", "postgresql://ann@db/cod", "a@b.c: 3 objects",
                 "postgres://db.example.org:5432/cod?media=/data"):
        assert redact(text) == text


def test_a_history_row_quoting_an_address_shows_no_part_of_its_password():
    from usvips.app.history_text import what_changed
    from usvips.store.records import HistoryEntry

    notes = "copied from postgresql://ann:Zq#9@x/y:Kw!@db.example.org:5432/reef?media=/data/surveys/2024"
    entry = HistoryEntry(3, "2026-11-28T10:00:00+00:00", "ann", 1, "edit", {"notes": ""}, {"notes": notes})
    shown = what_changed(entry)
    assert "Zq#9" not in shown and "x/y" not in shown and "Kw!" not in shown and "ann@db.example.org" in shown
