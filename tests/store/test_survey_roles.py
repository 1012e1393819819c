"""Roles on a server (issue 34, item 5), with second and third database logins made here (the suite's
server runs as a superuser): ``project push`` creates the roles (annotator, reviewer, administrator) and
grants, so a login given a role opens the pushed survey; one given none is told in one line what to ask
for; the annotator of a login is the login, recorded in the history by the server whatever the client
claims; only reviewers accept or flag; the survey is named ``host/database``."""

from __future__ import annotations

import itertools

import psycopg
import pytest
from psycopg import sql

from usvips.cli import main
from usvips.store import Project
from usvips.store.annotator import annotating_as
from usvips.store.opening import create_project, open_project
from usvips.store.records import ProjectError, Vertex

_logins = itertools.count()


def _login(server: str, *roles: str) -> str:
    """A new database login (no password: the server trusts this machine's socket) with ``roles``."""
    name = f"reader_{next(_logins)}"
    with psycopg.connect(server, autocommit=True) as connection:
        connection.execute(sql.SQL("CREATE ROLE {} LOGIN").format(sql.Identifier(name)))
        for role in roles:
            connection.execute(sql.SQL("GRANT {} TO {}").format(sql.Identifier(role), sql.Identifier(name)))
    return name


def _as(url: str, login: str) -> str:
    """``url`` (``postgresql://postgres:@/db?host=…``) for another login."""
    return url.replace("postgresql://postgres:@", f"postgresql://{login}@", 1)


@pytest.fixture
def pushed(postgres_server, new_database, tmp_path) -> str:
    """A project file with two objects pushed to a new survey by the server's superuser; its URL."""
    source = tmp_path / "reef.usvips"
    with Project.create(source) as project:
        project.annotator = "ann"
        for k in range(2):
            project.add_object("length", [Vertex(10.0 + k, 20.0, 8.0, 20.0), Vertex(40.0, 20.0, 38.0, 20.0)], "cod")
    url = new_database("roles")
    assert main(["project", "push", str(source), url]) == 0
    return url


def test_a_second_login_with_a_role_opens_a_pushed_survey_and_one_without_is_told_what_to_ask(postgres_server,
                                                                                               pushed):
    stranger = _login(postgres_server)
    with pytest.raises(ProjectError, match=f"the login {stranger} is not one of this survey's annotators.*"
                                           f"GRANT usvips_annotator TO {stranger}") as refused:
        open_project(_as(pushed, stranger))
    assert "\n" not in str(refused.value) and "permission denied" not in str(refused.value)
    carl = _login(postgres_server, "usvips_annotator")
    with open_project(_as(pushed, carl)) as survey:
        assert [o.creator for o in survey.objects()] == ["ann", "ann"]
        survey.update_object(1, notes="carl: checked")
        assert survey.object(1).notes == "carl: checked"
        assert str(survey.path).endswith("/" + pushed.split("/")[3].split("?")[0])  # host/database, no file


def test_the_annotator_is_the_login_recorded_by_the_server_and_only_reviewers_accept_or_flag(postgres_server,
                                                                                              pushed):
    carl = _login(postgres_server, "usvips_annotator")
    dora = _login(postgres_server, "usvips_reviewer")
    with annotating_as("mallory"), open_project(_as(pushed, carl)) as survey:
        assert survey.annotator == carl  # the login, not $USVIPS_ANNOTATOR nor --annotator
        survey.annotator = "mallory"  # a client's claim: the server records the login anyway
        made = survey.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)], "ling")
        with pytest.raises(ProjectError, match=f"only a reviewer accepts or flags an object.*{carl}"):
            survey.set_review(made, "accepted")
        assert survey.review(made).state == "unreviewed"
        assert [h.annotator for h in survey.history(made)] == [carl]
    with open_project(_as(pushed, dora)) as survey:
        survey.set_review(made, "flagged", "two fish in one box")
        review = survey.review(made)
        assert (review.state, review.reviewer) == ("flagged", dora)
        assert survey.history(made)[-1].annotator == dora
    with open_project(pushed) as survey:  # the owner (who pushed) copied the rows as they were made
        assert survey.history(1)[0].annotator == "ann"


def test_a_survey_made_on_the_server_gets_its_grants_too(postgres_server, new_database):
    url = new_database("made")
    create_project(url).close()
    carl = _login(postgres_server, "usvips_annotator")
    with open_project(_as(url, carl)) as survey:
        assert survey.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)]) == 1
