"""MaxN per species from reviewed objects: only accepted objects with a species count, one individual per
object on its frame, per video or pair; the first frame reaching the maximum is named."""

from tests.app.detection_scenes import add_video
from usvips.app.reviewed_max_n import reviewed_max_n
from usvips.cli import main
from usvips.store import Project
from usvips.store.project import Vertex


def _fish(project, species, frame, video="drop", state="accepted"):
    where = {"pair": video, "video": video, "frame_left": frame, "frame_right": frame, "time_s": frame / 25}
    vertices = [Vertex(10.0 + frame, 20.0, 5.0, 20.0, **where), Vertex(60.0 + frame, 25.0, 50.0, 25.0, **where)]
    object_id = project.add_object("length", vertices, species)
    if state != "unreviewed":
        project.set_review(object_id, state, "" if state == "accepted" else "not a fish")
    return object_id


def test_max_n_counts_accepted_objects_of_a_species_on_one_frame(tmp_path, capsys):
    path = tmp_path / "p.usvips"
    with Project.create(path) as project:
        add_video(tmp_path, project, "drop", frames=14, size=(64, 48))
        for frame, species in ((5, "Pagrus auratus"), (5, "Pagrus auratus"), (9, "Pagrus auratus"),
                               (9, "Pagrus auratus"), (9, "Pagrus auratus"), (9, "Coris julis"), (12, "Coris julis"),
                               (12, "Coris julis")):
            _fish(project, species, frame)
        _fish(project, "Coris julis", 12, state="unreviewed")  # a proposal not yet checked: not counted
        _fish(project, "Coris julis", 12, state="flagged")
        _fish(project, "", 9)                                    # no species: not counted
        found = reviewed_max_n(project)
    assert [(r.species, r.max_n, r.frame, r.objects) for r in found] == [("Coris julis", 2, 12, 3),
                                                                         ("Pagrus auratus", 3, 9, 5)]
    assert main(["detect", str(path), "--max-n"]) == 0
    out = capsys.readouterr().out
    assert "drop Pagrus auratus: MaxN 3 at frame 9 (from 5 accepted objects)" in out
    assert "MaxN of 2 species" in out
