// Lit, two-sided triangles: ambient + key + fill light, Lambert diffuse and a little Blinn-Phong specular.

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) front: vec4<f32>,
    @location(3) back: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) front: vec4<f32>,
    @location(3) back: vec4<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = globals.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.front = v.front;
    out.back = v.back;
    return out;
}

fn light(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, albedo: vec3<f32>, color: vec3<f32>) -> vec3<f32> {
    let ndl = max(dot(n, l), 0.0);
    let h = normalize(l + v);
    let spec = globals.params.y * pow(max(dot(n, h), 0.0), globals.params.z) * step(0.0, ndl - 1e-4);
    return color * (albedo * ndl + vec3<f32>(spec));
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) is_front: bool) -> @location(0) vec4<f32> {
    let v = normalize(globals.eye.xyz - in.world);
    var n = in.normal;
    let len = length(n);
    if len < 1e-6 {
        n = v;
    } else {
        n = n / len;
    }
    var base = in.front;
    if !is_front {
        n = -n;
        base = in.back;
    }
    // Hemisphere ambient: full from above, slightly darker from below.
    let hemi = 1.0 - globals.ambient.w * (0.5 - 0.5 * n.y);
    var c = base.rgb * globals.ambient.rgb * hemi;
    c += light(n, v, globals.key_dir.xyz, base.rgb, globals.key_color.rgb * globals.key_dir.w);
    c += light(n, v, globals.fill_dir.xyz, base.rgb, globals.fill_color.rgb * globals.fill_dir.w);
    return output_color(vec4<f32>(c, base.a));
}
