// Shared by lit.wgsl and line.wgsl: the renderer prepends this file to both.
// Must match `Globals` in src/render/pipelines.rs.

struct Globals {
    view_proj: mat4x4<f32>,
    // xyz: eye position in world space.
    eye: vec4<f32>,
    // xyz: unit direction towards the key light; w: intensity.
    key_dir: vec4<f32>,
    // rgb: key light colour.
    key_color: vec4<f32>,
    // xyz: unit direction towards the fill light; w: intensity.
    fill_dir: vec4<f32>,
    // rgb: fill light colour.
    fill_color: vec4<f32>,
    // rgb: ambient colour; w: how much darker surfaces facing down are (0..1).
    ambient: vec4<f32>,
    // x: 1 if the target is not sRGB and the shader must encode; y: specular strength; z: shininess.
    params: vec4<f32>,
};

@group(0) @binding(0) var<uniform> globals: Globals;

// Linear to sRGB transfer function, for non-sRGB targets only (sRGB targets encode in hardware).
fn output_color(c: vec4<f32>) -> vec4<f32> {
    if globals.params.x < 0.5 {
        return c;
    }
    let x = clamp(c.rgb, vec3<f32>(0.0), vec3<f32>(1.0));
    let lo = x * 12.92;
    let hi = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return vec4<f32>(select(hi, lo, x <= vec3<f32>(0.0031308)), c.a);
}
