"""``usvips plan``: a map and JSON for a calibration or a rig on paper; bad input on one line."""

import json
from pathlib import Path

import numpy as np
import pytest

from usvips.cli import main
from usvips.core.planner import planned_rig, precision_map

SAMPLES = Path(__file__).resolve().parents[2] / "sample_projects"


def test_plan_a_calibration_writes_the_map(tmp_path, capsys):
    out = tmp_path / "plan.png"
    assert main(["plan", "--calibration", str(SAMPLES / "rov_flatport" / "calibration.json"), "--range", "1:3:3",
                 "--across=-0.4:0.4:3", "--orientations", "4", "--out", str(out)]) == 0
    assert out.read_bytes().startswith(b"\x89PNG")
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("range 1.00 m: 0.3 m length sigma") and lines[-1] == f"wrote {out}"


def test_plan_a_rig_on_paper_as_json_matches_the_planner(capsys):
    assert main(["plan", "--focal-px", "1400", "--image-size", "1920x1080", "--baseline", "0.7", "--toe-in", "4",
                 "--housing", "flat-port", "--port", "g=0.04", "--sigma-px", "0.4", "--range", "1:3:3",
                 "--across=-0.5:0.5:3", "--orientations", "6", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert [row["range_m"] for row in summary["ranges"]] == [1.0, 2.0, 3.0] and not summary["with_calibration"]
    from usvips.core.housing import FlatPortHousing

    rig = planned_rig(1400, 1920, 1080, 0.7, np.radians(4), FlatPortHousing(0, 0, 0.04, 0.01, 1.5, 1.34), 0.4)
    plan = precision_map(rig, np.linspace(-0.5, 0.5, 3), np.array([1.0, 2.0, 3.0]), 0.3, orientations=6)
    assert summary == json.loads(json.dumps(plan.summary()))


@pytest.mark.parametrize("arguments, message", [
    (["--focal-px", "1400", "--image-size", "1920x1080", "--json"], "--baseline"),
    (["--focal-px", "1400", "--image-size", "1920x1080", "--baseline", "0.7", "--range", "0.02:0.04:2", "--json"],
     "range 0.02 m: no position"),
    (["--focal-px", "1400", "--image-size", "1920x1080", "--baseline", "0.7", "--range", "1-3", "--json"],
     "FROM:TO"),
    (["--focal-px", "1400", "--image-size", "1920x1080", "--baseline", "0.7", "--housing", "flat-port",
      "--port", "q=1", "--json"], "unknown 'q'"),
    (["--focal-px", "1400", "--image-size", "1920x1080", "--baseline", "0.7"], "--out PICTURE"),
])
def test_bad_input_is_one_line(capsys, arguments, message):
    assert main(["plan", *arguments]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
