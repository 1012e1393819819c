"""Edits of a model description's text (TOML) that keep the rest of it as written, comments included."""

from __future__ import annotations


def without_table(text: str, table: str) -> str:
    """A description's text without its ``[table]`` (from its header, and the comment lines just above it, to
    the next table or the end); the text unchanged when it has none."""
    lines = text.splitlines(keepends=True)
    start = next((i for i, line in enumerate(lines) if line.lstrip().startswith(f"[{table}]")), None)
    if start is None:
        return text
    end = next((i for i in range(start + 1, len(lines)) if lines[i].lstrip().startswith("[")), len(lines))
    while start > 0 and lines[start - 1].lstrip().startswith("#"):
        start -= 1
    return "".join(lines[:start] + lines[end:])
