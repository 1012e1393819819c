"""``usvips detect PROJECT --video`` end to end on a short rendered stereo video of two fish swimming through
a flat-port housing (tests/core/test_tracking.py's rig and floor), with a tiny ONNX model that reads which
frame and side it is shown from a patch painted in the image's corner (a frame code, as burnt-in frame
numbers are) and gives that frame's true keypoints: the model's proposals are paired through the housing,
refined along the curve, stored, and each fish's proposals over the frames joined as ONE object with its
other frames as instants — the survey counts two fish, each length combined over its instants and within
3σ of the truth."""

import numpy as np

from tests.app.detection_scenes import model_table
from tests.core.test_tracking import H, W, floor_seen, rig
from usvips.app.object_instants import survey_objects
from usvips.app.project_figures import evaluate, measurement_input
from usvips.app.video_project import add_video
from usvips.cli import main
from usvips.core.stereo_calibration import StereoCalibration
from usvips.core.synth.swimming import SwimmingFish
from usvips.io.calibration_file import calibration_to_dict
from usvips.io.video_writer import encode_video
from usvips.store import Project

FRAMES, FPS, SIZE = 8, 25.0, 320
PATCH = 24  # px: the corner patch holding the frame code
CODES = {"left": [20 + 12 * i for i in range(FRAMES)], "right": [130 + 12 * i for i in range(FRAMES)]}


def _render(stereo, fishes) -> dict[str, list[np.ndarray]]:
    """Each side's frames (grey as RGB): the fish before the textured floor, a frame code in the corner."""
    out = {}
    for side, camera in (("left", stereo.left), ("right", stereo.right)):
        bundle, floor = floor_seen(camera)
        frames = []
        for i in range(FRAMES):
            nearest, grey = np.full(len(floor), np.inf), floor.copy()
            for fish in fishes:
                depth, value = fish.at(i / FPS).hit(bundle.origins, bundle.directions)
                closer = depth < nearest
                nearest, grey = np.where(closer, depth, nearest), np.where(closer, value, grey)
            image = np.clip(np.rint(grey), 0, 255).astype(np.uint8).reshape(H, W)
            image[:PATCH, :PATCH] = CODES[side][i]
            frames.append(np.repeat(image[:, :, None], 3, axis=2))
        out[side] = frames
    return out


def lookup_model(tables: np.ndarray, codes: np.ndarray) -> bytes:
    """An ONNX model giving ``tables[k]`` (each [1, C, R]) when the mean of the input's corner patch
    (letterboxed 320 × 240 → 320 × 320: rows 40 on) is within 3/8 of the codes' spacing of ``codes[k]`` / 255
    (the video's coding moves it a little): a weight per code, one there and zero half-way to the next,
    then a MatMul with the tables."""
    from onnx import TensorProto, helper, numpy_helper

    shape = tables.shape[1:]
    flat = tables.reshape(len(tables), -1).astype(np.float32)
    centres = (np.asarray(codes, np.float32) / 255.0)
    half = np.float32(np.min(np.diff(np.sort(centres))) / 2)
    steep = np.float32(4.0 / half)
    nodes = [helper.make_node("Slice", ["images", "starts", "ends", "axes"], ["patch"]),
             helper.make_node("ReduceMean", ["patch"], ["key"], keepdims=0),
             helper.make_node("Sub", ["key", "centres"], ["offset"]),
             helper.make_node("Abs", ["offset"], ["distance"]),
             helper.make_node("Sub", ["half", "distance"], ["margin"]),
             helper.make_node("Mul", ["margin", "steep"], ["raw"]),
             helper.make_node("Clip", ["raw", "zero", "one"], ["weights"]),
             helper.make_node("Reshape", ["weights", "row"], ["weight_row"]),
             helper.make_node("MatMul", ["weight_row", "tables"], ["picked"]),
             helper.make_node("Reshape", ["picked", "shape"], ["output0"])]
    constants = {"starts": np.array([44, 4], np.int64), "ends": np.array([40 + PATCH - 4, PATCH - 4], np.int64),
                 "axes": np.array([2, 3], np.int64), "centres": centres, "half": np.array(half, np.float32),
                 "steep": np.array(steep, np.float32),
                 "one": np.array(1.0, np.float32), "zero": np.array(0.0, np.float32),
                 "row": np.array([1, len(centres)], np.int64), "tables": flat,
                 "shape": np.array([1, *shape], np.int64)}
    graph = helper.make_graph(nodes, "frame-lookup-yolo-pose",
                              [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, SIZE, SIZE])],
                              [helper.make_tensor_value_info("output0", TensorProto.FLOAT, [1, *shape])],
                              [numpy_helper.from_array(v, k) for k, v in constants.items()])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    return model.SerializeToString()


def _nearest(fishes, vertex) -> int:
    """Which fish's true snout, at the vertex's frame, the vertex's 3-D point is nearest."""
    return int(np.argmin([np.linalg.norm(f.snout_fork(vertex.frame_left / FPS)[0] - vertex.xyz) for f in fishes]))


def test_detect_on_a_rendered_video_stores_each_fish_once_with_its_frames_as_instants(tmp_path, capsys):
    stereo = rig("flat-port")
    # two fish swimming opposite ways across both views, 1.1 and 1.3 m away
    fishes = [SwimmingFish(start=(0.25, 0.1, -1.1), heading=(1.0, 0.0, 0.05), length=0.22, speed=0.3, bend=0.0,
                           seed=1),
              SwimmingFish(start=(0.2, -0.1, -1.3), heading=(-1.0, 0.0, 0.0), length=0.26, speed=0.25, bend=0.0,
                           seed=2)]
    frames = _render(stereo, fishes)
    for side in ("left", "right"):
        encode_video(tmp_path / f"{side}.mkv", frames[side], FPS, "ffv1")
    truth = {side: [] for side in ("left", "right")}
    for i in range(FRAMES):
        bodies = np.array([f.snout_fork(i / FPS) for f in fishes])
        for side, camera in (("left", stereo.left), ("right", stereo.right)):
            pixels = np.array([camera.project(b).pixels for b in bodies])
            assert np.all((pixels > PATCH + 4) & (pixels < np.array([W, H]) - 4))  # both fish in view
            truth[side].append(model_table(pixels, SIZE, SIZE, image=(W, H)))
    tables = np.concatenate([np.concatenate(truth["left"]), np.concatenate(truth["right"])])
    (tmp_path / "lookup.onnx").write_bytes(lookup_model(tables, CODES["left"] + CODES["right"]))
    description = tmp_path / "lookup.toml"
    description.write_text(f'[model]\nfile = "lookup.onnx"\nfamily = "yolo-pose"\ninput_width = {SIZE}\n'
                           f'input_height = {SIZE}\n\n[output]\nclasses = ["fish"]\nkeypoints = ["snout", "fork"]\n'
                           '\n[keypoint_sigma]\nbasis = "test frames"\npx = {snout = 0.5, fork = 0.5}\n')
    project = tmp_path / "survey.usvips"
    with Project.create(project) as opened:
        add_video(opened, [tmp_path / "left.mkv"], [tmp_path / "right.mkv"], "drop")
        calibration = StereoCalibration.from_cameras(stereo.left, stereo.right, "water", 0.05)
        opened.add_calibration("cal", calibration_to_dict(calibration), ("drop",))

    # refined along the curve, as the window does: the model's keypoints are the truth, and the matches that
    # would move them beyond 3√2 x their 0.5 px sigma are refused (taken, they spoil the links; fails without).
    # A pair with such a refusal gets no length (its keypoints are not shown to be one point) and is not joined;
    # the chain bridges a frame without one.
    assert main(["detect", str(project), "--video", "drop", "--model", str(description)]) == 0
    out = capsys.readouterr().out
    unmeasured = out.count("are not one point")
    assert unmeasured <= FRAMES // 2  # on these sharp frames most pairs keep their length
    joined = 2 * (FRAMES - 1) - unmeasured
    assert out.count("instant of object") == joined
    assert f"2 fish seen on several frames joined into objects with {joined} further instant(s)" in out
    with Project.open(project) as opened:
        assert len(opened.objects()) == 2 * FRAMES
        fish = survey_objects(opened)
        assert len(fish) == 2 + unmeasured  # two fish, and the proposals without a length on their own
        fish = [stored for stored in fish if stored.vertices[0].xyz is not None]
        assert len(fish) == 2 and sum(1 + len(opened.instants(f.id)) for f in fish) == 2 * FRAMES - unmeasured
        for stored in fish:
            instants = opened.instants(stored.id)
            frames = [stored.vertices[0].frame_left] + [opened.object(i).vertices[0].frame_left for i in instants]
            assert frames == sorted(set(frames)) and set(frames) <= set(range(FRAMES))
            nearest = {_nearest(fishes, o.vertices[0]) for o in [stored, *map(opened.object, instants)]}
            assert len(nearest) == 1  # one fish's proposals only
            nearest = nearest.pop()
            combined = evaluate(measurement_input(opened, stored))
            assert combined.instant_count == 1 + len(instants)
            assert abs(combined.main.value - fishes[nearest].length) < 3 * combined.main.sigma
