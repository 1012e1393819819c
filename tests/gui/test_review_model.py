"""Review mode's model without Qt: the queue's order, moving, accepting, flagging, skipping, progress, and
reviews refused when someone else changed the object, against a real project file."""

from __future__ import annotations

import numpy as np
import pytest

from usvips.core.errors import UsvipsError
from usvips.gui.review_model import ReviewModel, progress_text, queue_key
from usvips.store import Project
from usvips.store.records import StaleEditError, Vertex


def _survey(path, rng, count: int) -> tuple[Project, list[int]]:
    """A project of ``count`` points, each on a random video frame or image pair, added in random order."""
    project = Project.create(path)
    project.annotator = "measurer"
    for label in ("pA", "pB"):
        project.add_pair(label)
    video = path.parent / "v.mp4"
    video.write_bytes(b"v")
    project.add_video("dive", [(video, 500, 20.0)], [(video, 500, 20.0)], 25.0, 500, (64, 48))
    ids = []
    for _ in range(count):
        if rng.random() < 0.5:
            frame = int(rng.integers(0, 500))
            vertex = Vertex(1.0, 2.0, 3.0, 4.0, None, None, None, None, "dive", frame, frame, frame / 25.0)
        else:
            vertex = Vertex(1.0, 2.0, 3.0, 4.0, pair=str(rng.choice(["pA", "pB"])))
        ids.append(project.add_object("point", [vertex], "cod"))
    return project, ids


@pytest.mark.parametrize("seed", range(5))
def test_a_random_walk_of_the_queue_keeps_its_order_and_stores_every_review(tmp_path, seed):
    """Random key presses (next, previous, accept, flag, skip) over a queue of random objects, some already
    reviewed: the queue is the unreviewed ones in (video or pair, frame, id) order; after every press the
    store holds exactly the reviews made, by the annotator, and the progress counts them."""
    rng = np.random.default_rng(seed)
    project, ids = _survey(tmp_path / "s.usvips", rng, int(rng.integers(5, 15)))
    done_before = {int(i) for i in rng.choice(ids, 2, replace=False)}
    for object_id in done_before:
        project.set_review(object_id, "accepted")
    project.annotator = "reader"
    model = ReviewModel()
    events = []
    model.changed.connect(lambda: events.append("changed"))
    model.reviewed.connect(lambda object_id, review: events.append((object_id, review.state)))
    model.load(project)
    objects = {o.id: o for o in project.objects()}
    assert model.queue == sorted((i for i in ids if i not in done_before), key=lambda i: queue_key(objects[i]))
    assert model.current == model.queue[0] and model.progress() == f"0 of {len(model.queue)} reviewed"
    want = {}
    for press in rng.choice(["next", "previous", "accept", "flag", "skip"], 40):
        before = model.current
        if press == "accept":
            model.accept()
            want[before] = ("accepted", "")
        elif press == "flag":
            model.flag(f"reason for {before}")
            want[before] = ("flagged", f"reason for {before}")
        else:
            getattr(model, press)()
        if press in ("accept", "flag"):
            assert events[-2] == (before, want[before][0]) or events[-1] == (before, want[before][0])
            unreviewed = [i for i in model.queue if i not in want]
            if unreviewed:  # on to an unreviewed object
                assert model.current in unreviewed
            else:
                assert model.finished and model.current == before
        elif press == "next":
            assert model.queue.index(model.current) == min(model.queue.index(before) + 1, len(model.queue) - 1)
        elif press == "previous":
            assert model.queue.index(model.current) == max(model.queue.index(before) - 1, 0)
        stored = {r.object_id: (r.state, r.reason) for r in project.reviews() if r.state != "unreviewed"}
        assert stored == {**{i: ("accepted", "") for i in done_before}, **want}
        assert all(project.review(i).reviewer == "reader" for i in want)
        flagged = sum(s == "flagged" for s, _ in want.values())
        assert model.progress() == progress_text(len(want), len(model.queue), flagged)
    project.close()


def test_a_review_of_an_object_changed_by_someone_else_is_refused_and_the_object_read_again(tmp_path):
    rng = np.random.default_rng(1)
    project, ids = _survey(tmp_path / "s.usvips", rng, 3)
    model = ReviewModel()
    model.load(project)
    first = model.current
    with Project.open(tmp_path / "s.usvips") as other:  # another annotator flags it meanwhile
        other.annotator = "other reader"
        other.set_review(first, "flagged", "two fish")
    with pytest.raises(StaleEditError, match=f"object {first}"):
        model.accept()
    assert model.current == first and model.state(first).state == "flagged"  # what they did, shown
    assert model.accept().state == "accepted"  # seen, and reviewed again: kept
    assert project.review(first).state == "accepted" and model.current != first
    project.close()


def test_bad_reviews_objects_added_and_deleted_and_an_empty_queue(tmp_path):
    rng = np.random.default_rng(2)
    project, ids = _survey(tmp_path / "s.usvips", rng, 4)
    model = ReviewModel()
    model.load(project)
    with pytest.raises(UsvipsError, match="a flag needs a reason"):
        model.flag("  ")
    assert project.history()[-1].change == "add"
    order = list(model.queue)
    model.next()
    model.next()
    third = model.current
    model.forget([order[0]])  # deleted in the window: the current object stays current
    assert model.current == third and order[0] not in model.queue
    model.forget([third])  # the current one deleted: the next takes its place
    assert model.current == order[3]
    new = project.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0, pair="pA")])
    model.add([project.object(new)])
    assert model.queue[-1] == new and model.progress() == "0 of 3 reviewed"
    model.load(None)
    assert model.current is None and model.progress().startswith("nothing to review")
    with pytest.raises(UsvipsError, match="queue is empty"):
        model.accept()
    project.close()


def test_a_review_after_an_edit_in_the_window_or_a_reload_from_an_older_cache_is_not_stale(tmp_path):
    """The window's own changes are not someone else's: an object edited in the window (its new version
    handed over), or a queue loaded again from a cache older than the reviews made here, reviews as is."""
    rng = np.random.default_rng(3)
    project, ids = _survey(tmp_path / "s.usvips", rng, 3)
    cache = project.objects()  # the window's cache, read once
    model = ReviewModel()
    model.load(project, cache)
    first = model.current
    project.update_object(first, notes="edited in the window")
    model.updated([project.object(first)])
    assert model.accept().state == "accepted"
    model.go_to(first)
    assert model.unreview().state == "unreviewed" and model.current == first  # a review made by mistake
    model.load(project, cache)  # the cache still holds the versions from before the edit and the reviews
    assert first in model.queue and model.current == first
    assert model.flag("looked again").state == "flagged"
    assert [e.change for e in project.history(first)] == ["add", "edit", "review", "review", "review"]
    project.close()


def test_reviews_read_again_show_others_reviews_and_an_edited_acceptance_rejoins_the_queue(tmp_path):
    """Reading the reviews again (of one object: one query; of several: one read of all) shows what another
    annotator did; an object accepted before the queue was loaded and then edited (unreviewed again) joins
    the queue's end; an id not in the queue's survey is left out."""
    rng = np.random.default_rng(12)
    project, ids = _survey(tmp_path / "s.usvips", rng, 5)
    done = ids[0]
    project.set_review(done, "accepted")
    model = ReviewModel()
    model.load(project)
    assert done not in model.queue and model.progress() == "0 of 4 reviewed"
    # the whole survey counted beside the queue: the object accepted before it was loaded too
    assert model.survey_progress(ids) == "survey: 1 of 5 reviewed" and model.survey_counts(ids) == (1, 5, 0)
    assert model.survey_progress(model.queue) == ""  # the queue is the survey: its own count says it
    events = []
    model.changed.connect(lambda: events.append("changed"))
    with Project.open(project.path) as other:
        other.annotator = "someone else"
        other.set_review(model.queue[1], "flagged", "two fish")
        other.update_object(done, attribute="ling")  # its acceptance is undone by the edit
    assert model.reread([model.queue[1]]) == [model.queue[1]]
    assert (model.state(model.queue[1]).state, model.state(model.queue[1]).reviewer) == ("flagged", "someone else")
    assert events == ["changed"] and model.progress() == "1 of 4 reviewed, 1 flagged"
    assert model.reread([done, ids[1], 999]) == [done] and model.queue[-1] == done
    assert model.progress() == "1 of 5 reviewed, 1 flagged"
    assert model.reread([done]) == [] and events == ["changed", "changed"]  # nothing new: no event
    project.close()


def test_every_move_reads_the_new_objects_review_again_by_one_query_and_a_stale_review_is_still_refused(tmp_path):
    """Another annotator reviews objects of the queue while it is walked: each move (next, previous, skip, go
    to) and ``refresh_current`` shows the review as stored, by ONE SQL statement, announced by ``read``;
    the reader's own review of such an object is refused by name once (their version is old), then kept."""
    rng = np.random.default_rng(13)
    project, ids = _survey(tmp_path / "s.usvips", rng, 6)
    model = ReviewModel()
    model.load(project)
    read = []
    model.read.connect(lambda object_id, review: read.append((object_id, review.state, review.reviewer)))
    statements = []
    project._db.raw.set_trace_callback(statements.append)
    queue = list(model.queue)
    with Project.open(project.path) as other:
        other.annotator = "bob"
        for step, move in enumerate([model.next, model.next, model.previous, lambda: model.go_to(queue[4]),
                                     model.skip, model.refresh_current]):
            target = {0: queue[1], 1: queue[2], 2: queue[1], 3: queue[4], 4: queue[5], 5: queue[5]}[step]
            state = ("accepted", "flagged")[step % 2]
            other.set_review(target, state, f"seen {step}")  # each a change (the same again would be none)
            statements.clear()
            move()
            assert model.current == target and len(statements) == 1, statements
            assert model.state(target).state == state and model.state(target).reviewer == "bob"
            assert read[-1] == (target, state, "bob")
        statements.clear()
        assert model.refresh_current() is False and len(statements) == 1  # nothing new: no event
        assert len(read) == 6
        with pytest.raises(StaleEditError, match=f"object {queue[5]} was changed by someone else"):
            model.accept()
        assert project.review(queue[5]).reviewer == "bob"
        model.go_to(queue[5])
        assert model.accept().reviewer == "measurer"  # looked at again: kept
    project._db.raw.set_trace_callback(None)
    project.close()


def test_a_review_after_an_edit_undone_in_the_window_is_not_stale(tmp_path):
    """An edit undone in the window puts the object's rows back as they were, its older version stamp too
    (``put_back``): the version handed over then is the object as stored, and a review of it is made, not
    refused as if someone else had changed it."""
    rng = np.random.default_rng(5)
    project, ids = _survey(tmp_path / "s.usvips", rng, 3)
    model = ReviewModel()
    model.load(project, project.objects())
    first = model.current
    before = project.object_rows(first)  # what the window's undo keeps
    project.update_object(first, attribute="ling")
    model.updated([project.object(first)])
    project.put_back(before, replace=True)  # Ctrl+Z
    model.updated([project.object(first)])
    assert model.accept().state == "accepted"
    assert project.review(first).state == "accepted"
    project.close()
