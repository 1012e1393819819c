"""The bench runner: every area is found without being registered by hand, runs in a process of its own,
and an area that fails names itself in its row while the others still report (the command then exits 1)."""

import json
import os

import pytest

from usvips import bench
from usvips.cli import main

FINE = '''
def benchmarks(scale=1.0):
    yield {"name": "fine row", "n": int(100 * scale), "ours_s": 0.1, "baseline": "x", "baseline_s": 0.2,
           "ratio": 0.5, "target": 1.0, "met": True}
'''
BROKEN = '''
def benchmarks(scale=1.0):
    yield {"name": "made before the failure", "n": 1, "ours_s": 0.1, "baseline": "x", "baseline_s": 0.1,
           "ratio": 1.0, "target": 2.0, "met": True}
    raise RuntimeError("there is no object 2501 in the project")
'''
CRASHING = '''
import os
def benchmarks(scale=1.0):
    os.abort()
    yield {}
'''
HANGING = '''
import time
def benchmarks(scale=1.0):
    time.sleep(60)
    yield {}
'''


@pytest.fixture
def fake_areas(tmp_path, monkeypatch):
    """Areas ``fine``, ``broken``, ``crashing`` and ``hanging`` as modules the child processes import."""
    folder = tmp_path / "fake_areas"
    folder.mkdir()
    names = {"fine": FINE, "broken": BROKEN, "crashing": CRASHING, "hanging": HANGING}
    for name, source in names.items():
        (folder / f"area_{name}.py").write_text(source)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(folder), os.environ.get("PYTHONPATH")])))
    monkeypatch.setattr(bench, "areas", lambda: {name: f"area_{name}" for name in names})


def test_every_area_of_the_package_and_of_the_window_is_found_without_registration():
    found = bench.areas()
    assert list(found)[: len(bench.BENCH_MODULES)] == list(bench.BENCH_MODULES)
    assert found["gui"] == "usvips.gui.qt.bench" and found["window_tracking"] == "usvips.gui.qt.bench_tracking"
    assert found["scaling"] == "usvips.bench.scaling"
    # modules that hold no benchmarks are no areas: shared scenes, the child process itself
    assert "board_views" not in found and "area_process" not in found
    for name, module in found.items():
        assert module.startswith(("usvips.bench.", "usvips.gui.qt.bench")), name


def test_a_module_added_to_the_package_is_an_area(tmp_path, monkeypatch):
    (tmp_path / "newly_added.py").write_text(FINE)
    (tmp_path / "helper_scenes.py").write_text("def scene():\n    return 1\n")
    monkeypatch.setattr(bench, "_package_folder", lambda package: tmp_path if package == bench.__name__ else None)
    found = bench.areas()
    assert found["newly_added"] == "usvips.bench.newly_added" and "helper_scenes" not in found


def test_a_failing_area_names_itself_and_the_others_still_report(fake_areas):
    runs = bench.run_areas(["broken", "fine", "crashing"], scale=0.5)
    broken, fine, crashing = runs
    assert [row["name"] for row in broken.rows] == ["made before the failure", "area broken failed"]
    assert broken.error.startswith("RuntimeError: there is no object 2501 in the project (at area_broken.py:")
    assert broken.rows[-1]["met"] is False and broken.rows[-1]["area"] == "broken"
    assert fine.error is None and fine.rows == [{"name": "fine row", "n": 50, "ours_s": 0.1, "baseline": "x",
                                                  "baseline_s": 0.2, "ratio": 0.5, "target": 1.0, "met": True,
                                                  "area": "fine"}]
    assert fine.peak_rss_mb > 0 and fine.cpu_s > 0 and fine.summary()["rows"] == 1
    assert crashing.error.startswith("its process exited with -6")  # killed by a signal: still named


def test_an_area_that_hangs_is_stopped_and_named(fake_areas):
    (hanging,) = bench.run_areas(["hanging"], timeout_s=2)
    assert hanging.error == "stopped after 2 s" and hanging.rows[-1]["area"] == "hanging"


def test_the_command_prints_every_row_and_exits_1_when_an_area_failed(fake_areas, capsys):
    assert main(["bench", "--only", "fine", "broken", "--scale", "0.1"]) == 1
    out, err = capsys.readouterr()
    report = json.loads(out)
    assert [row["area"] for row in report["results"]] == ["fine", "broken", "broken"]
    assert [area["error"] is None for area in report["areas"]] == [True, False]
    assert report["scale"] == 0.1 and "load_1min_at_start" in report
    assert err.strip().splitlines()[-1] == ("usvips bench: area broken failed: RuntimeError: there is no object "
                                            "2501 in the project (at area_broken.py:5)")
    assert err.splitlines()[0] == "usvips bench: area fine: 1 rows in 0 s"  # progress, area by area
    assert main(["bench", "--only", "fine"]) == 0
    assert main(["bench", "--only", "nowhere"]) == 2


def test_the_report_file_is_written_after_each_area(fake_areas, tmp_path, capsys):
    out = tmp_path / "report.json"
    assert main(["bench", "--only", "broken", "fine", "--scale", "0.1", "--out", str(out)]) == 1
    written, printed = json.loads(out.read_text()), json.loads(capsys.readouterr().out)
    assert written["results"] == printed["results"] and written["areas"] == printed["areas"]
