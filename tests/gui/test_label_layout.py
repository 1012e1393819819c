"""Object labels placed so that none covers another."""

import numpy as np

from usvips.gui.label_layout import keep_inside, stack_labels


def _boxes(anchors, sizes, offsets):
    return [(x, y - h + o, x + w, y + o) for (x, y), (w, h), o in zip(anchors, sizes, offsets, strict=True)]


def _overlaps(boxes):
    return [(i, j) for i in range(len(boxes)) for j in range(i + 1, len(boxes))
            if boxes[i][0] < boxes[j][2] and boxes[j][0] < boxes[i][2] and boxes[i][1] < boxes[j][3]
            and boxes[j][1] < boxes[i][3]]


def test_labels_apart_stay_where_they_are():
    anchors = np.array([[10.0, 100.0], [400.0, 100.0], [10.0, 300.0]])
    assert np.all(stack_labels(anchors, np.array([[120.0, 16.0]] * 3)) == 0)


def test_two_fish_side_by_side_get_labels_that_do_not_overlap():
    anchors = np.array([[100.0, 200.0], [130.0, 205.0]])
    sizes = np.array([[150.0, 16.0], [180.0, 16.0]])
    offsets = stack_labels(anchors, sizes)
    assert offsets[0] == 0 and offsets[1] != 0 and not _overlaps(_boxes(anchors, sizes, offsets))


def test_many_random_crowded_labels_never_overlap_and_move_little():
    rng = np.random.default_rng(5)
    for _ in range(200):
        n = int(rng.integers(2, 9))
        anchors = rng.uniform(0, 300, (n, 2))
        sizes = np.column_stack([rng.uniform(40, 200, n), np.full(n, 16.0)])
        offsets = stack_labels(anchors, sizes)
        assert not _overlaps(_boxes(anchors, sizes, offsets))
        assert np.all(np.abs(offsets) <= (n - 1) * 18.0 + 1e-9)


def test_a_label_running_past_the_right_edge_moves_left_to_be_read_whole():
    lefts, widths = np.array([10.0, 380.0, 450.0, 5.0]), np.array([100.0, 150.0, 100.0, 700.0])
    shifts = keep_inside(lefts, widths, 500.0)
    assert shifts[0] == 0 and shifts[1] == -30.0 and shifts[2] == -50.0  # right edges now at 500
    assert shifts[3] == -5.0  # wider than the view: starts at its left edge, never beyond


def test_the_pane_draws_a_label_near_its_right_edge_inside_the_view(qtbot):
    """Seen at 1366 × 768: "2 Pagrus aura" cut off by the left image's edge."""
    from usvips.gui.qt.pane import StereoPane

    pane = StereoPane("left")
    qtbot.addWidget(pane)
    pane.resize(500, 400)
    pane.show()
    qtbot.waitExposed(pane)
    pane.set_image(np.zeros((300, 400), dtype=np.uint8))
    pane.fit()
    qtbot.wait(100)
    pane.set_selection_marks(np.zeros((0, 2)), np.zeros((0, 2)), [("2 Pagrus auratus", (395.0, 150.0), False)], 1)
    (label,) = pane.labels
    right, box = pane.graphics.viewport().width(), label.screen_rect(pane.graphics)
    assert box.right() <= right + 1.0, (box, right)
    assert box.width() > 50
