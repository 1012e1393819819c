"""The window on a survey on a PostgreSQL server (a real one, started by the store tests' fixture): opened
by its URL as File › Open opens a file, its objects listed with their figures, remembered in File › Recent
without a password and opened again from there."""

import itertools

import numpy as np
import pytest

from tests.store import conftest as store_fixtures
from tests.store.conftest import PASSWORD, PASSWORD_USER, database_url
from usvips.store.opening import create_project, without_password
from usvips.store.records import Vertex

postgres_server = store_fixtures.postgres_server  # the store tests' session server (started once, if asked)
_names = itertools.count()


@pytest.fixture
def new_survey(postgres_server):
    """A function giving the URL of a new database on the session's server."""
    return lambda stem: database_url(postgres_server, f"{stem}_{next(_names)}")


def _survey(url: str, count: int) -> None:
    rng = np.random.default_rng(4)
    with create_project(url) as survey:
        survey.add_objects([("length", [Vertex(*rng.uniform(0, 600, 4), tuple(rng.normal(size=3)), np.eye(3) * 1e-6)
                                        for _ in range(2)], "cod", "", "ann") for _ in range(count)])


def test_the_window_opens_a_survey_on_a_server_by_its_url(qtbot, make_window, new_survey):
    url = new_survey("window")
    _survey(url, 5)
    window = make_window()
    assert window.open_path(url)
    listing = window.object_list
    qtbot.waitUntil(lambda: listing._worker is None, timeout=20000)
    assert type(window.workspace.project).__name__ == "ServerProject"
    assert listing.row_count() == 5
    assert all(listing.text(r, "figure") not in ("", "computing…") for r in range(5))
    assert window.recent_projects()[0] == without_password(url)
    window.workspace.close_project()
    assert window.open_path(window.recent_projects()[0]) and listing.row_count() == 5


def test_a_password_is_not_remembered(qtbot, make_window, new_survey):
    from urllib.parse import urlsplit, urlunsplit

    parts = urlsplit(new_survey("secret"))
    url = urlunsplit((parts.scheme, f"{PASSWORD_USER}:{PASSWORD}@{parts.netloc.rsplit('@', 1)[-1]}", parts.path,
                      parts.query, ""))
    _survey(url, 1)
    window = make_window()
    assert window.open_path(url)
    assert PASSWORD not in " ".join(window.recent_projects()) and PASSWORD_USER in window.recent_projects()[0]
