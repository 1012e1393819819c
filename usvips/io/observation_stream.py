"""A stereo observation CSV (``id,xl,yl,xr,yr[,pair]``, see :mod:`usvips.io.tables`) read in chunks of
rows, so that a file of any length is read with flat memory (``usvips intersect`` over 10⁷ points).

Every chunk is checked as :func:`usvips.io.tables.read_observations` checks a whole file, with the same
messages naming the file and line; a file with several faults names the first bad line (in line order).
An id given twice in a pair is found across chunks by a hash set (:class:`SeenKeys`) of the first
:data:`MEMORY_KEYS` rows; the keys of further rows are looked up in it and then written to a temporary
file (16 bytes a row) whose duplicates are found bucket by bucket when the file ends or a bad line is
met, so memory stays flat however long the file (:class:`_Checked`). The lines named in that error
are found by reading the file again (only on that error). Chunked or whole, the rows are the same, and
the error is always the first bad line's.
"""

from __future__ import annotations

import math
import re
import tempfile
from collections.abc import Iterator
from itertools import repeat
from pathlib import Path

import numpy as np

from usvips.core.errors import InputFileError
from usvips.core.observations import StereoObservations
from usvips.io.file_errors import not_a_file
from usvips.io.tables import (
    MAX_FIELD_CHARS,
    OBSERVATION_COLUMNS,
    _check_id,
    _check_width,
    _column_index,
    _number,
    _show,
    check_header,
    split_line,
)
from usvips.io.text_lines import last_break_end, line_of_offset, not_utf8, refuse_control_characters, split_lines

#: data rows per chunk (each chunk is read, intersected and written before the next)
CHUNK_ROWS = 1 << 15
#: bytes read from the file at a time
BLOCK_BYTES = 1 << 22
#: rows whose (pair, id) keys the duplicate check holds in memory (a hash table of 16 MiB); the keys of
#: further rows go to a temporary file (see :class:`_Checked`)
MEMORY_KEYS = 1 << 20
#: spilled keys sorted at a time when the temporary file is checked (16 MiB of keys and lines)
BUCKET_KEYS = 1 << 20
#: a block of lines may take the quick path only when it holds nothing but these (no blanks, quotes, '#',
#: controls or non-ASCII characters: those lines go through the line-by-line checks)
_PLAIN = re.compile(r"[^\x21\x24-\x7e\n]")


class SeenKeys:
    """A set of 64-bit hashes in a numpy open-addressing table (at most 3/4 full: 11-21 bytes per key):
    :meth:`add` tells which of a batch of keys were seen before, earlier in the batch included."""

    #: keys moved at a time when the table grows (the temporary arrays stay small)
    BATCH = 1 << 16

    def __init__(self, size: int = 1 << 12) -> None:
        self._table = np.zeros(max(16, 1 << (int(size) - 1).bit_length()), dtype=np.int64)
        self._count = 0

    def _slots(self, keys: np.ndarray) -> np.ndarray:
        mixed = (keys.view(np.uint64) * np.uint64(0x9E3779B97F4A7C15)) >> np.uint64(17)
        return (mixed & np.uint64(len(self._table) - 1)).astype(np.int64)

    def _grow(self, needed: int) -> None:
        size = len(self._table)
        while 4 * needed > 3 * size:
            size *= 2
        if size != len(self._table):
            old, self._table, self._count = self._table, np.zeros(size, dtype=np.int64), 0
            for start in range(0, len(old), self.BATCH):
                part = old[start:start + self.BATCH]
                self._insert(part[part != 0])

    def add(self, keys: np.ndarray) -> np.ndarray:
        """Insert ``keys`` (int64); returns the (ascending) indices of those already in the set."""
        keys = np.where(keys == 0, 1, np.asarray(keys, dtype=np.int64))  # 0 marks an empty slot
        self._grow(self._count + len(keys))
        return self._insert(keys)

    def _insert(self, keys: np.ndarray) -> np.ndarray:
        mask = len(self._table) - 1
        slots = self._slots(keys)
        pending = np.arange(len(keys))
        seen: list[np.ndarray] = []
        while pending.size:
            at = slots[pending]
            current = self._table[at]
            hit = current == keys[pending]
            seen.append(pending[hit])
            empty = current == 0
            free, first = np.unique(at[empty], return_index=True)  # the earliest key takes a free slot
            winners = pending[empty][first]
            self._table[free] = keys[winners]
            self._count += len(winners)
            placed = np.zeros(len(pending), dtype=bool)
            placed[np.flatnonzero(empty)[first]] = True
            moving = ~hit & ~empty  # another key holds the slot: probe the next one
            slots[pending[moving]] = (slots[pending[moving]] + 1) & mask
            pending = pending[~hit & ~placed]  # losers of a free slot look at it again (ascending order kept)
        return np.sort(np.concatenate(seen)) if seen else np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return self._count

    def contains(self, keys: np.ndarray) -> np.ndarray:
        """Which of ``keys`` (int64) are in the set (a boolean mask); nothing is inserted."""
        keys = np.where(keys == 0, 1, np.asarray(keys, dtype=np.int64))
        mask = len(self._table) - 1
        slots = self._slots(keys)
        found = np.zeros(len(keys), dtype=bool)
        pending = np.arange(len(keys))
        while pending.size:
            current = self._table[slots[pending]]
            found[pending[current == keys[pending]]] = True
            moving = (current != keys[pending]) & (current != 0)  # another key holds the slot: probe on
            pending = pending[moving]
            slots[pending] = (slots[pending] + 1) & mask
        return found


def _lines(path: Path, block_bytes: int) -> Iterator[tuple[int, list[str]]]:
    """(number of the first line, lines) of the file, block by block, numbered and split as an editor does
    (:mod:`usvips.io.text_lines`: at CR LF, CR or LF); a file that is not UTF-8 is named with its
    line."""
    number, carry, first = 1, b"", True
    with open(path, "rb") as stream:
        while True:
            data = stream.read(block_bytes)
            block = carry + data
            if not data:
                carry = b""
            else:
                cut = last_break_end(block, more=True)
                block, carry = block[:cut], block[cut:]
                if not block:
                    carry = block + carry
                    continue
            if first and block.startswith(b"\xef\xbb\xbf"):
                block = block[3:]
            first = first and not block
            try:
                text = block.decode("utf-8")
            except UnicodeDecodeError as error:
                if number == 1:
                    raise not_utf8(str(path), block, error.start) from None
                line = number - 1 + line_of_offset(block, error.start)
                raise InputFileError(str(path), "not a text (UTF-8) CSV file", line) from None
            refuse_control_characters(str(path), text, number)
            lines = split_lines(text)
            if lines:
                yield number, lines
            number += len(lines)
            if not data:
                return


class _Checked:
    """The (pair, id) keys of the rows checked so far, for duplicates: the first ``memory_keys`` in a hash
    set; every further row's key is looked up in that set and among its own chunk's rows (such a
    duplicate is found at once) and then written with its line to a temporary file, whose duplicates
    across chunks :meth:`spilled_duplicate` finds bucket by bucket (at most :data:`BUCKET_KEYS` keys
    sorted at a time): memory stays flat however long the file."""

    def __init__(self, path: Path, memory_keys: int = MEMORY_KEYS) -> None:
        self.path = path
        self.keys = SeenKeys()
        self.memory_keys = int(memory_keys)
        self._spill = None  # the temporary file of (hash, line) int64 pairs
        self._spilled = 0

    def duplicate(self, ids: list[str], pairs: list[str] | None, lines: list[int]) -> InputFileError | None:
        """The error of the first row of the chunk whose (pair, id) a row of the set (an earlier row, or
        one before it in this chunk) has; None: none. Rows beyond the set are spilled (see the class)."""
        # a file without a pair column keys its rows by id alone (one pair): the ids' own hashes, which
        # Python keeps with each string, without a tuple per row
        hashes = np.fromiter(map(hash, zip(pairs, ids, strict=True) if pairs is not None else ids),
                             dtype=np.int64, count=len(ids))
        room = max(self.memory_keys - len(self.keys), 0)
        candidates = self.keys.add(hashes[:room]).tolist()
        if len(hashes) > room:
            rest = hashes[room:]
            within = SeenKeys(2 * len(rest)).add(rest)  # a chunk's own rows repeated: found here, at once
            candidates += (room + np.union1d(np.flatnonzero(self.keys.contains(rest)), within)).tolist()
            self._write_spill(rest, np.asarray(lines[room:], dtype=np.int64))
        if not candidates:
            return None
        keyed = list(zip(pairs, ids, strict=True)) if pairs is not None else [("1", i) for i in ids]
        for k in sorted(candidates):
            earlier = keyed.index(keyed[k])
            first = lines[earlier] if earlier < k else self._first_line(keyed[k], lines[0])
            if first is not None:
                return self._error(keyed[k], first, lines[k])
        return None

    def _error(self, key: tuple[str, str], first: int, line: int) -> InputFileError:
        pair, pid = key
        return InputFileError(str(self.path), f"duplicate id {_show(pid)} in pair {_show(pair)} (first on line "
                              f"{first})", line)

    def _write_spill(self, hashes: np.ndarray, lines: np.ndarray) -> None:
        if self._spill is None:
            self._spill = tempfile.TemporaryFile(prefix="usvips-ids-")
        self._spill.seek(0, 2)
        self._spill.write(np.column_stack([hashes, lines]).tobytes())
        self._spilled += len(hashes)

    def _spilled_rows(self, bucket: int, buckets: int) -> np.ndarray:
        """The spilled (hash, line) rows whose hash falls in ``bucket`` of ``buckets`` (read in blocks)."""
        self._spill.seek(0)
        parts = []
        while True:
            block = self._spill.read(16 * BUCKET_KEYS)
            if not block:
                break
            rows = np.frombuffer(block, dtype=np.int64).reshape(-1, 2)
            parts.append(rows[rows[:, 0].view(np.uint64) % np.uint64(buckets) == bucket] if buckets > 1 else rows)
        return np.concatenate(parts) if parts else np.zeros((0, 2), dtype=np.int64)

    def spilled_duplicate(self) -> InputFileError | None:
        """The error of the first spilled row whose key an earlier spilled row has (None: none)."""
        if not self._spilled:
            return None
        buckets = -(-self._spilled // BUCKET_KEYS)
        found: list[tuple[int, int]] = []  # (line, the line of the first row with its hash)
        for bucket in range(buckets):
            rows = self._spilled_rows(bucket, buckets)
            rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]  # by hash, then line
            again = np.flatnonzero(rows[1:, 0] == rows[:-1, 0]) + 1
            if again.size:
                starts = np.flatnonzero(np.r_[True, rows[1:, 0] != rows[:-1, 0]])
                group = np.searchsorted(starts, again, side="right") - 1
                found.extend(zip(rows[again, 1].tolist(), rows[starts[group], 1].tolist(), strict=True))
        if not found:
            return None
        found.sort()
        keys = self._keys_at({line for pair in found for line in pair})
        for line, first in found:  # a different key of the same hash is a collision, not a duplicate
            if keys[line] == keys[first]:
                return self._error(keys[line], first, line)
        return None

    def _keys_at(self, wanted: set[int]) -> dict[int, tuple[str, str]]:
        """The (pair, id) keys of the rows on lines ``wanted`` (reading the file up to the last of them)."""
        keys: dict[int, tuple[str, str]] = {}
        columns: dict[str, int] | None = None
        last = max(wanted)
        for start, lines in _lines(self.path, BLOCK_BYTES):
            for number, line in enumerate(lines, start=start):
                if number > last:
                    return keys
                fields = split_line(self.path, number, line)
                if fields is None:
                    continue
                if columns is None:
                    columns = {name: k for k, name in enumerate(fields)}
                elif number in wanted:
                    keys[number] = (fields[columns["pair"]] if "pair" in columns else "1", fields[columns["id"]])
        return keys

    def close(self) -> None:
        if self._spill is not None:
            self._spill.close()
            self._spill = None

    def _first_line(self, key: tuple[str, str], before: int) -> int | None:
        """The first line before line ``before`` whose row has ``key`` (None: a hash collision only)."""
        columns: dict[str, int] | None = None
        for start, lines in _lines(self.path, BLOCK_BYTES):
            for number, line in enumerate(lines, start=start):
                if number >= before:
                    return None
                fields = split_line(self.path, number, line)
                if fields is None:
                    continue
                if columns is None:
                    columns = {name: k for k, name in enumerate(fields)}
                    continue
                if (fields[columns["pair"]] if "pair" in columns else "1", fields[columns["id"]]) == key:
                    return number
        return None


def observation_chunks(path: str | Path, rows: int = CHUNK_ROWS, block_bytes: int = BLOCK_BYTES,
                       check_duplicates: bool = True, memory_keys: int = MEMORY_KEYS) -> Iterator[StereoObservations]:
    """The observation file at ``path`` as :class:`StereoObservations` of at most ``rows`` rows each, in
    file order (``lines`` gives each row's line); :class:`InputFileError` naming the file and the first
    bad line, raised when the chunk holding it is reached (the rows before it were given) — or, for an
    id given twice beyond the first ``memory_keys`` rows (see :class:`_Checked`), when the file ends."""
    path = Path(path)
    if not path.is_file():
        raise not_a_file(path)
    checked = _Checked(path, memory_keys)
    try:
        yield from _checked_chunks(path, rows, block_bytes, check_duplicates, checked)
    finally:
        checked.close()


def observation_header(path: str | Path, block_bytes: int = BLOCK_BYTES) -> list[str] | None:
    """The column names of the observation file's header line (None: no header before the file ends), read
    as :func:`observation_chunks` reads it: a caller that writes one row per observation learns here
    whether the file has a ``pair`` column before its chunks arrive."""
    path = Path(path)
    if not path.is_file():
        raise not_a_file(path)
    for start, lines in _lines(path, block_bytes):
        for number, line in enumerate(lines, start):
            fields = split_line(path, number, line)
            if fields is not None:
                return fields
    return None


def _checked_chunks(path: Path, rows: int, block_bytes: int, check_duplicates: bool,
                    checked: _Checked) -> Iterator[StereoObservations]:
    header: list[str] | None = None
    columns: dict[str, int] = {}
    given = 0
    try:
        waiting: list[str] = []  # lines read but not yet checked, and their numbers
        numbers: list[int] = []
        for start, lines in _lines(path, block_bytes):
            block_numbers = range(start, start + len(lines))
            if header is None:
                for k, (number, line) in enumerate(zip(block_numbers, lines, strict=True)):
                    fields = split_line(path, number, line)
                    if fields is not None:
                        header = fields
                        check_header(path, header, number)
                        columns = _column_index(path, header, OBSERVATION_COLUMNS)
                        lines, block_numbers = lines[k + 1:], block_numbers[k + 1:]
                        break
                else:
                    continue
            waiting.extend(lines)
            numbers.extend(block_numbers)
            while len(waiting) >= rows:
                chunk = _chunk(path, header, columns, waiting[:rows], numbers[:rows], checked, check_duplicates)
                del waiting[:rows], numbers[:rows]
                if len(chunk):
                    given += len(chunk)
                    yield chunk
        if waiting:
            chunk = _chunk(path, header, columns, waiting, numbers, checked, check_duplicates)
            if len(chunk):
                given += len(chunk)
                yield chunk
        spilled = checked.spilled_duplicate()
        if spilled is not None:
            raise spilled
    except OSError as error:
        raise InputFileError(str(path), f"cannot read the file: {error.strerror or error}") from None
    if header is None:
        raise InputFileError(str(path), "the file has no header line")
    if not given:
        raise InputFileError(str(path), "the file has a header but no data rows")


def _chunk(path: Path, header: list[str], columns: dict[str, int], lines: list[str], numbers: list[int],
           checked: _Checked, check_duplicates: bool) -> StereoObservations:
    """The rows of ``lines`` checked; the error of the first bad line (in line order) is raised."""
    parsed = _quick(header, columns, lines, numbers)
    failure: InputFileError | None = None
    if parsed is None:
        parsed, failure = _line_by_line(path, header, columns, lines, numbers)
    ids, pairs, pixels, extra, rows = parsed
    if check_duplicates and ids:
        duplicate = checked.duplicate(ids, pairs, rows)
        if duplicate is not None and (failure is None or duplicate.line < failure.line):
            failure = duplicate
    if failure is not None:
        spilled = checked.spilled_duplicate() if check_duplicates else None  # an earlier one not yet found
        raise spilled if spilled is not None and spilled.line < failure.line else failure
    return StereoObservations(tuple(ids), pixels[:, :2], pixels[:, 2:], tuple(pairs) if pairs else (), extra,
                              str(path), tuple(rows))


def _extra_names(header: list[str]) -> list[str]:
    return [c for c in header if c not in OBSERVATION_COLUMNS and c != "pair"]


def _quick(header: list[str], columns: dict[str, int], lines: list[str], numbers: list[int]):
    """The chunk's rows when every line is plain (one field per column, no blanks, quotes, comments or
    white space, every number finite), parsed in bulk; None: the lines must be checked one by one."""
    width = len(header)
    if not lines or "" in lines or max(map(len, lines)) > MAX_FIELD_CHARS:
        return None
    if set(map(str.count, lines, repeat(",", len(lines)))) != {width - 1}:
        return None
    block = "\n".join(lines)
    if _PLAIN.search(block):
        return None
    fields = block.replace("\n", ",").split(",")
    ids = fields[columns["id"]::width]
    pairs = fields[columns["pair"]::width] if "pair" in columns else None
    if "" in ids or (pairs is not None and "" in pairs):
        return None
    if any("_" in "".join(fields[columns[c]::width]) for c in ("xl", "yl", "xr", "yr", *_extra_names(header))):
        return None  # Python's digit separators (1_000), which numpy reads: refused by name on the slow path
    try:
        pixels = np.array([fields[columns[c]::width] for c in ("xl", "yl", "xr", "yr")], dtype=np.float64).T
        extra = {c: np.array([float(t) if t else math.nan for t in fields[columns[c]::width]])
                 for c in _extra_names(header)}
    except ValueError:
        return None
    if not np.all(np.isfinite(pixels)) or any(np.isinf(v).any() for v in extra.values()):
        return None
    if any(np.isnan(v).any() and "nan" in " ".join(fields[columns[c]::width]).lower() for c, v in extra.items()):
        return None  # a written-out "nan" is refused by name on the slow path
    return ids, pairs, pixels, extra, numbers


def _line_by_line(path: Path, header: list[str], columns: dict[str, int], lines: list[str],
                  numbers: list[int]):
    """The chunk's rows up to its first bad line, and that line's error (None: every line is good)."""
    ids, pairs, pixels, rows = [], [], [], []
    extra_names = _extra_names(header)
    extra: dict[str, list[float]] = {c: [] for c in extra_names}
    failure = None
    for number, line in zip(numbers, lines, strict=True):
        try:
            fields = split_line(path, number, line)
            if fields is None:
                continue
            _check_width(path, number, fields, header)
            pid = _check_id(path, number, fields[columns["id"]])
            pair = fields[columns["pair"]] if "pair" in columns else "1"
            if not pair:
                raise InputFileError(str(path), "empty pair label", number)
            values = [_number(path, number, c, fields[columns[c]]) if fields[columns[c]] else math.nan
                      for c in extra_names]
            pixel = [_number(path, number, c, fields[columns[c]]) for c in ("xl", "yl", "xr", "yr")]
        except InputFileError as error:
            failure = error
            break
        ids.append(pid)
        pairs.append(pair)
        rows.append(number)
        pixels.append(pixel)
        for c, value in zip(extra_names, values, strict=True):
            extra[c].append(value)
    table = np.array(pixels, dtype=np.float64).reshape(-1, 4)
    return (ids, pairs if "pair" in columns else None, table, {c: np.array(v) for c, v in extra.items()},
            rows), failure
