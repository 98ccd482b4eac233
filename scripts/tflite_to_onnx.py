#!/usr/bin/env python3
"""Converts MediaPipe's float TFLite models (face mesh, selfie segmentation) to ONNX for `ort`.

glyptic's own converter, written because `tflite2onnx` 0.4.1 fails on these models (no
HARD_SWISH, no MediaPipe transposed convolution, a layout bug on PRELU) and `tf2onnx` needs all
of TensorFlow. It covers exactly the operators these models use and refuses anything else by
name. Activations are kept NCHW inside the graph; the graph's inputs and outputs keep TFLite's
NHWC layout, so the ONNX model is called with the same tensors as the TFLite one.

usage: tflite_to_onnx.py MODEL.tflite OUT.onnx [--check]
  --check  also runs both models (tflite_runtime, onnxruntime) on random input and prints the
           largest difference (needs those two packages; models with MediaPipe's custom
           operator cannot be run by tflite_runtime).
"""

import struct
import sys

import numpy as np
import onnx
import tflite
from onnx import TensorProto, helper, numpy_helper

OPSET = 14

BUILTIN = {v: k for k, v in tflite.BuiltinOperator.__dict__.items() if not k.startswith("_")}
NP_TYPE = {
    tflite.TensorType.FLOAT32: np.float32,
    tflite.TensorType.FLOAT16: np.float16,
    tflite.TensorType.INT32: np.int32,
    tflite.TensorType.INT64: np.int64,
}


class Converter:
    def __init__(self, buf):
        self.model = tflite.Model.GetRootAsModel(buf, 0)
        if self.model.SubgraphsLength() != 1:
            raise SystemExit("only single-subgraph models are supported")
        self.g = self.model.Subgraphs(0)
        self.nodes = []
        self.inits = []
        self.const = {}  # tensor index -> numpy array (TFLite layout)
        self.names = {}  # tensor index -> ONNX name of the value (NCHW for 4-D activations)
        self.counter = 0
        for i in range(self.g.TensorsLength()):
            t = self.g.Tensors(i)
            b = self.model.Buffers(t.Buffer())
            if b is not None and b.DataLength() > 0:
                dtype = NP_TYPE.get(t.Type())
                if dtype is None:
                    raise SystemExit(f"tensor {t.Name().decode()}: unsupported type {t.Type()}")
                arr = np.frombuffer(b.DataAsNumpy().tobytes(), dtype=dtype)
                self.const[i] = arr.reshape(t.ShapeAsNumpy()) if t.ShapeLength() else arr

    # -- helpers ---------------------------------------------------------------------------
    def shape(self, i):
        return [int(d) for d in self.g.Tensors(i).ShapeAsNumpy()]

    def fresh(self, stem):
        self.counter += 1
        return f"{stem}_{self.counter}"

    def init(self, arr, stem):
        name = self.fresh(stem)
        self.inits.append(numpy_helper.from_array(np.ascontiguousarray(arr), name))
        return name

    def value(self, i):
        """ONNX name of tensor i as an activation (NCHW when 4-D), or an initializer."""
        if i in self.names:
            return self.names[i]
        if i in self.const:
            arr = self.const[i].astype(np.float32)
            if arr.ndim == 4:
                arr = arr.transpose(0, 3, 1, 2)
            elif arr.ndim in (1, 3):
                # A per-channel constant broadcast against NCHW: (C,) or (1,1,C) -> (C,1,1).
                arr = arr.reshape(-1, 1, 1) if arr.size > 1 else arr.reshape(1)
            self.names[i] = self.init(arr, "const")
            return self.names[i]
        raise SystemExit(f"tensor {self.g.Tensors(i).Name().decode()} has no producer")

    def node(self, op, inputs, outputs, **attrs):
        self.nodes.append(helper.make_node(op, inputs, outputs, name=self.fresh(op), **attrs))

    def activation(self, fused, name, out):
        """Applies a TFLite fused activation to `name`, writing `out`."""
        if fused == tflite.ActivationFunctionType.NONE:
            self.node("Identity", [name], [out])
        elif fused == tflite.ActivationFunctionType.RELU:
            self.node("Relu", [name], [out])
        elif fused == tflite.ActivationFunctionType.RELU6:
            self.node("Clip", [name, self.init(np.float32(0), "lo"), self.init(np.float32(6), "hi")], [out])
        else:
            raise SystemExit(f"unsupported fused activation {fused}")

    @staticmethod
    def same_pads(size, kernel, stride, dilation=1):
        out = -(-size // stride)
        total = max((out - 1) * stride + (kernel - 1) * dilation + 1 - size, 0)
        return total // 2, total - total // 2

    def conv_pads(self, padding, in_hw, k_hw, strides, dil):
        if padding == tflite.Padding.VALID:
            return [0, 0, 0, 0]
        (t, b), (l, r) = (self.same_pads(in_hw[i], k_hw[i], strides[i], dil[i]) for i in range(2))
        return [t, l, b, r]

    # -- operators -------------------------------------------------------------------------
    def convert(self):
        g = self.g
        inputs, outputs = [], []
        for k in range(g.InputsLength()):
            i = g.Inputs(k)
            t = g.Tensors(i)
            name = t.Name().decode()
            inputs.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, self.shape(i)))
            if len(self.shape(i)) == 4:
                self.names[i] = self.fresh("nchw_in")
                self.node("Transpose", [name], [self.names[i]], perm=[0, 3, 1, 2])
            else:
                self.names[i] = name
        for k in range(g.OperatorsLength()):
            self.operator(g.Operators(k))
        for k in range(g.OutputsLength()):
            i = g.Outputs(k)
            name = g.Tensors(i).Name().decode()
            if len(self.shape(i)) == 4:
                self.node("Transpose", [self.value(i)], [name], perm=[0, 2, 3, 1])
            else:
                self.node("Identity", [self.value(i)], [name])
            outputs.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, self.shape(i)))
        graph = helper.make_graph(self.nodes, "mediapipe", inputs, outputs, self.inits)
        model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)])
        model.ir_version = 8
        onnx.checker.check_model(model)
        return model

    def operator(self, op):
        oc = self.model.OperatorCodes(op.OpcodeIndex())
        code = max(oc.BuiltinCode(), oc.DeprecatedBuiltinCode())
        name = BUILTIN.get(code, str(code))
        ins = [op.Inputs(k) for k in range(op.InputsLength())]
        outs = [op.Outputs(k) for k in range(op.OutputsLength())]
        out = outs[0]
        o = self.fresh(name.lower())
        opts = op.BuiltinOptions()

        def options(cls):
            x = cls()
            x.Init(opts.Bytes, opts.Pos)
            return x

        if name == "DEQUANTIZE":
            if ins[0] not in self.const:
                raise SystemExit("DEQUANTIZE of a non-constant tensor")
            self.const[out] = self.const[ins[0]].astype(np.float32)
            return
        if name in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            depthwise = name == "DEPTHWISE_CONV_2D"
            p = options(tflite.DepthwiseConv2DOptions if depthwise else tflite.Conv2DOptions)
            w = self.const[ins[1]].astype(np.float32)  # conv: O H W I; depthwise: 1 H W C*M
            kh, kw = w.shape[1:3]
            c_in = self.shape(ins[0])[3]
            if depthwise and w.shape[3] % c_in:
                raise SystemExit(f"depthwise weights {w.shape} do not fit {c_in} input channels")
            strides = [p.StrideH(), p.StrideW()]
            dil = [p.DilationHFactor(), p.DilationWFactor()]
            pads = self.conv_pads(p.Padding(), self.shape(ins[0])[1:3], [kh, kw], strides, dil)
            w = w.transpose(3, 0, 1, 2) if depthwise else w.transpose(0, 3, 1, 2)
            args = [self.value(ins[0]), self.init(w, "w")]
            if len(ins) > 2 and ins[2] >= 0:
                args.append(self.init(self.const[ins[2]].astype(np.float32), "b"))
            self.node("Conv", args, [o], kernel_shape=[kh, kw], strides=strides, dilations=dil,
                      pads=pads, group=c_in if depthwise else 1)
            self.finish(p.FusedActivationFunction(), o, out)
        elif name in ("MAX_POOL_2D", "AVERAGE_POOL_2D"):
            p = options(tflite.Pool2DOptions)
            k = [p.FilterHeight(), p.FilterWidth()]
            strides = [p.StrideH(), p.StrideW()]
            pads = self.conv_pads(p.Padding(), self.shape(ins[0])[1:3], k, strides, [1, 1])
            kind = "MaxPool" if name == "MAX_POOL_2D" else "AveragePool"
            extra = {} if kind == "MaxPool" else {"count_include_pad": 0}
            self.node(kind, [self.value(ins[0])], [o], kernel_shape=k, strides=strides, pads=pads, **extra)
            self.finish(p.FusedActivationFunction(), o, out)
        elif name in ("ADD", "MUL"):
            p = options(tflite.AddOptions if name == "ADD" else tflite.MulOptions)
            self.node("Add" if name == "ADD" else "Mul", [self.value(ins[0]), self.value(ins[1])], [o])
            self.finish(p.FusedActivationFunction(), o, out)
        elif name == "PRELU":
            alpha = self.const[ins[1]].astype(np.float32).reshape(-1, 1, 1)
            self.node("PRelu", [self.value(ins[0]), self.init(alpha, "alpha")], [o])
            self.names[out] = o
        elif name == "RELU":
            self.node("Relu", [self.value(ins[0])], [o])
            self.names[out] = o
        elif name == "LOGISTIC":
            self.node("Sigmoid", [self.value(ins[0])], [o])
            self.names[out] = o
        elif name == "HARD_SWISH":
            self.node("HardSwish", [self.value(ins[0])], [o])
            self.names[out] = o
        elif name == "PAD":
            pads = self.const[ins[1]].astype(np.int64)  # NHWC x (before, after)
            nchw = pads[[0, 3, 1, 2]]
            onnx_pads = np.concatenate([nchw[:, 0], nchw[:, 1]]).astype(np.int64)
            self.node("Pad", [self.value(ins[0]), self.init(onnx_pads, "pads")], [o], mode="constant")
            self.names[out] = o
        elif name == "MEAN":
            p = options(tflite.ReducerOptions)
            axes = [int(a) for a in self.const[ins[1]].reshape(-1)]
            to_nchw = {0: 0, 1: 2, 2: 3, 3: 1}
            self.node("ReduceMean", [self.value(ins[0])], [o], axes=[to_nchw[a] for a in axes],
                      keepdims=int(p.KeepDims()))
            if not p.KeepDims():
                raise SystemExit("MEAN without keep_dims is not supported")
            self.names[out] = o
        elif name == "RESIZE_BILINEAR":
            p = options(tflite.ResizeBilinearOptions)
            n, h, w, c = self.shape(out)
            mode = "half_pixel" if p.HalfPixelCenters() else ("align_corners" if p.AlignCorners() else "asymmetric")
            sizes = self.init(np.array([n, c, h, w], dtype=np.int64), "sizes")
            self.node("Resize", [self.value(ins[0]), "", "", sizes], [o], mode="linear",
                      coordinate_transformation_mode=mode)
            self.names[out] = o
        elif name == "CUSTOM" and oc.CustomCode().decode() == "Convolution2DTransposeBias":
            # MediaPipe's transposed convolution with bias; its options are a raw
            # TfLiteTransposeConvParams: padding (1 same, 2 valid), stride_w, stride_h.
            raw = op.CustomOptionsAsNumpy().tobytes()
            padding, sw, sh = struct.unpack("<iii", raw[:12])
            w = self.const[ins[1]].astype(np.float32)  # O H W I
            kh, kw = w.shape[1:3]
            _, ih, iw, _ = self.shape(ins[0])
            _, oh, ow, _ = self.shape(out)
            pads = [0, 0, 0, 0]
            if padding == 1:
                th = max((ih - 1) * sh + kh - oh, 0)
                tw = max((iw - 1) * sw + kw - ow, 0)
                pads = [th // 2, tw // 2, th - th // 2, tw - tw // 2]
            args = [self.value(ins[0]), self.init(w.transpose(3, 0, 1, 2), "w"),
                    self.init(self.const[ins[2]].astype(np.float32), "b")]
            self.node("ConvTranspose", args, [o], kernel_shape=[kh, kw], strides=[sh, sw], pads=pads)
            self.names[out] = o
        else:
            raise SystemExit(f"unsupported operator {name}")

    def finish(self, fused, o, out):
        if fused == tflite.ActivationFunctionType.NONE:
            self.names[out] = o
        else:
            a = self.fresh("act")
            self.activation(fused, o, a)
            self.names[out] = a


def check(tfl_path, onnx_path):
    import onnxruntime as ort
    from tflite_runtime.interpreter import Interpreter

    it = Interpreter(model_path=tfl_path)
    it.allocate_tensors()
    sess = ort.InferenceSession(onnx_path, providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    feeds = {}
    for d in it.get_input_details():
        x = rng.uniform(-1, 1, d["shape"]).astype(np.float32)
        it.set_tensor(d["index"], x)
        feeds[d["name"]] = x
    it.invoke()
    got = dict(zip([o.name for o in sess.get_outputs()], sess.run(None, feeds)))
    for d in it.get_output_details():
        ref = it.get_tensor(d["index"])
        diff = np.abs(ref - got[d["name"]]).max()
        print(f"{d['name']}: max |tflite - onnx| = {diff:.3g} (|tflite| up to {np.abs(ref).max():.3g})")


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 2:
        raise SystemExit(__doc__)
    model = Converter(open(args[0], "rb").read()).convert()
    onnx.save(model, args[1])
    if "--check" in sys.argv:
        check(args[0], args[1])


if __name__ == "__main__":
    main()
