"""Float16 storage of an ONNX graph's weights (a large model's, ``models.store.stored_in_half``) and back.
Torch-free: the export writes it, the int8 quantizer undoes it (it only quantizes weights it finds as
initializers)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import onnx

__all__ = ["float_weights", "half_weights"]

SUFFIX = ".f16"


def half_weights(graph: onnx.GraphProto) -> None:
    """Store the graph's float weights that float16 holds exactly as float16, each read through a Cast that
    onnxruntime folds when it loads the file: half the file, the same function. Small constants (such as
    push-pull's 1e-6) stay as they are."""
    from onnx import TensorProto, helper, numpy_helper

    casts = []
    for init in graph.initializer:
        if init.data_type != TensorProto.FLOAT:
            continue
        v = numpy_helper.to_array(init)
        h = v.astype(np.float16)
        if v.size < 64 or not np.array_equal(h.astype(np.float32), v):
            continue
        name = init.name
        init.CopyFrom(numpy_helper.from_array(h, name + SUFFIX))
        casts.append(helper.make_node("Cast", [name + SUFFIX], [name], to=TensorProto.FLOAT))
    _set_nodes(graph, [*casts, *graph.node])


def float_weights(graph: onnx.GraphProto) -> None:
    """Undo ``half_weights``: each float16 weight and its Cast become the float32 weight they read as."""
    from onnx import TensorProto, numpy_helper

    halves = {i.name: i for i in graph.initializer if i.data_type == TensorProto.FLOAT16}
    keep = []
    for node in graph.node:
        if node.op_type == "Cast" and node.input[0] in halves and node.input[0].endswith(SUFFIX):
            init = halves[node.input[0]]
            wide = numpy_helper.to_array(init).astype(np.float32)
            init.CopyFrom(numpy_helper.from_array(wide, node.output[0]))
        else:
            keep.append(node)
    _set_nodes(graph, keep)


def _set_nodes(graph: onnx.GraphProto, nodes: list[onnx.NodeProto]) -> None:
    del graph.node[:]
    graph.node.extend(nodes)
