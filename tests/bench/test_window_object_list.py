"""The object list's scrolling row (area ``window_object_list``): found without registration, it names
what it timed, its baseline and the promise (no timed assertion: its timing is the bench's business)."""

from usvips import bench
from usvips.gui.qt import bench_object_list


def test_the_scrolling_row_names_its_steps_baseline_and_promise():
    assert bench.areas()["window_object_list"] == "usvips.gui.qt.bench_object_list"
    row = bench_object_list.scroll_row(scale=0.003)  # 300 objects
    assert row["n"] == row["rows_listed"] == 300 and "scroll the object list" in row["name"]
    assert row["target_s"] == bench_object_list.FREEZE_TARGET_S == 0.1 and row["met"] == (row["ours_s"] <= 0.1)
    assert row["steps"] > bench_object_list.PAGES and 0 < row["median_s"] <= row["ours_s"]
    assert 0 < row["worst_gui_cpu_s"] and row["baseline_s"] > 0 and row["rows_on_screen"] > 5
    assert 0 < row["figures_computed"] <= 300


def test_the_sort_row_computes_every_figure_and_names_its_freeze_and_promise():
    row = bench_object_list.sort_row(scale=0.06)  # 1,200 objects: above the list's eager size
    assert row["n"] == 1200 and "sort the object list of 1,200 objects by length" in row["name"]
    assert row["figures_known_before"] < 1200 == row["figures_known_after"]  # every figure computed by the sort
    assert row["target_s"] == bench_object_list.FREEZE_TARGET_S and row["met"] == (row["ours_s"] <= 0.1)
    assert row["ours_s"] > 0 and row["baseline_s"] > 0 and row["ticks"] > 0 and row["sort_s"] > 0
