"""The chunked observation reader's duplicate check beyond its in-memory set: keys of later rows go to a
temporary file checked when the file ends or a bad line is met, and the error is still the whole-file
reader's (the first bad line, naming the earlier line of a duplicate id)."""

import numpy as np
import pytest

from usvips.core.errors import InputFileError
from usvips.io import observation_stream
from usvips.io.observation_stream import SeenKeys, observation_chunks
from usvips.io.tables import read_observations


def _rows(rng, count: int, pairs: bool) -> list[str]:
    rows = [f"p{i},{100 + i % 50},{200 + i % 40},{90 + i % 50},{200 + i % 40}" for i in range(count)]
    if pairs:
        rows = [f"{row},{'ab'[int(rng.integers(2))]}" for row in rows]
    return rows


def _faulty_file(tmp_path, rng, case: int) -> tuple:
    """An observation file of 1-60 rows with 0-3 ids given again and perhaps a bad line, anywhere."""
    pairs = bool(case % 3 == 0)
    rows = _rows(rng, int(rng.integers(1, 61)), pairs)
    for _ in range(int(rng.integers(0, 4))):
        if len(rows) > 1:
            source, target = sorted(rng.choice(len(rows), 2, replace=False).tolist())
            fields = rows[target].split(",")
            fields[0] = rows[source].split(",")[0]
            rows[target] = ",".join(fields)
    if rng.random() < 0.3:
        rows[int(rng.integers(len(rows)))] = "q,1,abc,3,4" + (",a" if pairs else "")
    path = tmp_path / f"obs_{case}.csv"
    path.write_text("\n".join(["id,xl,yl,xr,yr" + (",pair" if pairs else ""), *rows]) + "\n")
    return path


def _first_fault(path) -> tuple[int, str] | None:
    """The first bad line of a file made by :func:`_faulty_file` and what its error says (by hand)."""
    lines = path.read_text().splitlines()
    pairs = lines[0].endswith(",pair")
    seen: dict[tuple[str, str], int] = {}
    for number, line in enumerate(lines[1:], start=2):
        fields = line.split(",")
        if fields[2] == "abc":
            return number, "column yl: 'abc' is not a number"
        key = (fields[5] if pairs else "1", fields[0])
        if key in seen:
            return number, f"duplicate id '{key[1]}' in pair '{key[0]}' (first on line {seen[key]})"
        seen[key] = number
    return None


@pytest.mark.parametrize("memory_keys", [0, 1, 5, 17, 1 << 20])
def test_the_first_bad_line_is_named(tmp_path, memory_keys):
    """Over many random files with ids given twice (within a chunk, across chunks, within and beyond the
    in-memory set) and bad lines, each cut into chunks of several sizes: the first bad line is named, as
    the whole-file reader names it when it is the only fault."""
    rng = np.random.default_rng(memory_keys)
    failures = 0
    for case in range(60):
        path = _faulty_file(tmp_path, rng, case)
        fault = _first_fault(path)
        for rows in (1, 4, 9, 100):
            if fault is None:
                whole = read_observations(path)
                chunks = list(observation_chunks(path, rows=rows, memory_keys=memory_keys))
                assert sum((c.ids for c in chunks), ()) == whole.ids
                assert sum((c.lines for c in chunks), ()) == whole.lines
            else:
                with pytest.raises(InputFileError) as error:
                    list(observation_chunks(path, rows=rows, memory_keys=memory_keys))
                assert str(error.value) == f"{path}, line {fault[0]}: {fault[1]}", (case, rows)
        failures += fault is not None
    assert failures > 20  # the cases did hold faults


def test_hash_collisions_are_not_taken_for_duplicates(tmp_path, monkeypatch):
    """Every key given the same hash: the lines are read again, and only a true duplicate is named."""
    monkeypatch.setattr(observation_stream, "hash", lambda key: 7, raising=False)
    rows = _rows(np.random.default_rng(1), 30, pairs=False)
    path = tmp_path / "obs.csv"
    path.write_text("\n".join(["id,xl,yl,xr,yr", *rows]) + "\n")
    for memory_keys in (0, 4, 100):
        assert len(sum((c.ids for c in observation_chunks(path, rows=7, memory_keys=memory_keys)), ())) == 30
    rows[25] = "p20" + rows[25][3:]  # row 25 (line 27) repeats the id of row 20 (line 22)
    path.write_text("\n".join(["id,xl,yl,xr,yr", *rows]) + "\n")
    for memory_keys in (0, 4, 100):
        with pytest.raises(InputFileError, match=r"line 27: duplicate id 'p20' in pair '1' \(first on line 22\)"):
            list(observation_chunks(path, rows=7, memory_keys=memory_keys))


def test_the_keys_beyond_the_set_are_spilled_not_held(tmp_path):
    """Memory stays flat: past ``memory_keys`` rows the set no longer grows."""
    path = tmp_path / "obs.csv"
    path.write_text("\n".join(["id,xl,yl,xr,yr", *_rows(np.random.default_rng(2), 500, pairs=False)]) + "\n")
    checked = observation_stream._Checked(path, memory_keys=64)
    try:
        chunks = list(observation_stream._checked_chunks(path, 50, 1 << 22, True, checked))
        assert len(checked.keys) == 64 and checked._spilled == 436 and sum(map(len, chunks)) == 500
    finally:
        checked.close()


def test_the_hash_set_says_which_keys_it_holds():
    rng = np.random.default_rng(6)
    seen, reference = SeenKeys(size=16), set()
    for _ in range(20):
        keys = rng.integers(-40, 2000, rng.integers(1, 300))
        probe = rng.integers(-60, 2500, 500)
        assert seen.contains(probe).tolist() == [(k or 1) in reference for k in probe.tolist()]
        seen.add(keys)
        reference.update((k or 1) for k in keys.tolist())
    assert len(seen) == len(reference)
