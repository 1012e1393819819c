"""Where a project is: a file path, or a survey's ``postgresql://`` (or ``postgres://``) URL — read into
its parts (the password taken out and remembered for redaction), named for a person (``host/database``,
never with its password), and told apart from a path. Used by the opener (:mod:`.opening`), the server
backend (:mod:`.postgres`) and the copying between them (:mod:`.transfer`), none of which imports another
for it.
"""

from __future__ import annotations

import ipaddress
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote, unquote, urlencode

from usvips.core.redaction import redact, remember_secret, split_user_information
from usvips.store.records import ProjectError

SERVER_SCHEMES = ("postgresql://", "postgres://")
OWN_QUERY = ("media", "cache")  # URL query parameters USVIPS reads itself (not passed to the server)
MAX_PORT = 65535


def is_server_location(location: str | Path) -> bool:
    """True when ``location`` names a survey on a server (a ``postgresql://`` URL), not a file."""
    return isinstance(location, str) and location.lower().startswith(SERVER_SCHEMES)


@dataclass(frozen=True)
class ServerLocation:
    """A ``postgresql://USER:PASSWORD@HOST:PORT/DATABASE?KEY=VALUE…`` URL, read once (percent-encoding
    undone): ``host`` '' when the URL names none (a socket folder may come as ``?host=``), an IPv6 host
    without its brackets; ``password`` None when the URL holds none (libpq then reads ``PGPASSWORD``, the
    password file ``~/.pgpass`` or a ``?service=`` of ``pg_service.conf``)."""

    scheme: str
    user: str
    password: str | None
    host: str
    port: int | None
    database: str
    query: tuple[tuple[str, str], ...]

    def _text(self, query: list[tuple[str, str]], database: str | None = None) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        user = f"{quote(self.user, safe='')}@" if self.user else ""
        port = f":{self.port}" if self.port is not None else ""
        tail = f"?{urlencode(query)}" if query else ""
        return f"{self.scheme}{user}{host}{port}/{quote(self.database if database is None else database)}{tail}"

    def public(self) -> str:
        """The URL as messages and titles show it: no password, none of USVIPS's own query parameters."""
        return self._text([(k, v) for k, v in self.query if k not in OWN_QUERY and k != "password"])

    def kept(self) -> str:
        """The URL as it may be kept (a recent-projects list): the password left out, all else kept."""
        return self._text([(k, v) for k, v in self.query if k != "password"])

    def name(self) -> str:
        """The survey's short name, ``host/database`` (``local/database`` for a socket on this machine)."""
        host = self.host or dict(self.query).get("host", "")
        return f"{host if host and not host.startswith('/') else 'local'}/{self.database}"

    def option(self, key: str) -> str | None:
        """The value of one query parameter (None when not given)."""
        return dict(self.query).get(key)

    def connection_parameters(self, database: str | None = None) -> dict[str, str | int]:
        """Keyword parameters for the server's client library (``psycopg.connect(**…)``): the password
        handed over as a value, never inside a URL; USVIPS's own query parameters left out."""
        parameters: dict[str, str | int] = {"dbname": self.database if database is None else database}
        for key, value in (("host", self.host), ("user", self.user), ("password", self.password)):
            if value:
                parameters[key] = value
        if self.port is not None:
            parameters["port"] = self.port
        parameters.update({k: v for k, v in self.query if k not in OWN_QUERY and k != "dbname"})
        return parameters


def parse_server_location(url: str) -> ServerLocation:
    """Read a server URL (see :class:`ServerLocation`); a password may hold any character (``#``, ``@``,
    ``/``, ``:``, percent-encoded or not where unambiguous). A URL that cannot be read is a
    :class:`ProjectError` in one line naming it (without its password) and what is wrong: a port that is
    not a number or out of range, a broken IPv6 host, no database."""
    scheme = next((s for s in SERVER_SCHEMES if url.lower().startswith(s)), None)
    if scheme is None:
        raise ProjectError(f"{redact(url)}: not a server address (postgresql://USER@HOST[:PORT]/DATABASE)")
    user_information, rest = split_user_information(url[len(scheme):])
    user, password = "", None
    if user_information is not None:
        user, _, secret = user_information.partition(":")
        user, password = unquote(user), (unquote(secret) or None)
        remember_secret(password)
        remember_secret(secret)
    shown = redact(url)
    authority, slash, after = rest.partition("/")
    if not slash:
        authority, _, after = rest.partition("?")
        after = "?" + after if after else ""
        path, _, query_text = "", "", after[1:]
    else:
        path, _, query_text = after.partition("?")
    host, port = _host_and_port(authority, shown)
    database = unquote(path)
    if not database or "/" in database:
        raise ProjectError(f"{shown}: name the survey's database at the end of the URL "
                           "(postgresql://user@host/DATABASE)")
    query = []
    for pair in filter(None, query_text.split("&")):
        key, _, value = pair.partition("=")
        query.append((unquote(key), unquote(value)))
        if unquote(key) == "password":
            remember_secret(unquote(value))
    if "port" in dict(query):
        _port(dict(query)["port"], shown)
    return ServerLocation(scheme, user, password, host, port, database, tuple(query))


def _host_and_port(authority: str, shown: str) -> tuple[str, int | None]:
    if authority.startswith("["):
        inside, closed, after = authority[1:].partition("]")
        if not closed:
            raise ProjectError(f"{shown}: the IPv6 host {authority!r} has no closing ']' (write it as [::1])")
        try:
            ipaddress.IPv6Address(inside.split("%", 1)[0])
        except ValueError:
            raise ProjectError(f"{shown}: the host [{inside}] is not an IPv6 address") from None
        if after and not after.startswith(":"):
            raise ProjectError(f"{shown}: {after!r} after the IPv6 host; give :PORT or nothing")
        return inside, _port(after[1:], shown) if after else None
    if "[" in authority or "]" in authority:
        raise ProjectError(f"{shown}: the host {authority!r} is a broken IPv6 address (write it as [::1]:PORT)")
    host, colon, port = authority.partition(":")
    return unquote(host), _port(port, shown) if colon else None


def _port(text: str, shown: str) -> int | None:
    """A port number 1 … 65535 ('' is none); anything else refused in one line."""
    if text == "":
        return None
    if not text.isascii() or not text.isdigit():
        raise ProjectError(f"{shown}: the port {text!r} is not a number (give 1 to {MAX_PORT}, e.g. 5432)")
    if not 1 <= int(text) <= MAX_PORT:
        raise ProjectError(f"{shown}: the port {int(text)} is out of range (1 to {MAX_PORT})")
    return int(text)


def public_location(url: str) -> str:
    """A server URL without its password (nor USVIPS's own query parameters): what messages show. A URL
    that cannot be read is shown redacted."""
    try:
        return parse_server_location(url).public()
    except ProjectError:
        return redact(url)


def without_password(url: str) -> str:
    """A server URL as it may be kept (a recent-projects list): its password left out, all else kept (a
    password then comes from the server's usual sources, e.g. ``~/.pgpass``)."""
    try:
        return parse_server_location(url).kept()
    except ProjectError:
        return redact(url)


def database_name(url: str) -> str:
    """The name of the database a server URL names (its path); empty when it names none."""
    try:
        return parse_server_location(url).database
    except ProjectError:
        return ""


def survey_name(location: str | Path) -> str:
    """How a title names a project: a file by its name, a survey on a server as ``host/database``."""
    if is_server_location(location):
        try:
            return parse_server_location(str(location)).name()
        except ProjectError:
            return redact(location)
    return Path(location).name


def shown(location: str | Path) -> str:
    """How a location is printed: a file as its path, a server URL without its password."""
    return public_location(location) if is_server_location(location) else redact(location)
