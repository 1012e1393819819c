"""Lines of a text file numbered as an editor numbers them.

A line ends at ``\\r\\n``, ``\\r`` or ``\\n`` — Windows, classic Mac and Unix — and nowhere else.
:meth:`str.splitlines` also breaks at form feeds, vertical tabs, the file, group and record separators,
NEL and the Unicode line and paragraph separators, which an editor shows inside a line: an error message
numbered by it would name a line after the one the user sees.
"""

from __future__ import annotations

import re

from usvips.core.errors import InputFileError

#: characters no field of a text table holds: C0 controls but the tab and the line breaks (the NUL is
#: binary data, named as such by the tables), DEL, the C1 controls and the Unicode line and paragraph
#: separators
CONTROL_CHARACTERS = re.compile("[\x01-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\u2028\u2029]")


def split_lines(text: str) -> list[str]:
    """The lines of ``text`` without their breaks (see the module docstring); a break at the very end ends
    the last line, as :meth:`str.splitlines` has it."""
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    if lines[-1] == "":
        lines.pop()
    return lines


def line_of_offset(data: bytes, offset: int) -> int:
    """The number (from 1) of the line of ``data`` that holds byte ``offset`` (breaks as :func:`split_lines`)."""
    head = data[:offset]
    return head.count(b"\n") + head.count(b"\r") - head.count(b"\r\n") + 1


def last_break_end(block: bytes, more: bool) -> int:
    """Where the last whole line of ``block`` ends (just after its break; 0 when none ends in it). ``more``:
    further bytes follow the block, so a ``\\r`` at its very end may be the first half of a ``\\r\\n``
    and does not end a line yet."""
    search = block[:-1] if more and block.endswith(b"\r") else block
    return max(search.rfind(b"\n"), search.rfind(b"\r")) + 1


def refuse_control_characters(path: str, text: str, first_line: int = 1) -> None:
    """An :class:`InputFileError` naming the line (``text`` begins at line ``first_line``) and the character
    when ``text`` holds a control character (:data:`CONTROL_CHARACTERS`): a field holding one would be
    stored as it is, and shown in ways no one typed. One scan of the whole text, not one per line."""
    found = CONTROL_CHARACTERS.search(text)
    if found is None:
        return
    line = first_line + len(split_lines(text[:found.start()] + "x")) - 1
    raise InputFileError(str(path), f"a control character (U+{ord(found.group()):04X}) in the line: not plain CSV "
                         "text", line)


def not_utf8(path: str, data: bytes, offset: int, what: str = "CSV file") -> InputFileError:
    """The error of a text file whose bytes ``data`` do not decode as UTF-8 at ``offset``: by its line, or as
    UTF-16 when it begins with that byte-order mark (a spreadsheet's "Unicode text" export)."""
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return InputFileError(str(path), f"is UTF-16 text, not UTF-8: save it as a UTF-8 {what}")
    return InputFileError(str(path), f"not a text (UTF-8) {what}", line_of_offset(data, offset))
