// The vertex stage of the full-screen passes (SSS, composite): one triangle covering the
// screen, (-1,-1), (3,-1), (-1,3), drawn with `draw(0..3)` and no vertex buffer.

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    let x = f32((index << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(index & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}
