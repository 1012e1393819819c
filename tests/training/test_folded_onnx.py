"""The shipped fish model's convolutions read back from its ONNX file (BatchNorms folded in), in graph
order, to continue training from; a file that is not ONNX, keeps BatchNorm nodes or does not fit the
network's layout is refused in one line."""

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from usvips.core.errors import UsvipsError
from usvips.locations import resources_folder
from usvips.training.folded_onnx import folded_convolutions, matched

MODEL = resources_folder() / "models" / "fish-centre-pose.onnx"


def test_the_shipped_model_gives_its_fourteen_convolutions_in_the_order_they_run():
    convolutions = folded_convolutions(MODEL)
    assert [c.weight.shape[:2] for c in convolutions] == [
        (16, 3), (24, 16), (24, 24), (40, 24), (40, 40), (64, 40), (64, 64), (96, 64), (96, 96),
        (64, 160), (40, 104), (32, 64), (32, 32), (21, 32)]
    assert [c.stride for c in convolutions] == [(2, 2), (2, 2), (1, 1), (2, 2), (1, 1), (2, 2), (1, 1), (2, 2),
                                                (1, 1), (1, 1), (1, 1), (1, 1), (1, 1), (1, 1)]
    assert convolutions[-1].weight.shape[2:] == (1, 1) and convolutions[-1].padding == (0, 0, 0, 0)
    assert all(c.padding == (1, 1, 1, 1) and c.weight.shape[2:] == (3, 3) for c in convolutions[:-1])
    assert all(c.bias.shape == (c.weight.shape[0],) and np.any(c.bias != 0) for c in convolutions)
    # the head's last convolution is stored under its module's name, the folded ones under the exporter's
    stored = {i.name: numpy_helper.to_array(i) for i in onnx.load(str(MODEL)).graph.initializer}
    np.testing.assert_array_equal(convolutions[-1].weight, stored["head.1.weight"])
    assert matched(MODEL, convolutions, [c.layout() for c in convolutions]) is convolutions


def test_a_model_that_does_not_fit_the_layout_is_refused_naming_the_first_misfit():
    convolutions = folded_convolutions(MODEL)
    layouts = [c.layout() for c in convolutions]
    strided = [*layouts[:3], (layouts[3][0], (1, 1), *layouts[3][2:]), *layouts[4:]]
    with pytest.raises(UsvipsError, match=r"convolution 4 is weight 40x24x3x3, stride \(2, 2\).*the fish model's is "
                                          r"weight 40x24x3x3, stride \(1, 1\)"):
        matched(MODEL, convolutions, strided)
    with pytest.raises(UsvipsError, match="14 convolutions, the fish model has 13"):
        matched(MODEL, convolutions, layouts[:-1])
    wider = [((32, 3, 3, 3), *layouts[0][1:]), *layouts[1:]]
    with pytest.raises(UsvipsError, match="convolution 1 is weight 16x3x3x3"):
        matched(MODEL, convolutions, wider)


def test_a_file_that_is_not_a_folded_onnx_model_is_refused_in_one_line(tmp_path):
    garbage = tmp_path / "garbage.onnx"
    garbage.write_bytes(b"\x08\x07not a model at all" * 50)
    batch_norm = tmp_path / "batch_norm.onnx"
    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 2, 4, 4])
    y = helper.make_tensor_value_info("y", TensorProto.FLOAT, [1, 2, 4, 4])
    weights = [numpy_helper.from_array(np.ones(2, np.float32), name) for name in ("s", "b", "m", "v")]
    graph = helper.make_graph([helper.make_node("BatchNormalization", ["x", "s", "b", "m", "v"], ["y"])],
                              "bn", [x], [y], weights)
    onnx.save(helper.make_model(graph), str(batch_norm))
    for path, words in ((tmp_path / "absent.onnx", "no such file"), (garbage, "not an ONNX model"),
                        (batch_norm, "holds BatchNormalization nodes")):
        with pytest.raises(UsvipsError) as caught:
            folded_convolutions(path)
        assert str(caught.value).startswith(str(path)) and words in str(caught.value)
        assert "\n" not in str(caught.value)
