"""usvips measure: fish of known length, measured from noisy picks with a calibration from noisy data."""

import csv

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, NOISE_PX, control_frame, observe, rig_at
from usvips.cli import main
from usvips.cli.measure import read_picks
from usvips.core.errors import InputFileError
from usvips.io.tables import write_control, write_observations


def test_fish_lengths_are_within_their_sigmas(tmp_path, capsys):
    control = control_frame()
    write_control(tmp_path / "c.csv", control)
    write_observations(tmp_path / "air.csv", observe(rig_at(0), control.xyz, control.ids, "1", seed=1).observations)
    write_observations(tmp_path / "w.csv", observe(rig_at(0, FLAT), control.xyz, control.ids, "1", seed=2).observations)
    assert main(["calibrate", "air", "--control", str(tmp_path / "c.csv"), "--obs", str(tmp_path / "air.csv"),
                 "--out", str(tmp_path / "air.json"), "--sigma-px", str(NOISE_PX)]) == 0
    assert main(["calibrate", "water", "--base", str(tmp_path / "air.json"), "--housing", "flat-port",
                 "--control", str(tmp_path / "c.csv"), "--obs", str(tmp_path / "w.csv"), "--out",
                 str(tmp_path / "w.json"), "--fix", "t=0.016", "n2=1.65", "--sigma-px", str(NOISE_PX)]) == 0
    rng = np.random.default_rng(7)
    rig = rig_at(0, FLAT)
    lengths, rows = {}, ["object,type,vertex,xl,yl,xr,yr,attribute"]
    for k in range(30):
        snout = np.array([rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.2), rng.uniform(-0.6, -0.1)])
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        length = rng.uniform(0.2, 0.5)
        ends = np.array([snout, snout + length * direction])
        pl, pr = rig.left.project(ends), rig.right.project(ends)
        if not (pl.ok.all() and pr.ok.all()):
            continue
        lengths[f"fish{k}"] = length
        for v in range(2):
            xl, yl = pl.pixels[v] + rng.normal(0, NOISE_PX, 2)
            xr, yr = pr.pixels[v] + rng.normal(0, NOISE_PX, 2)
            rows.append(f"fish{k},line,{v},{xl},{yl},{xr},{yr},cod")
    (tmp_path / "picks.csv").write_text("\n".join(rows) + "\n")
    assert main(["measure", "--calibration", str(tmp_path / "w.json"), "--picks", str(tmp_path / "picks.csv"),
                 "--out", str(tmp_path / "fish.csv")]) == 0
    measured = list(csv.DictReader((tmp_path / "fish.csv").open()))
    assert len(measured) == len(lengths) > 20
    normalised = np.array([(float(m["value"]) - lengths[m["object"]]) / float(m["sigma"]) for m in measured])
    assert np.all(np.abs(normalised) < 3.5)
    assert 0.4 < np.mean(normalised**2) < 1.8


def test_bad_picks_are_one_line_errors(tmp_path, capsys):
    (tmp_path / "p.csv").write_text("object,type,vertex,xl,yl,xr,yr\nf,line,0,1,2,3,\n")
    (tmp_path / "cal.json").write_text("{}")
    assert main(["measure", "--calibration", str(tmp_path / "cal.json"), "--picks", str(tmp_path / "p.csv"),
                 "--out", str(tmp_path / "o.csv")]) == 2
    assert "not a USVIPS calibration file" in capsys.readouterr().err
    with pytest.raises(InputFileError, match="line 2: vertex and pixel columns must be numbers"):
        read_picks(tmp_path / "p.csv")
    (tmp_path / "q.csv").write_text("object,type,vertex,xl,yl,xr,yr\nf,circle,0,1,2,3,4\n")
    with pytest.raises(InputFileError, match="line 2: type 'circle'"):
        read_picks(tmp_path / "q.csv")
    assert not (tmp_path / "o.csv").exists()
