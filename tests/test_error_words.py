"""Errors of core, app and io are in the user's terms: no message names a command-line flag (the window
shows them to people who never typed one). An error about a setting carries it in ``parameter``; each
front end says how to set it (the command line's hints: tests/cli/test_flag_hints.py)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "usvips"

#: a command-line flag: two dashes and a word (not a line of dashes, not a word-joined '--')
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")


def _docstrings(tree: ast.AST) -> set[int]:
    """ids of the docstring constants of a module's functions and classes (they may show a command)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                found.add(id(first.value))
    return found


def flags_in_strings(source: str) -> list[tuple[int, str]]:
    """(line, text) of every string in ``source`` (docstrings and comments aside) that names a flag."""
    tree = ast.parse(source)
    docstrings = _docstrings(tree)
    return sorted((node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings
            and FLAG.search(node.value))


def test_the_scan_finds_a_flag_in_a_message_and_in_a_parameter_name():
    source = ('def f(x):\n    """Run it with --out."""\n    raise ValueError(f"{x}: --out must be a folder")\n'
              'def g(parameter="--max-dt"):\n    return "a line ---------- of dashes"\n')
    assert [line for line, _ in flags_in_strings(source)] == [3, 4]


def test_no_string_of_core_app_or_io_names_a_command_line_flag():
    offending = []
    for layer in ("core", "app", "io"):
        for path in sorted((PACKAGE / layer).rglob("*.py")):
            for line, text in flags_in_strings(path.read_text(encoding="utf-8")):
                offending.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {text[:80]!r}")
    assert not offending, "strings naming command-line flags:\n" + "\n".join(offending)
