"""The row of colleagues' changes seen live (area ``window_live``): found without registration, it names
what it timed on the server and on the SQLite file, its baseline and the promise (no timed assertion:
its timing is the bench's business). The suite's own PostgreSQL server stands in for the bench's."""

from tests.store.conftest import postgres_server  # noqa: F401 - the suite's real server
from usvips import bench
from usvips.gui.qt import bench_live


def test_the_live_row_times_a_colleagues_changes_on_both_backends(postgres_server, monkeypatch):  # noqa: F811
    assert bench.areas()["window_live"] == "usvips.gui.qt.bench_live"
    monkeypatch.setenv("USVIPS_BENCH_POSTGRES", postgres_server)
    row = bench_live.live_row(scale=0.1)  # 50 objects, one addition and one edit per backend
    assert row["n"] == 50 and "a colleague's change shown" in row["name"]
    assert len(row["server_s"]) == len(row["file_s"]) == 2 and row["baseline"] == "the same on the SQLite file"
    assert row["ours_s"] == max(row["server_s"]) and row["baseline_s"] == max(row["file_s"])
    assert all(0 < t < bench_live.GIVE_UP_S for t in row["server_s"] + row["file_s"])  # every change was shown
    assert row["target_s"] == bench_live.TARGET_S == 2.0
    assert row["met"] == (max(row["server_s"] + row["file_s"]) <= 2.0)
