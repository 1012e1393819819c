"""The storage contract: what any implementation of :class:`usvips.store.interface.ProjectStore` must do.

Parametrised over the implementations in ``IMPLEMENTATIONS`` (SQLite's ``Project`` and the PostgreSQL
server's ``ServerProject``, against a real server the suite starts itself; a further backend adds its
opener here and must pass every test unchanged): round trips of pairs, objects, vertices,
calibrations, control, media and videos, vocabularies and records; transactions all or nothing;
read-only refusals that change nothing; two handles on one project.
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from usvips.core.campaign import Campaign
from usvips.core.deployment import Deployment, Georeference
from usvips.core.errors import UsvipsError
from usvips.core.observation_record import ObservationRecord, Species
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.pointing import WeakMatch
from usvips.store import Project, ProjectError
from usvips.store.interface import ProjectStore
from usvips.store.postgres import ServerProject
from usvips.store.project import Vertex
from usvips.store.records import REVIEW_STATES, Review, StaleEditError
from usvips.store.versions import CREATIONS, READS, VERSION_PARAMETERS


@dataclass(frozen=True)
class Implementation:
    """How a test makes and reopens a store: ``create(where)`` a new empty store named by ``where`` (a
    path in the test's folder), ``open(where, read_only)`` another handle on it, and ``snapshot(where)``
    something that changes whenever the stored data change (to prove that nothing was written)."""

    name: str
    create: Callable[[Path], ProjectStore]
    open: Callable[[Path, bool], ProjectStore]
    snapshot: Callable[[Path], str]


def _sqlite_snapshot(path: Path) -> str:
    with Project.open(path, read_only=True) as project:  # the data, not the file's bytes (WAL checkpoints)
        return hashlib.sha256(repr((project.pairs(), [(o.id, o.kind, o.attribute, o.notes) for o in
                                                       project.objects()], project.calibrations(),
                                                      project.vocabulary(), project.videos())).encode()).hexdigest()


def _server_implementation(new_database: Callable[[str], str]) -> Implementation:
    """A survey on the session's PostgreSQL server (tests/store/conftest.py), one new database per store
    the test creates; the store's local name (``path``: messages, media folder) is the test's ``where``.
    A copy (``copy_to`` a file) is an SQLite project file, opened as one."""
    urls: dict[Path, str] = {}

    def create(where: Path) -> ProjectStore:
        urls[where] = new_database("contract")
        return ServerProject.create(urls[where], path=where)

    def open_(where: Path, read_only: bool = False) -> ProjectStore:
        if where in urls:
            return ServerProject.open(urls[where], read_only=read_only, path=where)
        return Project.open(where, read_only=read_only)

    def snapshot(where: Path) -> str:
        with open_(where, True) as project:
            return hashlib.sha256(repr((project.pairs(), [(o.id, o.kind, o.attribute, o.notes) for o in
                                                           project.objects()], project.calibrations(),
                                                          project.vocabulary(), project.videos())).encode()).hexdigest()

    return Implementation("postgresql", create, open_, snapshot)


IMPLEMENTATIONS = [
    Implementation("sqlite", lambda where: Project.create(where),
                   lambda where, read_only=False: Project.open(where, read_only=read_only), _sqlite_snapshot),
    "postgresql",  # made per test by _server_implementation (it needs the session's server)
]


@pytest.fixture(params=IMPLEMENTATIONS, ids=lambda i: i if isinstance(i, str) else i.name)
def impl(request) -> Implementation:
    if request.param == "postgresql":
        return _server_implementation(request.getfixturevalue("new_database"))
    return request.param


@pytest.fixture
def where(tmp_path) -> Path:
    return tmp_path / "contract.usvips"


@pytest.fixture
def store(impl, where):
    project = impl.create(where)
    yield project
    project.close()


def _vertex(rng, pair=None, calibration_id=None) -> Vertex:
    a = rng.normal(size=(3, 3)) * 1e-3
    return Vertex(*map(float, rng.uniform(0, 2000, 4)), tuple(map(float, rng.normal(size=3))), a @ a.T,
                  calibration_id, pair)


def _images(folder: Path, count: int) -> list[tuple[str, Path, Path]]:
    out = []
    for k in range(count):
        left, right = folder / f"p{k}_left.png", folder / f"p{k}_right.png"
        left.write_bytes(b"left image %d" % k)
        right.write_bytes(b"right image %d" % k)
        out.append((f"p{k}", left, right))
    return out


def _assert_same_object(got, want) -> None:
    """Two stored objects hold the same (vertex covariances compared as arrays, bit for bit)."""
    assert (got.id, got.kind, got.attribute, got.notes, got.creator, got.created, got.modified) == (
        want.id, want.kind, want.attribute, want.notes, want.creator, want.created, want.modified)
    assert len(got.vertices) == len(want.vertices)
    for a, b in zip(got.vertices, want.vertices, strict=True):
        assert dataclasses.replace(a, covariance=None) == dataclasses.replace(b, covariance=None)
        assert (a.covariance is None) == (b.covariance is None)
        if a.covariance is not None:
            np.testing.assert_array_equal(a.covariance, b.covariance)


# ------------------------------------------------------------------------------------------ the interface
def test_the_implementation_has_every_operation_of_the_interface_with_its_parameters(store):
    assert isinstance(store, ProjectStore)
    for name, member in vars(ProjectStore).items():
        if name.startswith("_") and name not in ("__enter__", "__exit__") or not callable(member):
            continue
        wanted = list(inspect.signature(member).parameters)
        got = list(inspect.signature(getattr(type(store), name)).parameters)
        assert got == wanted, f"{name}: parameters {got}, the interface says {wanted}"
    assert isinstance(store.version, int) and store.version >= 1
    assert isinstance(store.path, Path) and store.read_only is False


# ------------------------------------------------------------------------------------------ round trips
def test_pairs_round_trip_in_order_and_a_used_label_is_refused(store, where):
    ids = [store.add_pair("a", medium="air"), store.add_pair("b", frame=12, size=(640, 480))]
    pairs = store.pairs()
    assert [p.label for p in pairs] == ["a", "b"] and [p.id for p in pairs] == ids
    assert pairs[0].medium == "air" and pairs[1].medium == "water" and pairs[1].frame == 12
    assert (pairs[1].width, pairs[1].height) == (640, 480)
    with pytest.raises(ProjectError):
        store.add_pair("a")
    assert [p.label for p in store.pairs()] == ["a", "b"]


def test_objects_and_their_vertices_round_trip_exactly(store):
    rng = np.random.default_rng(5)
    store.add_pair("a")
    calibration_id = store.add_calibration("c", {"phase": "water", "sigma0_px": 0.4})
    made = {}
    for kind, count in (("point", 1), ("length", 2), ("arc", 4), ("polygon", 5), ("circle", 3)):
        vertices = [_vertex(rng, "a", calibration_id) for _ in range(count)]
        made[store.add_object(kind, vertices, f"{kind} attr", "a note", "tester")] = (kind, vertices)
    stored = store.objects()
    assert [o.id for o in stored] == sorted(made)
    for obj in stored:
        kind, vertices = made[obj.id]
        assert (obj.kind, obj.attribute, obj.notes, obj.creator) == (kind, f"{kind} attr", "a note", "tester")
        assert len(obj.vertices) == len(vertices)
        for got, want in zip(obj.vertices, vertices, strict=True):
            assert (got.xl, got.yl, got.xr, got.yr) == (want.xl, want.yl, want.xr, want.yr)
            assert got.xyz == want.xyz  # float64 kept bit for bit
            np.testing.assert_array_equal(got.covariance, want.covariance)
            assert (got.calibration_id, got.pair) == (calibration_id, "a")
        _assert_same_object(store.object(obj.id), obj)


def test_a_vertex_without_3d_values_keeps_its_picks_only(store):
    object_id = store.add_object("point", [Vertex(1.5, 2.5, 3.5, 4.5)])
    vertex = store.object(object_id).vertices[0]
    assert (vertex.xl, vertex.yl, vertex.xr, vertex.yr) == (1.5, 2.5, 3.5, 4.5)
    assert vertex.xyz is None and vertex.covariance is None and vertex.calibration_id is None and vertex.pair is None


def test_objects_update_and_delete_and_unknown_ids_and_kinds_are_errors(store):
    rng = np.random.default_rng(6)
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    replacement = [_vertex(rng), _vertex(rng), _vertex(rng)]
    store.update_object(object_id, attribute="haddock", notes="re-picked", vertices=replacement, kind="arc")
    obj = store.object(object_id)
    assert (obj.kind, obj.attribute, obj.notes) == ("arc", "haddock", "re-picked")
    assert [v.xyz for v in obj.vertices] == [v.xyz for v in replacement]
    store.delete_object(object_id)
    assert store.objects() == []
    for call in (lambda: store.object(object_id), lambda: store.delete_object(object_id)):
        with pytest.raises(ProjectError, match=str(object_id)):
            call()
    with pytest.raises(UsvipsError):
        store.add_object("hexagon", [_vertex(rng)])
    with pytest.raises(UsvipsError):
        store.add_object("length", [_vertex(rng)])  # one vertex is not a length
    assert store.objects() == []


def test_an_object_keeps_its_instants_and_links_that_would_chain_or_mix_kinds_are_refused(store):
    rng = np.random.default_rng(8)
    first, second, third, other = (store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
                                   for _ in range(4))
    point = store.add_object("point", [_vertex(rng)])
    store.add_instant(first, third)
    store.add_instant(first, second)
    assert store.instants(first) == [second, third] and store.instants(second) == []
    assert store.instant_links() == {second: first, third: first}
    for bad, words in (((first, first), "itself"), ((first, point), "one kind"), ((other, second), "already"),
                       ((second, other), "itself an instant"), ((other, first), "instants of its own"),
                       ((first, 999), "999")):
        with pytest.raises(ProjectError, match=words):
            store.add_instant(*bad)
    assert store.instant_links() == {second: first, third: first}
    store.remove_instant(third)
    assert store.instants(first) == [second] and store.object(third).kind == "length"
    with pytest.raises(ProjectError, match="not an instant"):
        store.remove_instant(third)
    store.delete_object(second)
    assert store.instants(first) == []
    store.add_instant(first, third)
    store.delete_object(first)  # its instants stay, as objects of their own
    assert store.instant_links() == {} and store.object(third).attribute == "cod"
@pytest.mark.parametrize("seed", range(3))
def test_how_an_instant_was_made_is_stored_with_its_link_and_no_notes_change_it(store, seed):
    """Schema 10: ``tracked_from`` (the left frame a track started from; None: picked by hand) is what
    add_instant was given, read back per object and for all, kept by delete and undo, in the history's
    link rows; editing an instant's notes never changes it; a frame that is not a whole number >= 0 is
    refused and nothing is stored."""
    rng = np.random.default_rng(seed)
    store.annotator = "ann"
    first, tracked, picked, alone = (store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
                                     for _ in range(4))
    start = int(rng.integers(0, 10_000))
    for bad in (-1, 2.5, True, "3", np.float64(4.0)):
        with pytest.raises(ProjectError, match="whole number"):
            store.add_instant(first, tracked, tracked_from=bad)
    assert store.instant_links() == {}
    count = len(store.history())
    store.add_instant(first, tracked, tracked_from=np.int64(start))
    store.add_instant(first, picked)
    sources = {tracked: start, picked: None}
    assert store.instant_sources(first) == sources and store.instant_sources() == sources
    assert store.instant_sources(tracked) == {} and store.instant_sources(alone) == {}
    assert [(e.object_id, e.old, e.new) for e in store.history()[count:]] == [
        (tracked, {"instant_of": None}, {"instant_of": first, "tracked_from": start}),
        (picked, {"instant_of": None}, {"instant_of": first})]
    store.update_object(tracked, notes="picked by hand after all")  # the notes say nothing of how it was made
    store.update_object(picked, notes=f"tracked from frame {start + 1}")
    assert store.instant_sources(first) == sources
    store.put_back(store.take_object(tracked))  # deleting an instant and undoing it keeps how it was made
    store.put_back(store.take_object(first))  # … and deleting the object (its links go with it) too
    assert store.instant_sources() == sources and store.instant_links() == {tracked: first, picked: first}
    count = len(store.history())
    store.remove_instant(tracked)
    assert [(e.object_id, e.old, e.new) for e in store.history()[count:]] == [
        (tracked, {"instant_of": first, "tracked_from": start}, {"instant_of": None})]
    assert store.instant_sources() == {picked: None}


@pytest.mark.parametrize("seed", range(3))
def test_the_links_of_some_objects_are_every_link_they_take_part_in(store, seed):
    """``instant_links_of``: the links in which the ids take part, as the instant or as its object — what
    ``instant_links`` holds for them, the other links left unread."""
    rng = np.random.default_rng(seed)
    ids = [store.add_object("arc", [_vertex(rng), _vertex(rng)], "cod") for _ in range(30)]
    wholes = [int(i) for i in rng.choice(ids, 6, replace=False)]
    free = [i for i in ids if i not in wholes]
    for instant in rng.choice(free, 15, replace=False):
        store.add_instant(wholes[int(rng.integers(0, len(wholes)))], int(instant))
    every = store.instant_links()
    for _ in range(8):
        asked = [int(i) for i in rng.choice(ids, int(rng.integers(1, 8)), replace=False)]
        assert store.instant_links_of(asked) == {i: w for i, w in every.items() if i in asked or w in asked}
    assert store.instant_links_of([]) == {} and store.instant_links_of(ids) == every
    assert store.instant_links_of([10**9]) == {}


@pytest.mark.parametrize("seed", range(3))
def test_the_records_of_some_objects_are_theirs_alone(store, seed):
    """``records_of``: what ``records`` holds for the ids asked (an object without a record, or no object, is
    absent), the other records left unread — over more ids than one statement binds."""
    rng = np.random.default_rng(seed)
    ids = [store.add_object("arc", [_vertex(rng), _vertex(rng)], "cod") for _ in range(40)]
    for object_id in rng.choice(ids, 25, replace=False):
        store.set_record(int(object_id), ObservationRecord(genus=f"G{int(rng.integers(0, 99))}",
                                                           number=int(rng.integers(1, 9)), comment=f"c {object_id}"))
    every = store.records()
    for _ in range(8):
        asked = [int(i) for i in rng.choice(ids, int(rng.integers(1, 12)), replace=False)]
        assert store.records_of(asked) == {i: r for i, r in every.items() if i in asked}
    assert store.records_of([]) == {} and store.records_of(ids) == every
    assert store.records_of([10**9]) == {}
    assert store.records_of([*ids] * 30) == every  # 1,200 ids asked (duplicates): read in slices


@pytest.mark.parametrize("seed", range(3))
def test_the_objects_on_a_pair_or_on_a_videos_frames_are_read_without_the_rest(store, where, seed):
    """What a detection run compares its proposals with: the objects whose first vertex is on the pair or
    video, on a video between two left frames (inclusive), each as ``object`` reads it."""
    rng = np.random.default_rng(seed)
    folder = where.parent
    for label in ("v", "w"):
        (folder / f"{label}.mp4").write_bytes(label.encode())
        store.add_video(label, [(folder / f"{label}.mp4", 50, 25.0)], [(folder / f"{label}.mp4", 50, 25.0)], 25.0,
                        50, (64, 48))
    first: dict[int, tuple[str, int]] = {}
    for _ in range(12):
        label = ("v", "w")[int(rng.integers(0, 2))]
        frames = [int(f) for f in rng.integers(0, 40, int(rng.integers(2, 5)))]
        vertices = [dataclasses.replace(_vertex(rng, label), video=label, frame_left=f, frame_right=f + 1,
                                        time_s=f / 25.0) for f in frames]
        first[store.add_object("arc", vertices, "cod")] = (label, frames[0])
    for _ in range(6):
        low = int(rng.integers(0, 40))
        high = low + int(rng.integers(0, 15))
        found = store.objects_on("v", low, high)
        expected = sorted(i for i, (label, f) in first.items() if label == "v" and low <= f <= high)
        assert [o.id for o in found] == expected
        assert repr(found) == repr([store.object(i) for i in expected])  # (covariances are arrays)
    assert [o.id for o in store.objects_on("w")] == sorted(i for i, (label, _) in first.items() if label == "w")
    assert store.objects_on("no such pair") == [] and store.objects_on("v", 41, 60) == []
    with pytest.raises(UsvipsError, match="last_frame"):
        store.objects_on("v", 3)


@pytest.mark.parametrize("seed", range(4))
def test_an_object_taken_and_put_back_is_exactly_what_it_was(store, where, seed):
    rng = np.random.default_rng(seed)
    folder = where.parent
    (folder / "v.mp4").write_bytes(b"video")
    store.add_video("v", [(folder / "v.mp4", 50, 25.0)], [(folder / "v.mp4", 50, 25.0)], 25.0, 50, (64, 48))
    calibration_id = store.add_calibration("c", {"phase": "water", "sigma0_px": 0.4})
    ids = []
    for _ in range(3):
        count = int(rng.integers(2, 6))
        vertices = [dataclasses.replace(_vertex(rng, "v", calibration_id), video="v", frame_left=int(f),
                                        frame_right=int(f) + 2, time_s=float(f) / 25.0)
                    for f in rng.integers(0, 40, count)]
        ids.append(store.add_object("arc", vertices, "cod", "a note", "tester"))
    target = ids[int(rng.integers(0, 3))]
    store.update_object(target, vertices=[_vertex(rng, "v", calibration_id) for _ in range(3)])  # a history
    record = ObservationRecord("Gadidae", "Gadus", "morhua", "COD", int(rng.integers(1, 9)), "adult", "", "x")
    store.set_record(target, record)
    before, history = store.object(target), store.vertex_history(target)
    assert history
    assert store.object_rows(target) == store.object_rows(target)  # reading changes nothing
    removed = store.take_object(target)
    assert target not in [o.id for o in store.objects()] and store.vertex_history(target) == []
    store.put_back(removed)
    _assert_same_object(store.object(target), before)
    assert store.object(target).modified == before.modified and store.record(target) == record
    assert store.vertex_history(target) == history
    assert [o.id for o in store.objects()] == sorted(ids)
    with pytest.raises(ProjectError, match=f"object {target} exists again"):
        store.put_back(removed)
    # an edit undone by its rows: exactly as before, and no history row added by the undo
    store.update_object(target, attribute="haddock", vertices=[_vertex(rng, "v", calibration_id)] * 2, kind="length")
    store.set_record(target, None)
    store.put_back(removed, replace=True)
    _assert_same_object(store.object(target), before)
    assert store.vertex_history(target) == history and store.record(target) == record


def _pointed(rng, vertex: Vertex) -> Vertex:
    """``vertex`` with a random pointing: a source, stated sigmas or the default, a weak match or none."""
    source = str(rng.choice(["hand click", "auto-match", "tracked", "hand click (snout, by ana)", "corner"]))
    stated = rng.random() < 0.6
    return dataclasses.replace(
        vertex, source=source, pointing_px=tuple(map(float, rng.uniform(0.2, 2.0, 2))) if stated else None,
        pointing_origin=str(rng.choice(["given", "estimated"])) if stated else "default",
        weak=WeakMatch(float(rng.uniform(-1, 1)), "a second peak scores 0.93 of the best") if rng.random() < 0.5
        else None)


@pytest.mark.parametrize("seed", range(3))
def test_each_vertex_keeps_its_pointing_and_a_weak_match_survives_every_edit_and_undo(store, seed):
    rng = np.random.default_rng(seed)
    store.add_pair("a")
    vertices = [_pointed(rng, _vertex(rng, "a")) for _ in range(4)]
    vertices[1] = dataclasses.replace(vertices[1], weak=WeakMatch(0.42, "the best correlation 0.42 is below 0.50"))
    fish = store.add_object("arc", vertices, "cod", "weak: ambiguous", "tester")
    for got, want in zip(store.object(fish).vertices, vertices, strict=True):  # source, sigmas, origin, weak flag
        assert (got.source, got.pointing_px, got.pointing_origin, got.weak) == (
            want.source, want.pointing_px, want.pointing_origin, want.weak)
    store.update_object(fish, notes="")  # a colleague's notes edit
    store.update_object(fish, kind="polygon")
    # a re-pick with the same picks, as a caller that knows nothing of pointing builds them: all is kept
    store.update_object(fish, vertices=[Vertex(v.xl, v.yl, v.xr, v.yr, v.xyz, v.covariance, None, "a")
                                        for v in vertices])
    assert [v.weak for v in store.object(fish).vertices] == [v.weak for v in vertices]
    assert [(v.source, v.pointing_px) for v in store.object(fish).vertices] == [(v.source, v.pointing_px)
                                                                                 for v in vertices]
    before = store.object(fish)
    removed = store.take_object(fish)  # deleted, then undone
    store.put_back(removed)
    _assert_same_object(store.object(fish), before)
    rows = store.object_rows(fish)  # an edit, then undone by its rows
    store.update_object(fish, vertices=[dataclasses.replace(v, xl=v.xl + 30.0, weak=None) for v in vertices])
    assert store.object(fish).vertices[1].weak is None  # picked again elsewhere: a new pick, a new fact
    store.put_back(rows, replace=True)
    assert store.object(fish).vertices[1].weak == WeakMatch(0.42, "the best correlation 0.42 is below 0.50")
    assert any(entry.new and any("weak" in v for v in entry.new.get("vertices", []))
               for entry in store.history(fish))  # the history shows the flag


def test_a_bad_pointing_is_refused_by_name_and_stores_nothing(store):
    for bad in (Vertex(1, 2, 3, 4, source="guess"),
                Vertex(1, 2, 3, 4, pointing_px=(0.5, -1.0), pointing_origin="given"),
                Vertex(1, 2, 3, 4, pointing_px=(0.5, 0.5), pointing_origin="measured")):
        with pytest.raises(ProjectError, match="cannot store the vertex"):
            store.add_object("point", [bad])
    assert store.objects() == []


def test_calibrations_round_trip_with_their_active_pairs(store):
    for label in ("a", "b", "c"):
        store.add_pair(label)
    data = {"format": "usvips-calibration", "phase": "water", "sigma0_px": 0.43, "nested": {"k": [1.5, -2e-9]}}
    first = store.add_calibration("first", data, ("a", "b"))
    second = store.add_calibration("second", {"phase": "air"})
    assert store.calibration(first) == data
    assert [(c.id, c.name, c.phase) for c in store.calibrations()] == [(first, "first", "water"),
                                                                                 (second, "second", "air")]
    assert store.calibrations()[0].sigma0_px == 0.43
    assert (store.active_calibration("a"), store.active_calibration("b"), store.active_calibration("c")) == (
        first, first, None)
    store.activate_calibration("b", second)
    assert store.active_calibration("b") == second
    with pytest.raises(ProjectError):
        store.calibration(second + 100)
    with pytest.raises(ProjectError):
        store.activate_calibration("c", second + 100)
    with pytest.raises(ProjectError):
        store.add_calibration("bad", {"x": float("nan")})
    assert len(store.calibrations()) == 2


def test_control_and_its_observations_round_trip(store):
    rng = np.random.default_rng(7)
    control = ControlPoints(("1", "2", "10"), rng.normal(size=(3, 3)), np.abs(rng.normal(size=(3, 3))) * 1e-3)
    store.set_control(control)
    got = store.control()
    assert got.ids == control.ids
    np.testing.assert_array_equal(got.xyz, control.xyz)
    np.testing.assert_array_equal(got.sigmas, control.sigmas)
    store.add_pair("w")
    observations = StereoObservations(("1", "10"), rng.uniform(0, 999, (2, 2)), rng.uniform(0, 999, (2, 2)))
    store.add_control_observations(observations, "calibration-water", "w")
    back = store.control_observations("calibration-water", "w")
    assert back.ids == ("1", "10") and back.pairs == ("w", "w")
    np.testing.assert_array_equal(back.left, observations.left)
    np.testing.assert_array_equal(back.right, observations.right)
    assert len(store.control_observations("check", "w")) == 0
    with pytest.raises(ProjectError):
        store.add_control_observations(observations, "calibration-water", "w")  # the same points again
    fewer = StereoObservations(("2",), rng.uniform(0, 999, (1, 2)), rng.uniform(0, 999, (1, 2)))
    store.add_control_observations(fewer, "calibration-water", "w", replace=True)
    assert store.control_observations("calibration-water", "w").ids == ("2",)


def test_media_and_image_pairs_round_trip_and_changes_are_found(store, where):
    folder = where.parent
    plan = _images(folder, 3)
    ids = store.add_image_pairs(plan, "water", [(640, 480)] * 3)
    assert len(ids) == 3 and [p.label for p in store.pairs()] == ["p0", "p1", "p2"]
    for (label, left, right), pair in zip(plan, store.pairs(), strict=True):
        assert pair.label == label
        assert store.image_path(pair.left) == left.resolve() and store.media_path(pair.right) == right.resolve()
    assert store.media_problems() == []
    plan[1][1].write_bytes(b"something else entirely")
    moved = folder / "moved"
    moved.mkdir()
    plan[2][2].rename(moved / plan[2][2].name)
    problems = dict(store.media_problems())
    assert set(problems) == {store.pairs()[1].left, store.pairs()[2].right}
    new = store.relocate_media(store.pairs()[2].right, moved / plan[2][2].name)
    assert store.media_path(new) == (moved / plan[2][2].name).resolve()
    assert set(dict(store.media_problems())) == {store.pairs()[1].left}
    with pytest.raises(ProjectError):
        store.image_path("no/such/image.png")


def test_videos_with_offsets_and_periods_round_trip(store, where):
    folder = where.parent
    chapters = {}
    for side in ("left", "right"):
        chapters[side] = []
        for k in range(2):
            path = folder / f"{side}{k}.mp4"
            path.write_bytes(f"{side} chapter {k}".encode())
            chapters[side].append((path, 100 + k, 25.0))
    store.add_video("dive", chapters["left"], chapters["right"], 25.0, 201, (1920, 1080), "fine")
    video = store.video("dive")
    assert (video.label, video.fps, video.frame_count, video.width, video.height) == (
        "dive", 25.0, 201, 1920, 1080)
    assert video.offset_frames == 0 and video.report == "fine"
    assert [v.label for v in store.videos()] == ["dive"]
    assert "dive" in [p.label for p in store.pairs()]  # a video is measured like a pair
    store.set_video_offset("dive", -3, {"method": "audio", "confidence": 0.9})
    video = store.video("dive")
    assert video.offset_frames == -3 and video.offset_estimate == {"method": "audio", "confidence": 0.9}
    store.add_period("dive", "transect 1", 10, 150)
    assert store.periods("dive") == [("transect 1", 10, 150)]
    with pytest.raises(ProjectError, match="dive"):
        store.add_video("dive", chapters["left"], chapters["right"], 25.0, 201, (1920, 1080))
    with pytest.raises(ProjectError):
        store.video("no such video")
    # a video knows its medium (an in-air calibration video is not water), stored as its pair's
    store.add_video("in air", chapters["left"], chapters["right"], 25.0, 201, (1920, 1080), medium="air")
    media = {p.label: p.medium for p in store.pairs()}
    assert media["in air"] == "air" and media["dive"] == "water"
    with pytest.raises(ProjectError, match="medium"):
        store.add_video("in oil", chapters["left"], chapters["right"], 25.0, 201, (1920, 1080), medium="oil")


def test_vocabulary_species_records_enhancements_and_drafts_round_trip(store):
    rng = np.random.default_rng(8)
    for term in ("cod", "haddock", "cod"):
        store.add_term(term)
    store.add_term("murky", "visibility")
    assert store.vocabulary() == ["cod", "haddock"] and store.vocabulary("visibility") == ["murky"]
    species = [Species("Gadidae", "Gadus", "morhua", "COD"),
               Species("Gadidae", "Melanogrammus", "aeglefinus", max_length_m=1.12)]
    store.set_species_list(species)
    assert store.species_list() == sorted(species, key=lambda s: (s.genus, s.species))
    object_id = store.add_object("point", [_vertex(rng)])
    record = ObservationRecord("Gadidae", "Gadus", "morhua", "COD", 3, "adult", "feeding", "near the rock")
    assert store.record(object_id) is None and store.records() == {}
    store.set_record(object_id, record)
    assert store.record(object_id) == record and store.records() == {object_id: record}
    store.set_record(object_id, None)
    assert store.record(object_id) is None
    store.set_enhancement("p1/left", '{"steps": []}')
    assert store.enhancement("p1/left") == '{"steps": []}' and store.enhancement("p2/left") is None
    store.set_draft("wizard", "half done")
    assert store.draft("wizard") == "half done"
    store.set_draft("wizard", None)
    assert store.draft("wizard") is None



def test_the_campaign_round_trips_is_replaced_and_removed_and_a_reader_cannot_change_it(impl, store, where):
    assert store.campaign() is None
    campaign = Campaign("2024-03_Abrolhos_stereo-BRUVs", "Abrolhos Reef monitoring", "stereo-BRUVs",
                        "stratified random, 4 strata", "Ana Ng", "UWA", "2024-03-02", "2024-03-09",
                        comment="Ünïcode, 'quotes' and \"more\"")
    store.set_campaign(campaign)
    assert store.campaign() == campaign
    half = Campaign(campaign_id="2025-01_x_stereo-DOVs")  # stored half filled in; an export names what is missing
    store.set_campaign(half)
    assert store.campaign() == half and half.missing() == ["project", "method", "submitter"]
    store.close()
    reader = impl.open(where, True)
    try:
        assert reader.campaign() == half  # kept, seen by another handle
        before = impl.snapshot(where)
        with pytest.raises(ProjectError):
            reader.set_campaign(campaign)
        assert impl.snapshot(where) == before and reader.campaign() == half
    finally:
        reader.close()
    writer = impl.open(where, False)
    try:
        writer.set_campaign(None)
        assert writer.campaign() is None
        writer.set_campaign(None)  # nothing to remove: no error
    finally:
        writer.close()
def test_deployments_and_the_georeference_round_trip(store, where):
    folder = where.parent
    (folder / "v0.mp4").write_bytes(b"video")
    store.add_video("v", [(folder / "v0.mp4", 10, 25.0)], [(folder / "v0.mp4", 10, 25.0)], 25.0, 10, (64, 48))
    assert store.deployments() == {} and store.deployment() is None and store.georeference() is None
    project_wide = Deployment(opcode="OP1", site="reef", depth_m=12.5)
    own = Deployment(opcode="OP2", location="bay")
    store.set_deployment(project_wide)
    store.set_deployment(own, "v")
    assert store.deployments() == {"": project_wide, "v": own}
    assert store.deployment("v") == own and store.deployment("other") == project_wide
    store.set_deployment(None, "v")
    assert store.deployment("v") == project_wide
    georeference = Georeference(-33.8, 151.2, 12.0, 45.0)
    store.set_georeference(georeference)
    assert store.georeference() == georeference
    store.set_georeference(None)
    assert store.georeference() is None


def test_a_copy_holds_everything_and_the_original_carries_on(impl, store, where):
    rng = np.random.default_rng(9)
    store.add_pair("a")
    object_id = store.add_object("length", [_vertex(rng, "a"), _vertex(rng, "a")], "cod")
    copy = store.copy_to(where.parent / "copy.usvips")
    with impl.open(copy, False) as other:
        _assert_same_object(other.object(object_id), store.object(object_id))
        assert other.pairs() == store.pairs()
    store.delete_object(object_id)
    with impl.open(copy, True) as other:
        assert [o.id for o in other.objects()] == [object_id]


# ------------------------------------------------------------------------------------------ transactions
def test_a_transaction_keeps_all_or_on_any_error_nothing(store):
    rng = np.random.default_rng(10)
    with store.transaction():
        store.add_pair("kept")
        store.add_object("point", [_vertex(rng)])
    with pytest.raises(RuntimeError), store.transaction():
        store.add_pair("lost")
        with store.transaction():  # nested: joins the outer one
            store.add_object("point", [_vertex(rng)])
            store.add_term("lost")
        store.add_calibration("lost", {"phase": "air"}, ("lost",))
        raise RuntimeError("the user's operation failed half way")
    assert [p.label for p in store.pairs()] == ["kept"]
    assert len(store.objects()) == 1 and store.vocabulary() == [] and store.calibrations() == []


def test_a_used_label_or_one_file_on_both_sides_adds_nothing(store, where):
    plan = _images(where.parent, 2)
    store.add_image_pairs(plan[:1])
    with pytest.raises(ProjectError, match="label.*'p0' already used"):
        store.add_image_pairs(plan)  # p1 is new, p0 is not: neither is added
    with pytest.raises(ProjectError, match="label.*'p1' already used"):
        store.add_image_pairs([plan[1], plan[1]])
    with pytest.raises(ProjectError, match="'same'.*both the left and the right image"):
        store.add_image_pairs([("same", plan[1][1], plan[1][1])])
    assert [p.label for p in store.pairs()] == ["p0"]


def test_several_objects_are_stored_all_or_none(store):
    rng = np.random.default_rng(11)
    good = ("point", [_vertex(rng)], "", "", "")
    with pytest.raises(UsvipsError):
        store.add_objects([good, good, ("length", [_vertex(rng)], "", "", "")])
    assert store.objects() == []
    with pytest.raises(UsvipsError):
        store.add_image_pairs([("x", Path("/no/such/left.png"), Path("/no/such/right.png"))])
    assert store.pairs() == []
    assert len(store.add_objects([good, good])) == 2


# ------------------------------------------------------------------------------------------ read-only
WRITES = {
    "add_pair": lambda s, f: s.add_pair("new"),
    "add_image_pairs": lambda s, f: s.add_image_pairs(_images(f, 1)),
    "add_calibration": lambda s, f: s.add_calibration("c", {"phase": "air"}),
    "activate_calibration": lambda s, f: s.activate_calibration("a", 1),
    "set_control": lambda s, f: s.set_control(ControlPoints(("9",), np.zeros((1, 3)))),
    "add_control_observations": lambda s, f: s.add_control_observations(
        StereoObservations(("9",), np.zeros((1, 2)), np.zeros((1, 2))), "check", "a"),
    "add_object": lambda s, f: s.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)]),
    "add_objects": lambda s, f: s.add_objects([("point", [Vertex(1.0, 2.0, 3.0, 4.0)], "", "", "")]),
    "add_video": lambda s, f: s.add_video("w", [(f / "v0.mp4", 10, 25.0)], [(f / "v0.mp4", 10, 25.0)], 25.0, 10,
                                          (64, 48)),
    "update_object": lambda s, f: s.update_object(1, attribute="changed"),
    "delete_object": lambda s, f: s.delete_object(1),
    "add_instant": lambda s, f: s.add_instant(1, 2),
    "remove_instant": lambda s, f: s.remove_instant(2),
    "take_object": lambda s, f: s.take_object(1),
    "put_back": lambda s, f: s.put_back(s.object_rows(1), replace=True),
    "add_term": lambda s, f: s.add_term("new"),
    "set_enhancement": lambda s, f: s.set_enhancement("k", "{}"),
    "set_draft": lambda s, f: s.set_draft("d", "text"),
    "set_species_list": lambda s, f: s.set_species_list([]),
    "set_record": lambda s, f: s.set_record(1, ObservationRecord(genus="Gadus")),
    "set_review": lambda s, f: s.set_review(1, "flagged", "tail cut off"),
    "set_video_offset": lambda s, f: s.set_video_offset("v", 2),
    "set_deployment": lambda s, f: s.set_deployment(Deployment(opcode="OP1")),
    "set_georeference": lambda s, f: s.set_georeference(Georeference(-33.8, 151.2, 12.0, 45.0)),
    "set_campaign": lambda s, f: s.set_campaign(Campaign("2024-03_x_stereo-BRUVs")),
    "add_period": lambda s, f: s.add_period("v", "p", 0, 1),
    "relocate_media": lambda s, f: s.relocate_media("v0.mp4", f / "v0.mp4"),
    "accept_media": lambda s, f: s.accept_media("v0.mp4"),
    "set_pointing_estimates": lambda s, f: s.set_pointing_estimates([{"source": "hand click", "sigma_px": 0.4}]),
    "transaction": lambda s, f: s.transaction().__enter__(),
}


@pytest.mark.parametrize("write", sorted(WRITES))
def test_a_read_only_store_refuses_every_write_and_changes_nothing(impl, where, write):
    folder = where.parent
    with impl.create(where) as store:
        store.add_pair("a")
        store.add_calibration("c", {"phase": "air"}, ("a",))
        store.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)], "cod")
        (folder / "v0.mp4").write_bytes(b"video")
        store.add_video("v", [(folder / "v0.mp4", 10, 25.0)], [(folder / "v0.mp4", 10, 25.0)], 25.0, 10, (64, 48))
    before = impl.snapshot(where)
    with impl.open(where, True) as store:
        assert store.read_only is True
        with pytest.raises(ProjectError, match="read-only|readonly|read only"):
            WRITES[write](store, folder)
        assert store.object(1).attribute == "cod"  # reading still works
    assert impl.snapshot(where) == before


# ------------------------------------------------------------------------------------------ two handles
def test_two_handles_see_each_others_committed_writes_and_never_uncommitted_ones(impl, store, where):
    rng = np.random.default_rng(12)
    with impl.open(where, False) as other:
        first = store.add_object("point", [_vertex(rng)])
        assert [o.id for o in other.objects()] == [first]
        with store.transaction():
            second = store.add_object("point", [_vertex(rng)])
            assert [o.id for o in other.objects()] == [first]  # not yet committed
        assert [o.id for o in other.objects()] == [first, second]
        other.update_object(first, attribute="from the other handle")
        assert store.object(first).attribute == "from the other handle"


def test_a_write_while_another_handle_holds_a_transaction_is_a_one_line_error_and_loses_nothing(impl, store,
                                                                                                  where):
    rng = np.random.default_rng(13)
    with impl.open(where, False) as other:
        with store.transaction():
            kept = store.add_object("point", [_vertex(rng)])
            with pytest.raises(ProjectError) as refused:
                other.add_object("point", [_vertex(rng)])
            assert "\n" not in str(refused.value) and str(where) in str(refused.value)
        assert [o.id for o in other.objects()] == [kept]


def test_two_handles_writing_from_two_threads_lose_no_object(impl, store, where):
    """Each thread opens its own handle and stores objects one transaction at a time; every object of
    both arrives once, with its own id."""
    count, results, errors = 40, {}, []

    def worker(name: str) -> None:
        rng = np.random.default_rng(len(name))
        try:
            with impl.open(where, False) as handle:
                ids = []
                for _ in range(count):
                    for _attempt in range(50):  # a busy store is an error the caller may retry
                        try:
                            ids.append(handle.add_object("point", [_vertex(rng)], name))
                            break
                        except ProjectError:
                            continue
                results[name] = ids
        except Exception as error:  # noqa: BLE001 - reported below
            errors.append(error)

    threads = [threading.Thread(target=worker, args=(name,)) for name in ("first", "second")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    stored = store.objects()
    assert len(stored) == 2 * count and len({o.id for o in stored}) == 2 * count
    for name, ids in results.items():
        assert len(ids) == count and {o.id for o in stored if o.attribute == name} == set(ids)


# ---------------------------------------------------------------------------------------- who, when, history
def _record(rng) -> ObservationRecord:
    return ObservationRecord(genus=str(rng.choice(["Pagrus", "Chrysophrys", "Gadus"])),
                             species=str(rng.choice(["auratus", "morhua", ""])), number=int(rng.integers(1, 9)))


@pytest.mark.parametrize("seed", range(3))
def test_each_write_to_an_object_leaves_exactly_one_history_row_with_who_and_what(store, seed):
    """Every write kind (add, edit, re-pick, record set and removed, delete, put back) adds one row, by the
    annotator of the handle that wrote, naming the object, with the values before and after."""
    rng = np.random.default_rng(seed)
    store.annotator = f"ann-{seed}"
    first = [_vertex(rng) for _ in range(2)]
    object_id = store.add_object("length", first, "cod", "n1")
    other = store.add_object("point", [_vertex(rng)], "sponge")
    second = [first[0], _vertex(rng)]
    record = _record(rng)

    writes = [
        ("edit", lambda: store.update_object(object_id, attribute="ling", notes="n2"),
         {"attribute": "cod", "notes": "n1"}, {"attribute": "ling", "notes": "n2"}),
        ("re-pick", lambda: store.update_object(object_id, vertices=second), None, None),
        ("record", lambda: store.set_record(object_id, record), None, dataclasses.asdict(record)),
        ("record", lambda: store.set_record(object_id, None), dataclasses.asdict(record), None),
    ]
    assert [(e.change, e.object_id, e.annotator) for e in store.history()] == [
        ("add", object_id, f"ann-{seed}"), ("add", other, f"ann-{seed}")]
    added = store.history(object_id)[0].new
    assert added["kind"] == "length" and added["attribute"] == "cod" and len(added["vertices"]) == 2
    assert added["vertices"][1]["xl"] == first[1].xl
    for change, write, old, new in writes:
        count = len(store.history())
        write()
        entries = store.history()
        assert len(entries) == count + 1
        last = entries[-1]
        assert (last.change, last.object_id, last.annotator) == (change, object_id, f"ann-{seed}")
        if old is not None or change == "record":
            assert last.old == old and last.new == new
    repick = store.history(object_id)[2]
    assert [v["xl"] for v in repick.old["vertices"]] == [first[0].xl, first[1].xl]
    assert [v["xl"] for v in repick.new["vertices"]] == [second[0].xl, second[1].xl]

    store.annotator = "second reader"
    taken = store.take_object(object_id)
    assert store.history()[-1].change == "delete" and store.history()[-1].old["attribute"] == "ling"
    store.put_back(taken)
    assert (store.history()[-1].change, store.history()[-1].annotator) == ("put back", "second reader")
    assert store.history()[-1].new["attribute"] == "ling"
    store.delete_object(other)
    entries = store.history()
    assert (entries[-1].change, entries[-1].object_id, entries[-1].old["kind"]) == ("delete", other, "point")
    assert [e.id for e in entries] == sorted(e.id for e in entries) and len({e.id for e in entries}) == len(entries)
    assert [e.at for e in entries] == sorted(e.at for e in entries)  # newest last


def test_the_history_of_a_deleted_object_stays_and_no_write_can_alter_it(store):
    store.annotator = "ann"
    rng = np.random.default_rng(7)
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    store.set_record(object_id, _record(rng))
    store.delete_object(object_id)
    kept = store.history(object_id)
    assert [e.change for e in kept] == ["add", "record", "delete"]
    assert kept[-1].old["record"]["genus"] in ("Pagrus", "Chrysophrys", "Gadus")
    with pytest.raises(ProjectError):
        store.object(object_id)
    # the schema itself refuses to change or remove a history row, whoever asks (not only this program)
    for statement in ("UPDATE history SET annotator = 'someone else'", "DELETE FROM history"):
        with pytest.raises(Exception, match="append-only"):
            with store.transaction():
                store._db.execute(statement)
    assert store.history(object_id) == kept


def test_objects_vertices_and_records_carry_who_made_them_and_when(impl, store, where):
    rng = np.random.default_rng(3)
    store.annotator = "alice"
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    made = store.provenance(object_id)
    assert made.object[0] == "alice" and made.record is None
    assert [v[0] for v in made.vertices] == ["alice", "alice"]
    assert all(v[1] == made.object[1] for v in made.vertices)
    with impl.open(where, False) as bob:
        bob.annotator = "bob"
        stored = bob.object(object_id)
        bob.update_object(object_id, vertices=[stored.vertices[0], _vertex(rng)])  # bob re-picks the tail
        bob.set_record(object_id, _record(rng))
    after = store.provenance(object_id)
    assert after.object[:2] == made.object[:2] and after.object[2] > made.object[2]
    assert after.vertices[0] == made.vertices[0]  # the unchanged pick keeps who picked it
    assert after.vertices[1][0] == "bob" and after.vertices[1][1] > made.vertices[1][1]
    assert after.record[0] == "bob" and after.record[1] > made.object[1]
    assert [e.annotator for e in store.history(object_id)] == ["alice", "bob", "bob"]


def test_linking_and_unlinking_an_instant_is_one_history_row_each_and_a_refusal_none(store):
    rng = np.random.default_rng(11)
    store.annotator = "ann"
    first, later = (store.add_object("length", [_vertex(rng), _vertex(rng)], "cod") for _ in range(2))
    count = len(store.history())
    store.add_instant(first, later)
    assert [(e.change, e.object_id, e.old, e.new) for e in store.history()[count:]] == [
        ("edit", later, {"instant_of": None}, {"instant_of": first})]
    with pytest.raises(ProjectError):
        store.add_instant(later, first)  # would chain instants: refused, and nothing recorded
    store.remove_instant(later)
    assert [(e.change, e.object_id, e.old, e.new) for e in store.history()[count + 1:]] == [
        ("edit", later, {"instant_of": first}, {"instant_of": None})]
    with pytest.raises(ProjectError, match="not an instant"):
        store.remove_instant(later)
    assert len(store.history()) == count + 2


def test_a_refused_write_leaves_no_history_row(store):
    rng = np.random.default_rng(12)
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    read = store.object(object_id).modified
    store.update_object(object_id, notes="first edit")
    kept = store.history()
    refusals = [lambda: store.update_object(object_id, attribute="x", expected_modified=read),  # stale
                lambda: store.delete_object(object_id, expected_modified=read),
                lambda: store.update_object(object_id, kind="polygon"),  # too few vertices
                lambda: store.update_object(object_id + 99, attribute="x"),
                lambda: store.set_record(object_id + 99, ObservationRecord(genus="Gadus")),
                lambda: store.add_object("circle", [_vertex(rng)])]
    for refused in refusals:
        with pytest.raises(UsvipsError):
            refused()
        assert store.history() == kept


def test_two_annotators_writing_at_once_each_get_exactly_their_history_rows(impl, store, where):
    """Two handles in two threads, each an annotator adding objects and editing them one transaction at a
    time (retrying when the store is busy): the history holds exactly one row per write that was kept,
    carrying the annotator of the handle that made it — none lost, none doubled, none misattributed."""
    count, done, errors = 15, {}, []

    def worker(name: str) -> None:
        rng = np.random.default_rng(len(name))
        try:
            with impl.open(where, False) as handle:
                handle.annotator = name
                writes = []
                for k in range(count):
                    for _attempt in range(50):
                        try:
                            object_id = handle.add_object("point", [_vertex(rng)], name)
                            break
                        except ProjectError:
                            continue
                    writes.append(("add", object_id))
                    for _attempt in range(50):
                        try:
                            handle.update_object(object_id, notes=f"{name} {k}")
                            break
                        except ProjectError:
                            continue
                    writes.append(("edit", object_id))
                done[name] = writes
        except Exception as error:  # noqa: BLE001 - reported below
            errors.append(error)

    threads = [threading.Thread(target=worker, args=(name,)) for name in ("alice", "bob")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    entries = store.history()
    assert len(entries) == 4 * count
    for name, writes in done.items():
        assert [(e.change, e.object_id) for e in entries if e.annotator == name] == writes


# ------------------------------------------------------------------------------------------ reviews (schema 9)
@pytest.mark.parametrize("seed", range(3))
def test_reviews_follow_every_change_with_who_and_when_and_one_history_row_each(store, seed):
    """Random review changes by two annotators on a handful of objects: after each, the stored reviews are
    what was asked (state, reason, reviewer), the object's version moved forward, and the history gained
    exactly one 'review' row with the state before and after — unless the object already had that state
    and reason: then nothing changed (no row, the same version, the first reviewer kept)."""
    rng = np.random.default_rng(seed)
    ids = [store.add_object("point", [_vertex(rng)], "cod") for _ in range(int(rng.integers(3, 7)))]
    assert store.reviews() == [Review(i) for i in ids]
    assert all(store.review(i).state == "unreviewed" for i in ids)
    want = {i: Review(i) for i in ids}
    for step in range(12):
        store.annotator = str(rng.choice(["alice", "bob"]))
        object_id = int(rng.choice(ids))
        state = str(rng.choice(REVIEW_STATES))
        reason = {"flagged": f"reason {step} ü", "accepted": str(rng.choice(["", "fine"])), "unreviewed": ""}[state]
        before, count = store.object(object_id).modified, len(store.history())
        store.set_review(object_id, state, f"  {reason} ")  # a reason is kept stripped
        got = store.review(object_id)
        assert (got.state, got.reason) == (state, reason)
        if (want[object_id].state, want[object_id].reason) == (state, reason):  # no change
            assert got == want[object_id] and store.object(object_id).modified == before
            assert len(store.history()) == count
            continue
        assert (got.reviewer, bool(got.reviewed)) == ((store.annotator, True) if state != "unreviewed" else ("", False))
        assert store.object(object_id).modified > before
        entries = store.history()
        assert len(entries) == count + 1
        last = entries[-1]
        assert (last.change, last.object_id, last.annotator) == ("review", object_id, store.annotator)
        assert last.old["state"] == want[object_id].state and last.new["state"] == state
        if state != "unreviewed":
            assert last.new["reason"] == reason and last.new["reviewer"] == store.annotator
        want[object_id] = got
    assert store.reviews() == [want[i] for i in ids]
    for state in REVIEW_STATES:
        assert store.reviews(state) == [want[i] for i in ids if want[i].state == state]


def test_reviewing_again_with_the_same_state_and_reason_writes_nothing(impl, store, where):
    """Accepted (or flagged for a reason, or unreviewed) again as it already is: no history row, no new
    version, the first reviewer and time kept; another reason or state is a change as usual."""
    rng = np.random.default_rng(17)
    object_id = store.add_object("point", [_vertex(rng)], "cod")
    store.annotator = "alice"
    for state, reason, changes in (("unreviewed", "", False), ("accepted", "", True), ("accepted", " ", False),
                                   ("accepted", "fine", True), ("flagged", "blurred", True),
                                   ("flagged", "blurred ", False), ("flagged", "snout hidden", True),
                                   ("unreviewed", "", True), ("unreviewed", "", False)):
        review, version, count = store.review(object_id), store.object(object_id).modified, len(store.history())
        with impl.open(where, False) as other:  # another reader, naming the version they read
            other.annotator = "bob"
            other.set_review(object_id, state, reason, expected_modified=version)
        if changes:
            assert len(store.history()) == count + 1 and store.object(object_id).modified > version
            assert store.review(object_id).reviewer == ("bob" if state != "unreviewed" else "")
        else:
            assert store.review(object_id) == review and store.object(object_id).modified == version
            assert len(store.history()) == count


def test_bad_reviews_are_one_line_naming_the_object_and_change_nothing(store):
    rng = np.random.default_rng(5)
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    store.set_review(object_id, "accepted")
    kept, modified = store.history(), store.object(object_id).modified
    for write, message in [(lambda: store.set_review(object_id + 99, "accepted"), f"no object {object_id + 99}"),
                           (lambda: store.set_review(object_id, "approved"), "unknown review state 'approved'"),
                           (lambda: store.set_review(object_id, "flagged"), "a flag needs a reason"),
                           (lambda: store.set_review(object_id, "flagged", "   "), "a flag needs a reason"),
                           (lambda: store.set_review(object_id, "flagged", "two\nlines"), "one line"),
                           (lambda: store.set_review(object_id, "unreviewed", "why"), "has no reason"),
                           (lambda: store.review(object_id + 99), f"no object {object_id + 99}"),
                           (lambda: store.reviews("approved"), "unknown review state")]:
        with pytest.raises(ProjectError, match=message) as refused:
            write()
        assert "\n" not in str(refused.value) and f"object {object_id}" in str(refused.value) or "state" in message
    assert store.history() == kept and store.object(object_id).modified == modified
    assert store.review(object_id).state == "accepted"


def test_a_stale_review_is_refused_by_name_and_a_fresh_one_kept(impl, store, where):
    """Two reviewers read an object; one edits or reviews it; the other's review made on what they read is
    refused by name (nothing changed), and made again on the object as it now is, kept."""
    rng = np.random.default_rng(8)
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    with impl.open(where, False) as other:
        other.annotator = "bob"
        read = other.object(object_id).modified
        store.annotator = "alice"
        store.set_review(object_id, "flagged", "head hidden by a rock")
        kept = store.history()
        with pytest.raises(StaleEditError, match=f"object {object_id} was changed by someone else"):
            other.set_review(object_id, "accepted", expected_modified=read)
        assert store.history() == kept and store.review(object_id).state == "flagged"
        other.set_review(object_id, "accepted", expected_modified=other.object(object_id).modified)
        assert (store.review(object_id).state, store.review(object_id).reviewer) == ("accepted", "bob")
        read = store.object(object_id).modified
        other.update_object(object_id, notes="re-measured")
        with pytest.raises(StaleEditError):
            store.set_review(object_id, "flagged", "too long", expected_modified=read)
        assert store.review(object_id).state == "accepted"


def test_a_deleted_object_takes_its_review_and_an_undo_puts_it_back(store):
    rng = np.random.default_rng(9)
    first, second = (store.add_object("point", [_vertex(rng)], "cod") for _ in range(2))
    store.set_review(first, "flagged", "blurred")
    store.set_review(second, "accepted")
    taken = store.take_object(first)
    assert [r.object_id for r in store.reviews()] == [second]
    assert store.history(first)[-1].old["review"]["state"] == "flagged"
    store.put_back(taken)
    assert store.review(first).state == "flagged" and store.review(first).reason == "blurred"
    store.delete_object(second)
    assert store.reviews("accepted") == []


@pytest.mark.parametrize("seed", range(3))
def test_an_edit_of_what_was_reviewed_returns_an_accepted_object_to_unreviewed_and_an_undo_restores_it(store, seed):
    """Random edits of random objects in random review states: an edit that changes the kind, the attribute,
    the vertices (re-pick, a vertex deleted) or the observation record of an ACCEPTED object returns it to
    unreviewed with a second history row ('review' accepted → unreviewed, 'edited after review', by the
    editor); a flagged or unreviewed object keeps its review, and so does every object after an edit of its
    notes, an edit that changes nothing, or an instant linked. Putting back the rows read before the edit
    (an undo) restores the review exactly."""
    rng = np.random.default_rng(100 + seed)
    ids = [store.add_object("arc", [_vertex(rng) for _ in range(4)], "cod") for _ in range(5)]
    spare = store.add_object("arc", [_vertex(rng) for _ in range(3)], "cod")  # linked as an instant below
    edits = {
        "attribute": (True, lambda i: store.update_object(i, attribute=f"ling {rng.integers(1e9)}")),
        "same attribute": (False, lambda i: store.update_object(i, attribute=store.object(i).attribute)),
        "notes": (False, lambda i: store.update_object(i, notes=f"seen {rng.integers(1e9)}")),
        "kind": (True, lambda i: store.update_object(i, kind="polygon" if store.object(i).kind == "arc" else "arc")),
        "re-pick": (True, lambda i: store.update_object(
            i, vertices=[_vertex(rng)] + list(store.object(i).vertices[1:]))),
        "delete a vertex": (True, lambda i: store.update_object(i, vertices=list(store.object(i).vertices[:-1]))),
        "record": (True, lambda i: store.set_record(i, _record(rng))),
        "same record": (False, lambda i: store.set_record(i, store.record(i))),
        "instant": (False, lambda i: store.add_instant(i, spare) if spare not in store.instant_links() else
                    store.remove_instant(spare)),
    }
    names = sorted(edits)
    seen = set()
    for step in range(3 * len(names) + 12):  # each edit of each state first, then random ones
        object_id = int(rng.choice(ids))
        if len(store.object(object_id).vertices) < 4:  # room to delete a vertex, and to stay a polygon
            store.update_object(object_id, vertices=[_vertex(rng) for _ in range(4)])
        planned = step < 3 * len(names)
        state = REVIEW_STATES[step // len(names)] if planned else str(rng.choice(REVIEW_STATES))
        store.annotator = "reviewer"
        store.set_review(object_id, state, "head hidden" if state == "flagged" else "")
        reviewed = store.review(object_id)
        name = names[step % len(names)] if planned else str(rng.choice(names))
        changes_review, edit = edits[name]
        store.annotator = f"editor {step}"
        before, count = store.object_rows(object_id), len(store.history())
        edit(object_id)
        entries = store.history()[count:]
        if changes_review and state == "accepted":
            seen.add(name)
            assert store.review(object_id) == Review(object_id), name
            assert entries[-1].object_id == object_id and entries[-1].change == "review"
            assert entries[-1].annotator == f"editor {step}" and len(entries) == 2
            assert entries[-1].old == {"state": "accepted", "reason": "", "reviewer": "reviewer"}
            assert entries[-1].new == {"state": "unreviewed", "reason": "edited after review"}
            assert entries[0].change in ("edit", "re-pick", "record") and entries[0].at <= entries[-1].at
        else:
            assert store.review(object_id) == reviewed, name
            assert [e.change for e in entries] in (["edit"], ["re-pick"], ["record"]), name
        store.put_back(before, replace=True)  # the undo
        assert store.review(object_id) == reviewed
        assert store.object_rows(object_id) == before or name == "instant"  # the link is the spare's row
        if name == "instant":
            store.remove_instant(spare) if spare in store.instant_links() else None
    assert seen == {"attribute", "kind", "re-pick", "delete a vertex", "record"}


def test_a_review_read_before_an_edit_that_unreviewed_the_object_is_stale(impl, store, where):
    """The edit that returned an accepted object to unreviewed made a new version: a reviewer's accept of
    what they read before it is refused by name (the object stays unreviewed, the history as it was)."""
    rng = np.random.default_rng(31)
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    store.set_review(object_id, "accepted")
    with impl.open(where, False) as other:
        other.annotator = "reviewer"
        read = other.object(object_id).modified
        store.set_record(object_id, _record(rng))
        kept = store.history()
        with pytest.raises(StaleEditError, match=f"object {object_id} was changed by someone else"):
            other.set_review(object_id, "accepted", expected_modified=read)
        assert store.review(object_id).state == "unreviewed" and store.history() == kept


def test_two_readers_reviewing_the_same_objects_at_once_lose_nothing_and_overwrite_nothing(impl, store, where):
    """Two handles in two threads review the same objects, each naming the version it read: every review is
    kept or refused (stale, or the store busy) — a kept one is exactly one history row of its reader, a
    refused one none — and each object's state is its last kept review."""
    rng = np.random.default_rng(21)
    ids = [store.add_object("point", [_vertex(rng)], "cod") for _ in range(4)]
    kept: dict[str, list[tuple[int, str]]] = {}
    errors = []

    def reader(name: str) -> None:
        local = np.random.default_rng(len(name))
        try:
            with impl.open(where, False) as handle:
                handle.annotator = name
                made = []
                for k in range(12):
                    object_id = int(local.choice(ids))
                    state = ("accepted", "flagged")[k % 2]
                    read = handle.object(object_id).modified
                    prior = handle.review(object_id)  # as at ``read`` when the review below is not stale
                    reason = f"{name} {k}" if state == "flagged" else ""
                    try:
                        handle.set_review(object_id, state, reason, expected_modified=read)
                    except ProjectError:  # stale (the other reader was first) or busy: nothing written
                        continue
                    if (prior.state, prior.reason) != (state, reason):  # else already so: nothing written
                        made.append((object_id, state))
                kept[name] = made
        except Exception as error:  # noqa: BLE001 - reported below
            errors.append(error)

    threads = [threading.Thread(target=reader, args=(name,)) for name in ("alice", "bob")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    reviews = [e for e in store.history() if e.change == "review"]
    for name, made in kept.items():
        assert [(e.object_id, e.new["state"]) for e in reviews if e.annotator == name] == made
    for object_id in ids:
        mine = [e for e in reviews if e.object_id == object_id]
        final = store.review(object_id)
        if mine:
            assert (final.state, final.reviewer) == (mine[-1].new["state"], mine[-1].annotator)
            assert [e.old["state"] for e in mine[1:]] == [e.new["state"] for e in mine[:-1]]  # none overwritten
        else:
            assert final.state == "unreviewed"


def test_an_undo_or_redo_over_another_annotators_later_edit_is_refused_by_name_and_changes_nothing(impl, store,
                                                                                                      where):
    """Alice edits an object (her window keeps the rows before and after, for Ctrl+Z); Bob, on another
    handle, changes it again; Alice's undo (``put_back`` of the rows before, naming the version she left
    it at) is refused by name — the object, Bob, nothing changed — and so are her redo and her take of it
    (an undo of a store); with nobody in between every step goes through and restores the rows exactly.
    Putting back a deleted object whose id was used again names who did it."""
    rng = np.random.default_rng(41)
    store.annotator = "alice"
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    before = store.object_rows(object_id)
    store.update_object(object_id, attribute="haddock", vertices=[_vertex(rng), _vertex(rng)])
    after = store.object_rows(object_id)
    assert before.modified < after.modified == store.object(object_id).modified
    # nobody in between: undo, redo, undo — each exactly the rows, each checked against the version left
    store.put_back(before, expected_modified=after.modified)
    assert store.object_rows(object_id) == before
    store.put_back(after, expected_modified=before.modified)
    assert store.object_rows(object_id) == after
    with impl.open(where, False) as other:
        other.annotator = "bob"
        other.update_object(object_id, notes="measured again by bob")
        bobs, kept = other.object_rows(object_id), store.history()
        for step in (lambda: store.put_back(before, expected_modified=after.modified),        # the undo
                     lambda: store.put_back(after, expected_modified=before.modified),        # a redo
                     lambda: store.take_object(object_id, expected_modified=after.modified)):  # undo of a store
            with pytest.raises(StaleEditError, match=f"object {object_id} was changed by someone else") as refused:
                step()
            assert "edit by bob" in str(refused.value) and "\n" not in str(refused.value)
            assert store.object_rows(object_id) == bobs and store.history() == kept
        # deleted by Bob since: the undo is refused by name too, and the object stays deleted
        taken = other.take_object(object_id)
        kept = store.history()
        with pytest.raises(StaleEditError, match=f"object {object_id} was deleted by someone else.*delete by bob"):
            store.put_back(before, expected_modified=bobs.modified)
        assert object_id not in [o.id for o in store.objects()] and store.history() == kept
        # an undo of a delete when the id was used again meanwhile: refused, naming who
        other.put_back(taken)
        with pytest.raises(StaleEditError, match=f"object {object_id} exists again \\(last change: put back by bob"):
            store.put_back(taken)
        assert store.object_rows(object_id) == bobs


@pytest.mark.parametrize("seed", range(3))
def test_interleaved_edits_and_undos_of_two_annotators_never_overwrite_a_later_edit(impl, store, where, seed):
    """Random edits by two annotators on a few shared objects, each keeping an undo stack of (rows before,
    rows after) as the window does; a random undo goes through exactly when nobody changed the object
    since this annotator left it (then the object is the rows before, exactly), and otherwise is refused
    by name leaving the object and the history as they were."""
    rng = np.random.default_rng(300 + seed)
    ids = [store.add_object("arc", [_vertex(rng) for _ in range(3)], "cod") for _ in range(3)]
    with impl.open(where, False) as other:
        handles = {"alice": store, "bob": other}
        for name, handle in handles.items():
            handle.annotator = name
        stacks: dict[str, list] = {"alice": [], "bob": []}
        undone = refused = 0
        for _ in range(40):
            name = str(rng.choice(sorted(handles)))
            handle, stack = handles[name], stacks[name]
            if stack and rng.random() < 0.4:
                object_id, before, after = stack.pop()
                current, kept = handle.object_rows(object_id), handle.history()
                if current.modified == after.modified:
                    handle.put_back(before, expected_modified=after.modified)
                    assert handle.object_rows(object_id) == before
                    undone += 1
                else:
                    with pytest.raises(StaleEditError, match=f"object {object_id} was changed by someone else"):
                        handle.put_back(before, expected_modified=after.modified)
                    assert handle.object_rows(object_id) == current and handle.history() == kept
                    refused += 1
            else:
                object_id = int(rng.choice(ids))
                before = handle.object_rows(object_id)
                if rng.random() < 0.5:
                    handle.update_object(object_id, notes=f"{name} {rng.integers(1e9)}")
                else:
                    handle.update_object(object_id, vertices=[_vertex(rng) for _ in range(3)])
                stack.append((object_id, before, handle.object_rows(object_id)))
        assert undone and refused


# ---------------------------------------------------------------------------------------- stale writes
def test_every_write_of_the_interface_takes_the_version_it_read():
    """Enumerates the protocol: every operation is a read, a creation (nothing to have read) or a write
    with a version parameter (``usvips.store.versions``); a new write without one fails here. Every write
    is also in the read-only test's WRITES and in STALE below (each proven refused when stale)."""
    operations = {name for name, member in vars(ProjectStore).items()
                  if (not name.startswith("_") or name in ("__enter__", "__exit__"))
                  and (callable(member) or isinstance(member, property))}
    assert READS <= operations and CREATIONS <= operations
    writes = operations - READS
    unversioned = sorted(name for name in writes - CREATIONS if not set(VERSION_PARAMETERS)
                         & set(inspect.signature(getattr(ProjectStore, name)).parameters))
    assert unversioned == [], f"writes that take no version: {unversioned}"
    assert writes <= set(WRITES), f"writes the read-only test does not try: {writes - set(WRITES)}"
    assert writes - CREATIONS == set(STALE), f"versioned writes not proven refused when stale: {writes ^ set(STALE)}"


def _stale_setup(store, folder: Path) -> None:
    store.add_pair("a")
    first = store.add_calibration("c1", {"phase": "air"}, ("a",))
    store.add_calibration("c2", {"phase": "air"})
    assert first == 1
    for _ in range(3):
        store.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)], "cod")
    store.add_instant(1, 3)
    (folder / "v0.mp4").write_bytes(b"video")
    store.add_video("v", [(folder / "v0.mp4", 10, 25.0)], [(folder / "v0.mp4", 10, 25.0)], 25.0, 10, (64, 48))


def _sha(store, stored: str) -> str:
    return next(sha for path, _, _, sha in store.media_records() if path == stored)


_CONTROL = ControlPoints(("9",), np.zeros((1, 3)))
_OBSERVED = StereoObservations(("9",), np.zeros((1, 2)), np.zeros((1, 2)))
_OBSERVED_AGAIN = StereoObservations(("9",), np.ones((1, 2)), np.ones((1, 2)))

#: each versioned write: (read its version, a colleague's change, the write with the version read)
STALE = {
    "update_object": (lambda s, f: s.object(1).modified, lambda s, f: s.update_object(1, notes="bob's"),
                      lambda s, f, v: s.update_object(1, attribute="ann's", expected_modified=v)),
    "delete_object": (lambda s, f: s.object(1).modified, lambda s, f: s.update_object(1, notes="bob's"),
                      lambda s, f, v: s.delete_object(1, expected_modified=v)),
    "take_object": (lambda s, f: s.object(1).modified, lambda s, f: s.update_object(1, notes="bob's"),
                    lambda s, f, v: s.take_object(1, expected_modified=v)),
    "put_back": (lambda s, f: (s.object_rows(1), s.object(1).modified),
                 lambda s, f: s.update_object(1, notes="bob's"),
                 lambda s, f, v: s.put_back(v[0], expected_modified=v[1])),
    "set_record": (lambda s, f: s.object(1).modified, lambda s, f: s.update_object(1, notes="bob's"),
                   lambda s, f, v: s.set_record(1, ObservationRecord(genus="Gadus"), expected_modified=v)),
    "set_review": (lambda s, f: s.object(1).modified, lambda s, f: s.update_object(1, notes="bob's"),
                   lambda s, f, v: s.set_review(1, "accepted", expected_modified=v)),
    "add_instant": (lambda s, f: s.object(2).modified, lambda s, f: s.update_object(2, notes="bob's"),
                    lambda s, f, v: s.add_instant(1, 2, expected_modified=v)),
    "remove_instant": (lambda s, f: s.object(3).modified, lambda s, f: s.update_object(3, notes="bob's"),
                       lambda s, f, v: s.remove_instant(3, expected_modified=v)),
    "accept_media": (lambda s, f: _sha(s, "v0.mp4"),
                     lambda s, f: (f.joinpath("v0.mp4").write_bytes(b"other"), s.accept_media("v0.mp4")),
                     lambda s, f, v: (f.joinpath("v0.mp4").write_bytes(b"ann's"),
                                      s.accept_media("v0.mp4", expected_sha256=v))),
    "relocate_media": (lambda s, f: _sha(s, "v0.mp4"),
                       lambda s, f: (f.joinpath("moved").mkdir(), f.joinpath("moved", "v0.mp4").write_bytes(b"video"),
                                     s.relocate_media("v0.mp4", f / "moved" / "v0.mp4")),
                       lambda s, f, v: s.relocate_media("v0.mp4", f / "v0.mp4", expected_sha256=v)),
    "set_campaign": (lambda s, f: s.campaign(), lambda s, f: s.set_campaign(Campaign("2024-03_bob_stereo-BRUVs")),
                     lambda s, f, v: s.set_campaign(Campaign("2024-03_ann_stereo-BRUVs"), expected=v)),
    "set_deployment": (lambda s, f: s.deployments().get(""), lambda s, f: s.set_deployment(Deployment(opcode="BOB")),
                       lambda s, f, v: s.set_deployment(Deployment(opcode="ANN"), expected=v)),
    "set_georeference": (lambda s, f: s.georeference(),
                         lambda s, f: s.set_georeference(Georeference(-33.8, 151.2, 12.0, 45.0)),
                         lambda s, f, v: s.set_georeference(Georeference(-30.0, 150.0, 10.0, 0.0), expected=v)),
    "set_species_list": (lambda s, f: s.species_list(),
                         lambda s, f: s.set_species_list([Species("Gadidae", "Gadus", "morhua")]),
                         lambda s, f, v: s.set_species_list([Species("Sparidae", "Pagrus", "auratus")], expected=v)),
    "set_control": (lambda s, f: s.control(), lambda s, f: s.set_control(_CONTROL),
                    lambda s, f, v: s.set_control(ControlPoints(("8",), np.ones((1, 3))), expected=v)),
    "add_control_observations": (lambda s, f: s.control_observations("check", "a"),
                                 lambda s, f: s.add_control_observations(_OBSERVED, "check", "a"),
                                 lambda s, f, v: s.add_control_observations(_OBSERVED_AGAIN, "check", "a",
                                                                            replace=True, expected=v)),
    "activate_calibration": (lambda s, f: s.active_calibration("a"), lambda s, f: s.activate_calibration("a", 2),
                             lambda s, f, v: s.activate_calibration("a", 1, expected=v)),
    "set_video_offset": (lambda s, f: s.video("v").offset_frames, lambda s, f: s.set_video_offset("v", 2),
                         lambda s, f, v: s.set_video_offset("v", 3, expected=v)),
    "set_enhancement": (lambda s, f: s.enhancement("k"), lambda s, f: s.set_enhancement("k", '{"bob": 1}'),
                        lambda s, f, v: s.set_enhancement("k", '{"ann": 1}', expected=v)),
    "set_draft": (lambda s, f: s.draft("d"), lambda s, f: s.set_draft("d", "bob's"),
                  lambda s, f, v: s.set_draft("d", "ann's", expected=v)),
    "set_pointing_estimates": (lambda s, f: s.pointing_estimates(),
                               lambda s, f: s.set_pointing_estimates([{"annotator": "bob", "sigma_px": 0.6}]),
                               lambda s, f, v: s.set_pointing_estimates([{"annotator": "ann", "sigma_px": 0.4}],
                                                                        expected=v)),
}


def _everything(store) -> str:
    """What a refused write must leave as it was (every read of the interface that takes no argument)."""
    return repr((store.pairs(), store.objects(), store.records(), store.reviews(), store.instant_links(),
                 store.media_records(), store.campaign(), store.deployments(), store.georeference(),
                 store.species_list(), store.control(), store.control_observations("check", "a"),
                 store.active_calibration("a"), store.videos(), store.enhancement("k"), store.draft("d"),
                 store.pointing_estimates(), [(h.change, h.annotator, h.old, h.new) for h in store.history()]))


@pytest.mark.parametrize("write", sorted(STALE))
def test_a_write_made_on_what_a_colleague_changed_since_is_refused_by_name_and_changes_nothing(impl, store,
                                                                                               where, write):
    """Two handles on one store (two annotators): ann reads, bob changes the same thing, ann's write with
    the version she read is refused naming bob and when, and bob's change stays (0 edits lost); the same
    write with the version as it now is goes through."""
    folder = where.parent
    _stale_setup(store, folder)
    read, change, write_with = STALE[write]
    store.annotator = "ann"
    with impl.open(where, False) as bob:
        bob.annotator = "bob"
        version = read(store, folder)
        change(bob, folder)
        before = _everything(store)
        with pytest.raises(StaleEditError) as refused:
            write_with(store, folder, version)
        message = str(refused.value)
        assert "bob" in message and "\n" not in message and "nothing was changed" in message
        assert _everything(store) == before
        assert _everything(bob) == before
    if write == "relocate_media":
        return  # the file is where bob put it: relocating it back is another write, not this one again
    write_with(store, folder, read(store, folder))  # read afresh: the write goes through
    assert _everything(store) != before


def test_the_pointing_estimates_round_trip_and_a_reader_cannot_change_them(impl, store, where):
    assert store.pointing_estimates() == []
    records = [{"annotator": "Ana Ng", "source": "hand click", "sigma_px": 0.42, "low_px": 0.38, "high_px": 0.47,
                "note": "Ünïcode 'quotes'", "bias_px": None, "n": 36},
               {"annotator": "", "source": "tracked", "sigma_px": 0.3, "bias_px": [0.1, -0.2], "n": 9}]
    store.set_pointing_estimates(records)
    assert store.pointing_estimates() == records
    store.close()
    reader = impl.open(where, True)
    try:
        assert reader.pointing_estimates() == records  # kept, seen by another handle
        before = impl.snapshot(where)
        with pytest.raises(ProjectError):
            reader.set_pointing_estimates(records[:1])
        assert impl.snapshot(where) == before
    finally:
        reader.close()
    writer = impl.open(where, False)
    try:
        writer.set_pointing_estimates([])
        assert writer.pointing_estimates() == []
    finally:
        writer.close()


# ------------------------------------------------------------------------------------------ the change feed
def test_the_change_feed_shows_another_handles_adds_edits_and_deletes_in_order(impl, store, where):
    rng = np.random.default_rng(51)
    assert store.last_change_id() == 0 and store.changes_since(0) == []
    mine = store.add_object("point", [_vertex(rng)], "mine")
    seen = store.last_change_id()
    assert seen > 0 and [e.object_id for e in store.changes_since(0)] == [mine]
    with impl.open(where, False) as other:
        other.annotator = "bob"
        made = other.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
        other.update_object(mine, notes="seen by bob")
        other.delete_object(made)
    changes = store.changes_since(seen)
    assert [(e.change, e.object_id, e.annotator) for e in changes] == [
        ("add", made, "bob"), ("edit", mine, "bob"), ("delete", made, "bob")]
    assert [e.id for e in changes] == sorted(e.id for e in changes) and changes[0].id > seen
    assert store.last_change_id() == changes[-1].id and store.changes_since(changes[-1].id) == []
    assert store.changes_since(seen, limit=2) == changes[:2]
    assert store.changes_since(0) == store.history()


def test_a_watch_wakes_when_another_handle_commits_and_not_for_an_uncommitted_write(impl, store, where):
    rng = np.random.default_rng(52)
    watch = store.watch()
    try:
        assert watch.wait(0.0) is False  # nothing changed since it was made
        with impl.open(where, False) as other:
            with other.transaction():
                other.add_object("point", [_vertex(rng)], "pending")
                assert watch.wait(0.5) is False  # not committed yet: nothing to read
            assert watch.wait(30.0) is True  # a bound, not a wait: it returns at the commit's notice
            seen = store.last_change_id()
            done = threading.Event()
            woke: list[bool] = []

            def waiter() -> None:  # a background thread, as the window uses it
                woke.append(watch.wait(30.0))
                done.set()

            thread = threading.Thread(target=waiter)
            thread.start()
            other.add_object("point", [_vertex(rng)], "from the other handle")
            assert done.wait(30.0) and woke == [True]
            thread.join()
        assert [e.new["attribute"] for e in store.changes_since(seen)] == ["from the other handle"]
    finally:
        watch.close()
    watch.close()  # closing twice is no error
    assert watch.wait(0.1) is False


def test_media_are_located_through_the_store_whether_or_not_they_are_there(store, tmp_path):
    plan = _images(tmp_path, 2)
    store.add_image_pairs(plan)
    stored = [(pair.left, pair.right) for pair in store.pairs()]
    for (_label, left, right), (stored_left, stored_right) in zip(plan, stored, strict=True):
        assert store.media_location(stored_left) == left.resolve() == store.image_path(stored_left)
        assert store.media_location(stored_right) == right.resolve()
    plan[1][1].unlink()  # gone: still located (where it should be), no longer an image
    assert store.media_location(stored[1][0]) == plan[1][1].resolve()
    with pytest.raises(ProjectError, match="missing"):
        store.image_path(stored[1][0])


def test_an_object_id_is_never_used_twice_not_even_after_the_newest_object_is_deleted(store):
    """The id of a deleted object — the newest one included, which SQLite's rowids handed out again — is
    never given to another: history rows and reviews of one id belong to one object."""
    rng = np.random.default_rng(15)
    first = store.add_object("point", [_vertex(rng)], "first")
    newest = store.add_object("point", [_vertex(rng)], "newest")
    store.delete_object(newest, expected_modified=store.object(newest).modified)
    again = store.add_object("point", [_vertex(rng)], "again")
    assert again > newest > first
    batch = store.add_objects([("point", [_vertex(rng)], f"b{k}", "", "") for k in range(3)])
    assert batch == [again + 1, again + 2, again + 3]
    assert [h.change for h in store.history(newest)] == ["add", "delete"]
    assert [h.change for h in store.history(again)] == ["add"]


def test_two_writers_adding_at_once_never_get_the_same_id(impl, store, where):
    """Two handles adding objects at the same time (each in its own thread, as two windows or processes)
    reserve different ids: every add succeeds and no id is handed out twice."""
    import threading

    rng = np.random.default_rng(16)
    vertices = [[_vertex(rng)] for _ in range(40)]
    got: dict[str, list[int]] = {}
    failures: list[BaseException] = []

    def writer(name: str, part: list) -> None:
        try:
            with impl.open(where) as handle:
                got[name] = [handle.add_object("point", v, name) for v in part]
        except BaseException as error:  # noqa: BLE001 - reported by the assertion below
            failures.append(error)

    threads = [threading.Thread(target=writer, args=(name, vertices[k::2])) for k, name in enumerate(("a", "b"))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(120)
    assert not failures, failures
    ids = got["a"] + got["b"]
    assert len(ids) == len(set(ids)) == 40
    assert sorted(o.id for o in store.objects()) == sorted(ids)
