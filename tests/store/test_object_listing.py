"""``Project.objects_with_ids``: the objects of some ids by one query, the same as a full listing has."""

import numpy as np

from usvips.store import Project
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
