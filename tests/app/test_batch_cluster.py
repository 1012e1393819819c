"""usvips/app/batch_cluster.py: the batch tasks on a real local Dask distributed cluster give what the
serial run gives, byte for byte; a failing task is one line naming its input and the others are done."""

import shutil
from pathlib import Path

import pytest

from usvips.app import batch
from usvips.app.batch_cluster import local_workers, run_on_cluster
from usvips.cli import main
from usvips.core.errors import InvalidParameterError, UsvipsError

ROV = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport"
CALIBRATION = str(ROV / "calibration.json")


def _inputs(folder: Path) -> list[Path]:
    """Three good observation files (one with its pixels shifted), a broken one and a missing one."""
    folder.mkdir()
    files = []
    for k in range(3):
        target = folder / f"pair{k}.csv"
        shutil.copy(ROV / "observations_water.csv", target)
        files.append(target)
    lines = files[2].read_text().splitlines()
    files[2].write_text("\n".join([lines[0]] + [_shifted(line) for line in lines[1:]]) + "\n")
    broken = folder / "broken.csv"
    broken.write_text("id,xl,yl,xr,yr\n1,2,3,four,5\n")
    return [files[0], broken, files[1], folder / "missing.csv", files[2]]


def _shifted(line: str) -> str:
    cells = line.split(",")
    return ",".join([cells[0], *(f"{float(c) + 0.5:.4f}" for c in cells[1:5]), *cells[5:]])


def _tasks(inputs: list[Path], out: Path) -> list[batch.Task]:
    out.mkdir(exist_ok=True)
    return [batch.Task(p.name, batch.intersect_task, {"observations": str(p), "calibration": CALIBRATION,
                                                      "out": str(out / f"{p.stem}.points.csv")}) for p in inputs]


def test_a_local_cluster_gives_what_the_serial_run_gives_and_reports_failures_by_input(tmp_path):
    inputs = _inputs(tmp_path / "in")
    serial = batch.run(_tasks(inputs, tmp_path / "serial"), jobs=1)
    seen = []
    clustered = run_on_cluster(_tasks(inputs, tmp_path / "cluster"), "local:2",
                               progress=lambda outcome, done, total: seen.append((done, total)))
    assert sorted(seen) == [(k, 5) for k in range(1, 6)]
    assert [o.task.label for o in clustered] == [p.name for p in inputs]
    assert [o.status for o in clustered] == [o.status for o in serial] == ["ok", "failed", "ok", "failed", "ok"]
    for a, b in zip(serial, clustered, strict=True):
        assert a.message == b.message
        if a.ok:
            assert a.summary["points"] == b.summary["points"] > 10
            assert Path(a.summary["out"]).read_bytes() == Path(b.summary["out"]).read_bytes()
        else:
            assert "\n" not in b.message and b.task.label in b.message
    outputs = {p.name for p in (tmp_path / "cluster").iterdir()}
    assert outputs == {"pair0.points.csv", "pair1.points.csv", "pair2.points.csv"}  # nothing half-written
    # the shifted pair really gives other points: identical outputs are not a copy of one file
    assert (tmp_path / "cluster" / "pair2.points.csv").read_bytes() != (tmp_path / "cluster" /
                                                                         "pair0.points.csv").read_bytes()


def test_the_command_line_runs_on_a_local_cluster_and_refuses_bad_schedulers_in_one_line(tmp_path, capsys):
    inputs = _inputs(tmp_path / "in")
    names = [str(p) for p in inputs]
    assert main(["batch", "intersect", "--calibration", CALIBRATION, "--out-dir", str(tmp_path / "a"), "--jobs",
                 "1", *names]) == 2
    serial = capsys.readouterr()
    assert main(["batch", "intersect", "--calibration", CALIBRATION, "--out-dir", str(tmp_path / "b"),
                 "--scheduler", "local:2", *names]) == 2
    clustered = capsys.readouterr()
    assert _task_lines(clustered.out, tmp_path / "b") == _task_lines(serial.out, tmp_path / "a")
    assert "3 of 5 succeeded, 2 failed" in clustered.err
    assert any("FAILED" in line and "broken.csv" in line for line in clustered.out.splitlines())
    for name in ("pair0", "pair1", "pair2"):
        assert (tmp_path / "a" / f"{name}.points.csv").read_bytes() == (tmp_path / "b" / f"{name}.points.csv"
                                                                         ).read_bytes()
    for scheduler, words in (("local:0", "positive whole number"), ("local:x", "positive whole number"),
                             ("tcp://127.0.0.1:1", "cannot reach the Dask scheduler")):
        assert main(["batch", "intersect", "--calibration", CALIBRATION, "--out-dir", str(tmp_path / "c"),
                     "--scheduler", scheduler, *names[:1]]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], err
    assert main(["batch", "intersect", "--calibration", CALIBRATION, "--out-dir", str(tmp_path / "c"),
                 "--scheduler", "local:1", "--jobs", "2", *names[:1]]) == 2
    assert "one of --jobs and --scheduler" in capsys.readouterr().err


def _task_lines(out: str, folder: Path) -> list[str]:
    """The per-task progress lines without their [k/n] (tasks finish in any order) and output folder."""
    return sorted(line.split("] ", 1)[1].replace(str(folder), "OUT") for line in out.splitlines()
                  if line.startswith("["))


def test_local_workers_reads_local_n_only():
    assert local_workers("local:3") == 3 and local_workers("tcp://h:8786") is None
    with pytest.raises(InvalidParameterError):
        local_workers("local:-1")
    with pytest.raises(InvalidParameterError, match="at most 256"):
        local_workers("local:1000")  # refused before a single process starts
    assert issubclass(InvalidParameterError, UsvipsError)
