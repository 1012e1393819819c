"""The data that ships with USVIPS is found through the package (importlib.resources), not the checkout."""

from pathlib import Path

from usvips.locations import resources_folder, sample_project, sample_projects


def test_the_samples_and_resources_are_reached_through_the_package():
    top = Path(__file__).resolve().parents[1]
    assert sample_projects().resolve() == (top / "sample_projects").resolve()
    assert {p.parent.name for p in sample_projects().glob("*/project.json")} >= {"tank_1995", "rov_flatport",
                                                                                   "tank_system1"}
    assert (sample_project("tank_1995") / "control_table3_1.csv").is_file()
    assert (resources_folder() / "calibration_frame.csv").is_file()
