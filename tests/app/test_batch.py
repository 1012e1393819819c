"""usvips/app/batch.py: tasks are picklable functions of paths; a pool runs them, keeps going past a
failing one and reports each in one line."""

import pickle
import shutil
from pathlib import Path

import pytest

from usvips.app import batch
from usvips.cli import main

ROV = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport"


def _pairs(tmp_path: Path, count: int) -> list[Path]:
    files = []
    for k in range(count):
        target = tmp_path / f"pair{k}.csv"
        shutil.copy(ROV / "observations_water.csv", target)
        files.append(target)
    return files


def test_intersect_task_writes_what_usvips_intersect_writes(tmp_path):
    (obs,) = _pairs(tmp_path, 1)
    assert main(["intersect", "--calibration", str(ROV / "calibration.json"), "--obs", str(obs), "--out",
                 str(tmp_path / "cli.csv"), "--skip-failed"]) == 0
    summary = batch.intersect_task(str(obs), str(ROV / "calibration.json"), str(tmp_path / "task.csv"))
    assert (tmp_path / "task.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    assert summary["points"] == len((tmp_path / "task.csv").read_text().splitlines()) - 1 > 10


def test_tasks_pickle_so_any_executor_can_run_them(tmp_path):
    task = batch.Task("p", batch.intersect_task, {"observations": "a.csv", "calibration": "c.json", "out": "o.csv"})
    again = pickle.loads(pickle.dumps(task))
    assert again.function is batch.intersect_task and again.arguments == task.arguments


def test_a_failing_task_is_one_line_and_the_others_are_done(tmp_path):
    files = _pairs(tmp_path, 3)
    broken = tmp_path / "broken.csv"
    broken.write_text("id,xl,yl,xr,yr\n1,2,3,four,5\n")
    inputs = [files[0], broken, files[1], tmp_path / "missing.csv", files[2]]
    calibration = str(ROV / "calibration.json")
    tasks = [batch.Task(p.name, batch.intersect_task, {"observations": str(p), "calibration": calibration,
                                                      "out": str(tmp_path / f"{p.stem}.points.csv")}) for p in inputs]
    seen = []
    outcomes = batch.run(tasks, jobs=2, progress=lambda o, done, total: seen.append((done, total)))
    assert [o.task.label for o in outcomes] == [p.name for p in inputs]  # in the tasks' order
    assert [o.status for o in outcomes] == ["ok", "failed", "ok", "failed", "ok"]
    assert sorted(seen) == [(k, 5) for k in range(1, 6)]
    for outcome in outcomes:
        if not outcome.ok:
            assert "\n" not in outcome.message and outcome.task.label in outcome.message
        else:
            assert Path(outcome.summary["out"]).is_file()
    assert "four" in outcomes[1].message  # names the field that is wrong
    assert not (tmp_path / "broken.points.csv").exists()  # nothing half-written


def test_jobs_must_be_positive():
    with pytest.raises(batch.InvalidParameterError, match="parallel jobs: must be at least 1"):
        batch.run([batch.Task("x", batch.intersect_task)], jobs=0)
