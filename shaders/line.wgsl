// Coloured line segments. Each vertex may be pulled towards the eye (along its view ray, so it keeps
// its place on screen) to win the depth test against the surface it lies on: used for wireframes.

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) bias: f32,
    @location(2) color: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    let p = mix(v.position, globals.eye.xyz, v.bias);
    out.clip = globals.view_proj * vec4<f32>(p, 1.0);
    out.color = v.color;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    return output_color(in.color);
}
