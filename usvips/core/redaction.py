"""Secrets kept: the ONE function that takes passwords out of any text before it is shown or written.

Every door that shows or writes text that may hold a server address — command-line output and errors
(the CLI's streams pass through :func:`redact`), the window's title, status messages, log panel and
recent-projects list, progress lines, batch results, history rows, exported and log files — calls
:func:`redact`. It removes:

- the password of every ``postgresql://`` / ``postgres://`` URL in the text, whatever characters it holds
  (``#``, ``@``, ``/``, ``:``, percent-encoded or not: the user information ends at the last ``@`` that
  is followed by a host and a ``/database``), keeping the user name;
- the value of every ``password=`` in a query string or a libpq connection string;
- every password this process has read (:func:`remember_secret`, called by the server-address parser),
  wherever it appears (a library's error message quoting it, say).

Pure text: no I/O. The replacement is :data:`HIDDEN`.
"""

from __future__ import annotations

import re

HIDDEN = "***"
#: passwords shorter than this are not searched for in free text (a one-letter password would blot out
#: every such letter); they are still removed from URLs and ``password=`` values
MIN_REMEMBERED = 4

_remembered: set[str] = set()
_URL = re.compile(r"(?P<scheme>postgres(?:ql)?://)(?P<rest>[^\s<>]*)", re.I)
_KEY_VALUE = re.compile(r"(?P<key>\bpassword\s*=\s*)(?P<value>'(?:[^'\\]|\\.)*'|[^\s&'\"]+)", re.I)
#: what follows the user information in a URL: a host (any text without '@', '/' or '?': a broken one is
#: the parser's to name) with its port, then a /database or a query (a socket folder given as ?host=). An
#: '@' in a query value is percent-encoded (%40); in a password it may be typed as it is
_AFTER_AT = re.compile(r"^[^@/?]*[/?].*$", re.S)


def remember_secret(secret: str | None) -> None:
    """Remember a password read by this process, to take it out of any text :func:`redact` sees."""
    if secret and len(secret) >= MIN_REMEMBERED:
        _remembered.add(secret)
        _remembered.add(_percent_encoded(secret))


def _percent_encoded(secret: str) -> str:
    from urllib.parse import quote

    return quote(secret, safe="")


def split_user_information(rest: str) -> tuple[str | None, str]:
    """A URL's text after ``scheme://`` split into its user information (None when it has none) and the
    rest (host, port, path, query): at the LAST ``@`` after which a host, a port and a path or query
    follow — so a password may hold ``@``, ``/``, ``:``, ``#`` unencoded."""
    positions = [i for i, c in enumerate(rest) if c == "@"]
    for at in reversed(positions):
        if _AFTER_AT.match(rest[at + 1:]):
            return rest[:at], rest[at + 1:]
    if positions:  # no '@' is followed by a path: the URL ends at its host; the last '@' ends the user's part
        return rest[:positions[-1]], rest[positions[-1] + 1:]
    return None, rest


def _redact_url(match: re.Match) -> str:
    user_information, rest = split_user_information(match.group("rest"))
    if user_information is None:
        return match.group("scheme") + _KEY_VALUE.sub(lambda m: m.group("key") + HIDDEN, rest)
    user = user_information.split(":", 1)[0]
    rest = _KEY_VALUE.sub(lambda m: m.group("key") + HIDDEN, rest)
    return f"{match.group('scheme')}{user}@{rest}" if user else f"{match.group('scheme')}{rest}"


def redact(text: object) -> str:
    """``text`` (any object, as ``str``) without a password: see the module docstring."""
    out = _URL.sub(_redact_url, str(text))
    out = _KEY_VALUE.sub(lambda m: m.group("key") + HIDDEN, out)
    for secret in sorted(_remembered, key=len, reverse=True):
        out = out.replace(secret, HIDDEN)
    return out
