"""``Project.objects_with_ids``: the objects of some ids by one query, the same as a full listing has."""

import numpy as np
import pytest

from usvips.store import Project, ProjectError
from usvips.store.project import Vertex


def _vertex(rng) -> Vertex:
    xyz = tuple(float(v) for v in rng.normal(size=3))
    return Vertex(*rng.uniform(0, 600, size=4), xyz, np.eye(3) * rng.uniform(1e-7, 1e-5))


def test_objects_by_id_match_the_full_listing(tmp_path):
    rng = np.random.default_rng(3)
    project = Project.create(tmp_path / "p.usvips")
    try:
        kinds = ("point", "length", "polygon")
        counts = {"point": 1, "length": 2, "polygon": 4}
        ids = project.add_objects([(kind, [_vertex(rng) for _ in range(counts[kind])], f"a{i}", "", "test")
                                   for i, kind in enumerate(rng.choice(kinds, size=1200))])
        project.delete_object(ids[7])
        everything = {o.id: o for o in project.objects()}
        wanted = list(rng.choice(ids, size=700, replace=False)) + [ids[7], 10**9, ids[0], ids[0]]
        found = project.objects_with_ids(wanted)  # more than SQLite's bound-parameter chunk, unsorted
        expected = sorted({int(i) for i in wanted} & set(everything))
        assert [o.id for o in found] == expected  # ids not stored are simply absent; each once, in id order
        for stored in found:
            full = everything[stored.id]
            assert (stored.kind, stored.attribute, len(stored.vertices)) == \
                (full.kind, full.attribute, len(full.vertices))
            for a, b in zip(stored.vertices, full.vertices, strict=True):
                assert a.xyz == b.xyz and np.array_equal(a.covariance, b.covariance)
        assert project.objects_with_ids([]) == []
    finally:
        project.close()


def test_covariances_read_at_once_are_each_vertex_s_own_and_a_damaged_one_is_named(tmp_path):
    """The covariances of a listing are parsed together (one JSON text for the lot): each vertex still gets
    exactly its own 3 × 3 (vertices without one: None, mixed among them), and one damaged covariance among
    many — valid JSON of the wrong shape, or text that would shift its neighbours if joined — is named by its
    object, as when they were parsed one by one."""
    rng = np.random.default_rng(11)
    with Project.create(tmp_path / "p.usvips") as project:
        vertices = [[_vertex(rng) if rng.random() < 0.8 else Vertex(*rng.uniform(0, 600, size=4))
                     for _ in range(2)] for _ in range(300)]
        ids = project.add_objects([("length", pair, "", "", "test") for pair in vertices])
        for stored, given in zip(project.objects(), vertices, strict=True):
            for read, written in zip(stored.vertices, given, strict=True):
                if written.covariance is None:
                    assert read.covariance is None
                else:
                    assert read.covariance.shape == (3, 3) and np.array_equal(read.covariance, written.covariance)
        victim = int(rng.choice(ids[1:-1]))
        for damage in ("[1, 2, 3, 4, 5, 6, 7, 8]", "[1, 2, 3, 4, 5, 6, 7, 8, 9], [1, 2, 3, 4, 5, 6, 7, 8, 9]",
                       '["a", 2, 3, 4, 5, 6, 7, 8, 9]'):
            project._db.execute("UPDATE vertices SET covariance = ? WHERE object_id = ? AND idx = 0",
                                (damage, victim))
            with pytest.raises(ProjectError, match=f"object {victim}: a stored covariance is damaged"):
                project.objects()
