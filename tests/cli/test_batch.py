"""usvips batch: one task over many projects or pairs on every core, a line per task, exit status."""

import os
import shutil
import signal
import sys
import time
from pathlib import Path

import pytest

from usvips.cli import main

ROV = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport"


def _project_with_objects(tmp_path: Path, name: str) -> Path:
    """A project made from the rov_flatport sample with two fish measured from their true pixels."""
    import json

    from usvips.app.samples import open_or_create_from_manifest

    sample = tmp_path / name
    shutil.copytree(ROV, sample, ignore=shutil.ignore_patterns("project.usvips*"))
    open_or_create_from_manifest(sample).close()
    truth = json.loads((sample / "truth.json").read_text())
    cameras = next(p for p in truth["pairs"] if p["label"] == "measure1")["cameras"]
    left, right = cameras["left"]["objects"], cameras["right"]["objects"]
    rows = ["object,type,vertex,xl,yl,xr,yr,attribute"]
    for fish in ("fish1", "fish2"):
        for v, point in enumerate(("snout", "fork")):
            rows.append(f"{fish},length,{v},{left[fish][point][0]},{left[fish][point][1]},{right[fish][point][0]},"
                        f"{right[fish][point][1]},{fish}")
    (sample / "picks.csv").write_text("\n".join(rows) + "\n")
    project = sample / "project.usvips"
    assert main(["measure", "--picks", str(sample / "picks.csv"), "--project", str(project), "--pair", "measure1",
                 "--out", str(sample / "measured.csv")]) == 0
    renamed = sample / f"{name}.usvips"
    project.rename(renamed)
    return renamed


def test_batch_export_recomputes_every_project_and_names_the_one_that_fails(tmp_path, capsys):
    projects = [_project_with_objects(tmp_path, name) for name in ("reef_a", "reef_b")]
    broken = tmp_path / "broken.usvips"
    broken.write_text("not a project\n")
    capsys.readouterr()
    code = main(["batch", "export", str(projects[0]), str(broken), str(projects[1]), "--out-dir",
                 str(tmp_path / "out"), "--jobs", "2"])
    captured = capsys.readouterr()
    assert code == 2
    lines = [line for line in captured.out.splitlines() if line.startswith("[")]
    assert len(lines) == 3
    failing = [line for line in lines if "FAILED" in line]
    assert len(failing) == 1 and str(broken) in failing[0]
    assert "1 failed" in captured.err
    for project in projects:
        assert main(["project", "export", str(project), str(tmp_path / f"{project.stem}.csv")]) == 0
        ours = (tmp_path / "out" / f"{project.stem}.csv").read_text()
        assert ours == (tmp_path / f"{project.stem}.csv").read_text()
        assert len(ours.splitlines()) == 3  # header and the two fish
    assert not (tmp_path / "out" / "broken.csv").exists()


def test_batch_intersect_all_succeed_exit_zero(tmp_path, capsys):
    for k in range(3):
        shutil.copy(ROV / "observations_water.csv", tmp_path / f"dive{k}.csv")
    code = main(["batch", "intersect", *(str(tmp_path / f"dive{k}.csv") for k in range(3)), "--calibration",
                 str(ROV / "calibration.json"), "--out-dir", str(tmp_path / "points")])
    out = capsys.readouterr().out
    assert code == 0 and "3 of 3 succeeded" in out
    assert sorted(p.name for p in (tmp_path / "points").iterdir()) == [f"dive{k}.points.csv" for k in range(3)]


def test_bad_invocations_are_one_line(tmp_path, capsys):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    for folder in ("a", "b"):
        shutil.copy(ROV / "observations_water.csv", tmp_path / folder / "dive.csv")
    code = main(["batch", "intersect", str(tmp_path / "a" / "dive.csv"), str(tmp_path / "a" / ".." / "a" / "dive.csv"),
                 "--calibration", str(ROV / "calibration.json"), "--out-dir", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "given twice" in err
    assert not (tmp_path / "out").exists()
    code = main(["batch", "intersect", str(tmp_path / "a" / "dive.csv"), "--calibration", "c.json", "--out-dir",
                 str(tmp_path / "out"), "--jobs", "0"])
    assert code == 2 and "--jobs" in capsys.readouterr().err


@pytest.fixture
def ctrl_c_raises():
    """Ctrl-C raises KeyboardInterrupt here whatever this process inherited: a shell starts a background
    job (`pytest … &`) with SIGINT ignored, and Python then keeps it ignored, so the test's Ctrl-C would be
    lost and its worker would wait at the gate for its bound, task after task."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_ctrl_c_cancels_what_has_not_started_and_keeps_whole_outputs(tmp_path, monkeypatch, capsys, ctrl_c_raises):
    """A real SIGINT, sent as the first task's line is printed, while the one worker is held at a gate
    after its first task (events, not a wall-clock race): at most three more tasks can have been handed
    to it (the one it waits in and the pool's call queue of two, no longer cancellable), so every other
    one is cancelled; the gate opens once the last task is reported cancelled, and the handed ones then
    finish, whole."""
    from usvips.app import batch

    inputs = []
    for k in range(16):
        shutil.copy(ROV / "observations_water.csv", tmp_path / f"dive{k:02d}.csv")
        inputs.append(str(tmp_path / f"dive{k:02d}.csv"))
    gate = tmp_path / "gate"
    original = batch._execute

    def gated(function, arguments):
        if not arguments["observations"].endswith("dive00.csv"):
            waited = time.monotonic()
            while not gate.exists() and time.monotonic() - waited < 120:  # the test's event (a bound, not a hang)
                time.sleep(0.005)
        return original(function, arguments)

    # the pool forks its worker from this process and finds the function by its module and name
    gated.__module__, gated.__qualname__ = original.__module__, original.__qualname__
    monkeypatch.setattr(batch, "_execute", gated)
    printed: list[str] = []

    class InterruptOnFirstLine:
        def write(self, text: str) -> int:
            printed.append(text)
            if text.startswith("[1/16]"):
                os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C, delivered as this line is printed
            if " cancelled " in text and "dive15" in text:  # every cancellable task has been cancelled
                gate.touch()
            return len(text)

        def flush(self) -> None:
            pass

    monkeypatch.setattr(sys, "stdout", InterruptOnFirstLine())
    code = main(["batch", "intersect", *inputs, "--calibration", str(ROV / "calibration.json"),
                 "--out-dir", str(tmp_path / "out"), "--jobs", "1"])
    monkeypatch.undo()
    err = capsys.readouterr().err
    assert code == 130
    assert "Traceback" not in err and "cancelled (interrupted)" in err
    lines = "".join(printed).splitlines()
    assert lines[0].startswith("[1/16] ok")
    done = [line for line in lines if " ok " in line]
    cancelled = [line for line in lines if " cancelled " in line]
    assert len(done) + len(cancelled) == 16 and 1 <= len(done) <= 4
    written = sorted((tmp_path / "out").iterdir())
    assert len(written) == len(done)  # the finished ones, whole; no temporary or partial files
    reference = written[0].read_text()
    assert all(path.read_text() == reference for path in written)


def test_inputs_of_one_name_in_different_folders_are_named_by_their_folders(tmp_path, capsys):
    """The samples' own layout (``a/project.usvips``, ``b/project.usvips``; here observations): each output
    is named by as much of its folder as tells it apart."""
    for folder in ("a", "b", "c/a"):
        (tmp_path / folder).mkdir(parents=True)
        shutil.copy(ROV / "observations_water.csv", tmp_path / folder / "dive.csv")
    inputs = [str(tmp_path / folder / "dive.csv") for folder in ("a", "b", "c/a")]
    code = main(["batch", "intersect", *inputs, "--calibration", str(ROV / "calibration.json"), "--out-dir",
                 str(tmp_path / "out"), "--jobs", "1"])
    assert code == 0 and "3 of 3 succeeded" in capsys.readouterr().out
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert len(names) == 3 and "b_dive.points.csv" in names
    assert all(name.endswith("a_dive.points.csv") for name in names if name != "b_dive.points.csv")


def test_batch_intersect_counts_points_whose_rays_miss(tmp_path, capsys):
    """A right pick moved 30 px across the epipolar curve in one file: that file's line counts the point as
    `usvips intersect` does; the clean file's line does not."""
    lines = (ROV / "observations_water.csv").read_text().splitlines()
    (tmp_path / "clean.csv").write_text("\n".join(lines) + "\n")
    fields = lines[5].split(",")
    fields[4] = f"{float(fields[4]) + 30:.4f}"
    lines[5] = ",".join(fields)
    (tmp_path / "moved.csv").write_text("\n".join(lines) + "\n")
    code = main(["batch", "intersect", str(tmp_path / "clean.csv"), str(tmp_path / "moved.csv"), "--calibration",
                 str(ROV / "calibration.json"), "--out-dir", str(tmp_path / "points")])
    out = capsys.readouterr().out
    assert code == 0
    moved = [line for line in out.splitlines() if "moved.csv" in line]
    clean = [line for line in out.splitlines() if "clean.csv" in line]
    assert moved and "1 whose rays miss beyond the pointing sigma" in moved[0]
    assert clean and "miss" not in " ".join(clean)
