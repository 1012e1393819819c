import json

from tests.core.calibration_scenes import FLAT, control_frame, observe, rig_at
from usvips.cli import main
from usvips.io.tables import write_control, write_observations


def test_demo_runs_a_project_from_its_manifest(tmp_path, capsys):
    control = control_frame()
    write_control(tmp_path / "control.csv", control)
    write_observations(tmp_path / "air.csv", observe(rig_at(0), control.xyz, control.ids, "a", seed=1).observations)
    water = observe(rig_at(0, FLAT), control.xyz, control.ids, "w", seed=2).observations
    write_observations(tmp_path / "water.csv", water.take(range(0, len(water), 2)))
    write_observations(tmp_path / "check.csv", water.take(range(1, len(water), 2)))
    manifest = {"format": "usvips-sample", "version": 1, "name": "synthetic", "description": "flat ports",
                "control": "control.csv", "housing": "flat-port",
                "pairs": [{"label": "a", "medium": "air"}, {"label": "w", "medium": "water"}],
                "observations": [{"file": "air.csv", "role": "calibration-air", "pairs": ["a"]},
                                 {"file": "water.csv", "role": "calibration-water", "pairs": ["w"]},
                                 {"file": "check.csv", "role": "check", "pairs": ["w"]}]}
    (tmp_path / "project.json").write_text(json.dumps(manifest))
    assert main(["demo", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "phase 1 (in air" in out and "phase 2 (flat-port" in out
    rms = [float(v) for v in out.strip().splitlines()[-1].split()[1:]]
    assert len(rms) == 3 and max(rms) < 1.0  # centimetres, at 2-3 m with a 0.4 m base and 0.3 px noise


def test_demo_refuses_a_project_without_control(tmp_path, capsys):
    (tmp_path / "project.json").write_text(json.dumps({"format": "usvips-sample", "version": 1, "name": "x"}))
    assert main(["demo", str(tmp_path)]) == 2
    assert "no control file" in capsys.readouterr().err
