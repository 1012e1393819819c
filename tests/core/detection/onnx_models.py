"""Tiny ONNX models built in the tests (the test extra's ``onnx`` writes the graph): the network ignores its
input's values and gives a fixed output table, so that the runner's whole path — reading the bytes,
letterboxing, normalising, running OpenCV's DNN module, decoding — meets known truth."""

from __future__ import annotations

import numpy as np
from onnx import TensorProto, helper, numpy_helper


def constant_output_model(table: np.ndarray, input_width: int, input_height: int) -> bytes:
    """An ONNX model with input ``images`` [1, 3, H, W] whose output ``output0`` is ``table`` (+ 0 × the
    input's mean, so that the graph uses its input)."""
    table = np.asarray(table, dtype=np.float32)
    nodes = [helper.make_node("ReduceMean", ["images"], ["mean"], keepdims=0),
             helper.make_node("Mul", ["mean", "zero"], ["nothing"]),
             helper.make_node("Add", ["table", "nothing"], ["output0"])]
    graph = helper.make_graph(
        nodes, "constant-yolo-pose",
        [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, input_height, input_width])],
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, list(table.shape))],
        [numpy_helper.from_array(table, "table"), numpy_helper.from_array(np.array(0.0, np.float32), "zero")])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    return model.SerializeToString()
