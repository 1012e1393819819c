"""The detection benchmark rows (no timed assertions: the rows' shape and their verdicts)."""

from usvips.bench import areas, detection, detection_frame


def test_the_detection_area_is_found_and_its_rows_state_their_verdicts():
    assert areas()["detection"] == "usvips.bench.detection"
    pairing, decoding, refining, frame = detection.benchmarks(0.01)
    assert pairing["n"] == 4 and pairing["pairs"] == 4 and pairing["target"] == 1.0
    assert pairing["met"] == (pairing["ratio"] <= 1.0) and pairing["ours_s"] > 0 and pairing["baseline_s"] > 0
    assert decoding["n"] == 8400 and decoding["target_s"] == detection.DECODE_TARGET_S
    assert decoding["met"] == (decoding["ours_s"] <= decoding["target_s"]) and 0 < decoding["detections"] <= 300
    assert refining["n"] == 4 and refining["target_s"] == detection.REFINE_TARGET_S
    assert refining["met"] == (refining["ours_s"] <= refining["target_s"]) and refining["ours_s"] > 0
    assert frame["n"] == 1 and frame["target_s"] == detection_frame.TARGET_S == 0.2 and frame["threads"] >= 1
    assert frame["met"] == (frame["ours_s"] <= 0.2) and frame["fps_cpu"] == round(1 / frame["ours_s"], 2)
    assert set(frame["stages_cpu_s"]) == {*detection_frame.STAGES, "other"} == set(frame["stages_wall_s"])
    assert frame["stages_cpu_s"]["network"] > 0 and frame["stages_cpu_s"]["pairing"] > 0
    # the rendered frame holds fish the shipped model finds and pairs, so pairing and refinement do real work
    assert frame["fish_to_find"] >= 1 and frame["pairs"] >= 1 and frame["detections_left"] >= frame["pairs"]


def test_the_baseline_computes_the_same_costs_as_the_batch():
    import numpy as np

    from usvips.core.detection.stereo import pairing_costs

    rig = detection._rig()
    left, right = detection._frame(rig, 5, np.random.default_rng(1))
    np.testing.assert_allclose(detection._costs_one_curve_at_a_time(rig, left, right), pairing_costs(left, right, rig),
                               rtol=1e-9, atol=1e-9)


def test_the_stage_timed_pass_computes_what_detect_frame_computes():
    from usvips.app.detection_model import bundled_model_path, load_model
    from usvips.app.detection_service import detect_frame

    model = load_model(bundled_model_path())
    detector = model.make_detector()
    (left, right, geometry, _), = detection_frame.rendered_frames(1)
    plain = detect_frame(left, right, geometry, model, detector)
    clock = detection_frame._Clock()
    with detection_frame._service_stages_timed(clock):
        timed = detect_frame(left, right, geometry, model, detection_frame.StageTimedDetector(detector, clock))
    assert timed[1:] == plain[1:] and [p for p, *_ in timed[0]] == [p for p, *_ in plain[0]]
    assert all(clock.wall[stage] > 0 for stage in ("letterbox", "network", "decode", "pairing", "refinement"))
    assert (clock.wall["length"] > 0) == bool(plain[0])
