"""The detection benchmark rows (no timed assertions: the rows' shape and their verdicts)."""

from usvips.bench import areas, detection


def test_the_detection_area_is_found_and_its_rows_state_their_verdicts():
    assert areas()["detection"] == "usvips.bench.detection"
    pairing, decoding, refining = detection.benchmarks(0.2)
    assert pairing["n"] == 4 and pairing["pairs"] == 4 and pairing["target"] == 1.0
    assert pairing["met"] == (pairing["ratio"] <= 1.0) and pairing["ours_s"] > 0 and pairing["baseline_s"] > 0
    assert decoding["n"] == 8400 and decoding["target_s"] == detection.DECODE_TARGET_S
    assert decoding["met"] == (decoding["ours_s"] <= decoding["target_s"]) and 0 < decoding["detections"] <= 300
    assert refining["n"] == 4 and refining["target_s"] == detection.REFINE_TARGET_S
    assert refining["met"] == (refining["ours_s"] <= refining["target_s"]) and refining["ours_s"] > 0


def test_the_baseline_computes_the_same_costs_as_the_batch():
    import numpy as np

    from usvips.core.detection.stereo import pairing_costs

    rig = detection._rig()
    left, right = detection._frame(rig, 5, np.random.default_rng(1))
    np.testing.assert_allclose(detection._costs_one_curve_at_a_time(rig, left, right), pairing_costs(left, right, rig),
                               rtol=1e-9, atol=1e-9)
