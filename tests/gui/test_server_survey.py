"""The window on a survey on a PostgreSQL server (a real one, started by the store tests' fixture): opened
by its URL as File › Open opens a file, its objects listed with their figures, remembered in File › Recent
without a password and opened again from there."""

import itertools
from urllib.parse import quote

import numpy as np
import pytest

from tests.cli.test_secrets import SECRET, keeper  # noqa: F401 - a login with a distinctive password
from tests.cli.test_secrets import _url as _secret_url
from tests.store import conftest as store_fixtures
from tests.store.conftest import PASSWORD, PASSWORD_USER, database_url
from usvips.store.location import without_password
from usvips.store.opening import create_project
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
    qtbot.waitUntil(lambda: not window.workspace.cache.loading and listing._worker is None, timeout=20000)
    assert type(window.workspace.project).__name__ == "ServerProject"
    assert listing.row_count() == 5
    assert all(listing.text(r, "figure") not in ("", "computing…") for r in range(5))
    assert window.recent_projects()[0] == without_password(url)
    window.workspace.close_project()
    assert window.open_path(window.recent_projects()[0])
    qtbot.waitUntil(lambda: not window.workspace.cache.loading, timeout=20000)  # the objects read in a worker
    assert listing.row_count() == 5


def test_a_password_is_not_remembered(qtbot, make_window, new_survey):
    from urllib.parse import urlsplit, urlunsplit

    parts = urlsplit(new_survey("secret"))
    url = urlunsplit((parts.scheme, f"{PASSWORD_USER}:{PASSWORD}@{parts.netloc.rsplit('@', 1)[-1]}", parts.path,
                      parts.query, ""))
    _survey(url, 1)
    window = make_window()
    assert window.open_path(url)
    assert PASSWORD not in " ".join(window.recent_projects()) and PASSWORD_USER in window.recent_projects()[0]


def test_the_window_shows_and_keeps_no_password_and_names_the_survey_host_slash_database(
        qtbot, make_window, keeper, tmp_path):  # noqa: F811 - the fixture
    """Title, status messages, the log, the recent list and the settings file written, with a password
    holding '#', '@', '/' and ':' (issue 34, item 4): none holds it; the title names the survey
    ``host/database`` (``local/…`` over this machine's socket), not a file path that does not exist."""
    url = _secret_url(keeper, "window_secret", False)
    _survey(url, 2)
    window = make_window(tmp_path / "secret.ini")
    assert window.open_path(url)
    assert "local/window_secret" in window.title() and "window_secret (" not in window.title()
    assert window.windowTitle() == window.title()
    window.show_message("error", f"cannot reach {url}")  # any message that quotes the URL
    assert window.open_path(url.replace("Kw", "Kv")) is False  # a wrong password: said without the secret
    texts = [window.windowTitle(), window.statusBar().currentMessage(), window.log.toPlainText(),
             " ".join(window.recent_projects()), " ".join(a.text() for a in window.recent_menu.actions())]
    window.settings.sync()
    texts.append((tmp_path / "secret.ini").read_text(errors="replace"))
    for text in texts:
        assert SECRET not in text and quote(SECRET, safe="") not in text and "x/y:Kw" not in text
    assert any("local/window_secret" in a.text() or "window_secret" in a.text() for a in window.recent_menu.actions())


def test_an_unexpected_error_quoting_a_url_writes_and_shows_no_password(monkeypatch, tmp_path, capsys):
    from usvips.gui.qt import error_report as app

    monkeypatch.setattr(app, "log_path", lambda: tmp_path / "usvips.log")
    url = f"postgresql://keeper:{SECRET}@db.example.org:5432/reef"
    try:
        raise RuntimeError(f"could not reach {url}")
    except RuntimeError as error:
        sentence = app.report_unexpected(RuntimeError, error, error.__traceback__)
    written = (tmp_path / "usvips.log").read_text() + sentence + capsys.readouterr().err
    assert "keeper@db.example.org:5432/reef" in written
    assert SECRET not in written and quote(SECRET, safe="") not in written and "x/y:Kw" not in written
