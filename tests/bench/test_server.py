"""The server benchmark rows (no timed assertions: the rows' shape and their verdicts), against a
PostgreSQL the bench starts itself."""

from usvips.bench import BENCH_MODULES, server


def test_the_server_rows_compare_with_sqlite_on_the_same_data_and_judge_their_targets():
    assert "server" in BENCH_MODULES
    rows = list(server.benchmarks(0.01))
    assert len(rows) == 3
    listing, store, opening = rows
    assert listing["n"] == 100 and listing["target"] == server.LIST_TARGET
    assert listing["met"] == (listing["ratio"] <= server.LIST_TARGET) and listing["baseline_s"] > 0
    assert store["target_s"] == server.STORE_TARGET_S and store["met"] == (store["ours_s"] <= store["target_s"])
    assert opening["n"] == 100 and opening["met"] == (opening["ours_s"] <= server.OPEN_TARGET_S)
    assert all("SQLite" in row["baseline"] for row in rows)
