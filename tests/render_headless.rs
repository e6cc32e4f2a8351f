//! Headless rendering on a real wgpu adapter (lavapipe on CI): properties of the picture, then a
//! tolerant comparison with a reference PNG.
//!
//! These tests fail (not skip) without an adapter. To (re)create the reference, delete
//! `tests/reference/render_headless.png` and run with `SHELLWARP_BLESS=1`.

use std::path::PathBuf;

use glam::Vec3;
use image::RgbaImage;
use shellwarp::render::{
    Camera, Frame, Headless, Marker, MeshDraw, compare_images, linear_to_srgb, load_png, save_png,
};

const WIDTH: u32 = 256;
const HEIGHT: u32 = 192;
const ORANGE: [f32; 4] = [0.90, 0.36, 0.08, 1.0];
const TEAL: [f32; 4] = [0.05, 0.42, 0.45, 1.0];
const GRID: [f32; 4] = [0.12, 0.14, 0.20, 0.35];

fn headless() -> Headless {
    Headless::new(WIDTH, HEIGHT).unwrap_or_else(|e| {
        panic!("this test needs a wgpu adapter (lavapipe is enough): {e}");
    })
}

/// Make every triangle counter-clockwise when seen from the side `outward` points to.
fn orient(positions: &[[f32; 3]], triangles: &mut [[u32; 3]], outward: impl Fn(Vec3) -> Vec3) {
    for t in triangles.iter_mut() {
        let [a, b, c] = t.map(|i| Vec3::from(positions[i as usize]));
        if (b - a).cross(c - a).dot(outward((a + b + c) / 3.0)) < 0.0 {
            t.swap(1, 2);
        }
    }
}

/// A UV sphere (poles duplicated per slice; the degenerate pole triangles are harmless).
fn uv_sphere(center: Vec3, radius: f32, stacks: u32, slices: u32) -> MeshDraw {
    let mut positions = Vec::new();
    for i in 0..=stacks {
        let phi = std::f32::consts::PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let theta = std::f32::consts::TAU * j as f32 / slices as f32;
            let d = Vec3::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin());
            positions.push((center + radius * d).to_array());
        }
    }
    let mut triangles = Vec::new();
    let row = slices + 1;
    for i in 0..stacks {
        for j in 0..slices {
            let (a, b, c, d) = (i * row + j, i * row + j + 1, (i + 1) * row + j, (i + 1) * row + j + 1);
            triangles.push([a, c, b]);
            triangles.push([b, c, d]);
        }
    }
    orient(&positions, &mut triangles, |p| p - center);
    MeshDraw::from_positions(positions, triangles, ORANGE, TEAL)
}

/// An open, C-shaped curved sheet around a vertical axis: the outside is the front, the inside the back.
fn curled_sheet(axis: Vec3, radius: f32, height: f32) -> MeshDraw {
    let (nu, nv) = (18u32, 6u32);
    let mut positions = Vec::new();
    for i in 0..=nv {
        let y = axis.y + height * i as f32 / nv as f32;
        for j in 0..=nu {
            // Leave a gap facing +z (towards the camera) so the inside shows.
            let theta = 0.62 * std::f32::consts::PI + 1.75 * std::f32::consts::PI * j as f32 / nu as f32;
            let wobble = 1.0 + 0.08 * (3.0 * theta).sin() * (i as f32 / nv as f32);
            positions.push([axis.x + radius * wobble * theta.cos(), y, axis.z + radius * wobble * theta.sin()]);
        }
    }
    let mut triangles = Vec::new();
    let row = nu + 1;
    for i in 0..nv {
        for j in 0..nu {
            let (a, b, c, d) = (i * row + j, i * row + j + 1, (i + 1) * row + j, (i + 1) * row + j + 1);
            triangles.push([a, b, c]);
            triangles.push([b, d, c]);
        }
    }
    orient(&positions, &mut triangles, |p| Vec3::new(p.x - axis.x, 0.0, p.z - axis.z));
    MeshDraw::from_positions(positions, triangles, ORANGE, TEAL).with_wireframe([0.04, 0.04, 0.06, 1.0])
}

fn sphere_frame() -> Frame {
    let mut frame = Frame::new(Camera::look_at(Vec3::new(0.0, 1.4, 2.6), Vec3::new(0.0, 0.5, 0.0)));
    frame.ground_grid(0.0, 2.0, 0.25, GRID);
    frame.meshes.push(uv_sphere(Vec3::new(0.0, 0.5, 0.0), 0.5, 24, 48));
    frame
}

fn showcase_frame() -> Frame {
    let mut frame = Frame::new(Camera::look_at(Vec3::new(0.35, 1.5, 2.8), Vec3::new(0.15, 0.4, 0.0)));
    frame.ground_grid(0.0, 2.0, 0.25, GRID);
    frame.meshes.push(uv_sphere(Vec3::new(-0.6, 0.4, -0.1), 0.4, 20, 40));
    let sheet = curled_sheet(Vec3::new(0.65, 0.05, 0.0), 0.42, 0.8);
    for &i in &[6 * 19usize, 6 * 19 + 18] {
        let p = sheet.positions[i];
        frame.markers.push(Marker { position: p, size: 0.07, color: [0.85, 0.05, 0.05, 1.0] });
    }
    frame.meshes.push(sheet);
    frame
}

/// Save `image` as `name` in `$SHELLWARP_DUMP_DIR` when set, to look at renders while tuning.
fn dump(image: &RgbaImage, name: &str) {
    if let Some(dir) = std::env::var_os("SHELLWARP_DUMP_DIR") {
        save_png(image, PathBuf::from(dir).join(name)).unwrap();
    }
}

fn luminance(p: &image::Rgba<u8>) -> f32 {
    0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2])
}

fn is_orange(p: &image::Rgba<u8>) -> bool {
    i32::from(p[0]) > i32::from(p[2]) + 40
}

fn is_teal(p: &image::Rgba<u8>) -> bool {
    i32::from(p[2]) > i32::from(p[0]) + 30 && i32::from(p[1]) > i32::from(p[0]) + 30
}

fn background_rgba8(frame: &Frame) -> [u8; 4] {
    let c = frame.background;
    let enc = |x: f32| (linear_to_srgb(x) * 255.0).round() as u8;
    [enc(c[0]), enc(c[1]), enc(c[2]), (c[3] * 255.0).round() as u8]
}

fn mean_luminance(image: &RgbaImage, pixels: &[(u32, u32)]) -> f32 {
    pixels.iter().map(|&(x, y)| luminance(image.get_pixel(x, y))).sum::<f32>() / pixels.len().max(1) as f32
}

#[test]
fn sphere_is_shaded_on_a_plain_background() {
    let mut headless = headless();
    let frame = sphere_frame();
    let image = headless.render(&frame).unwrap();
    dump(&image, "sphere.png");
    assert_eq!(image.dimensions(), (WIDTH, HEIGHT));

    // The top rows are sky: exactly the clear colour, give or take rounding.
    let bg = background_rgba8(&frame);
    for x in 0..WIDTH {
        let p = image.get_pixel(x, 2).0;
        let worst = p.iter().zip(bg).map(|(&a, b)| a.abs_diff(b)).max().unwrap_or(0);
        assert!(worst <= 2, "pixel ({x}, 2) = {p:?}, background {bg:?}");
    }

    // The sphere covers the centre.
    let centre = image.get_pixel(WIDTH / 2, HEIGHT / 2);
    assert!(is_orange(centre), "centre pixel {centre:?} is not the sphere's colour");

    // Shading: the half towards the key light (upper left) is clearly brighter than the lower right.
    let sphere: Vec<(u32, u32)> =
        image.enumerate_pixels().filter(|(_, _, p)| is_orange(p)).map(|(x, y, _)| (x, y)).collect();
    let n = sphere.len() as f32;
    assert!(n > 0.1 * (WIDTH * HEIGHT) as f32, "sphere covers only {n} pixels");
    let (cx, cy) =
        (sphere.iter().map(|p| p.0 as f32).sum::<f32>() / n, sphere.iter().map(|p| p.1 as f32).sum::<f32>() / n);
    let (lit, shadow): (Vec<_>, Vec<_>) = sphere.iter().partition(|&&(x, y)| (x as f32 - cx) + (y as f32 - cy) < 0.0);
    let (lit, shadow) = (mean_luminance(&image, &lit), mean_luminance(&image, &shadow));
    assert!(lit > 1.25 * shadow, "lit side {lit:.1} is not brighter than the shadow side {shadow:.1}");
    // And it is not flat within the lit side either.
    let lums: Vec<f32> = sphere.iter().map(|&(x, y)| luminance(image.get_pixel(x, y))).collect();
    let (lo, hi) = lums.iter().fold((f32::MAX, f32::MIN), |(lo, hi), &l| (lo.min(l), hi.max(l)));
    assert!(hi - lo > 60.0, "luminance range {lo:.0}..{hi:.0} looks flat");
}

#[test]
fn quad_shows_front_colour_from_above_and_back_colour_from_below() {
    let mut headless = headless();
    let positions = vec![[-1.0, 0.0, -1.0], [-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0, -1.0]];
    // Counter-clockwise seen from +Y: the front faces up.
    let quad = MeshDraw::from_positions(positions, vec![[0, 1, 2], [0, 2, 3]], ORANGE, TEAL);
    assert!(quad.normals.iter().all(|n| n[1] > 0.99));
    let mut frame = Frame::new(Camera::look_at(Vec3::new(0.3, 2.5, 1.2), Vec3::ZERO));
    frame.meshes.push(quad);
    let above = headless.render(&frame).unwrap();
    frame.camera = Camera::look_at(Vec3::new(0.3, -2.5, 1.2), Vec3::ZERO);
    let below = headless.render(&frame).unwrap();
    dump(&above, "quad_above.png");
    dump(&below, "quad_below.png");
    let (a, b) = (above.get_pixel(WIDTH / 2, HEIGHT / 2), below.get_pixel(WIDTH / 2, HEIGHT / 2));
    assert!(is_orange(a), "from above: {a:?} should be the front (orange) colour");
    assert!(is_teal(b), "from below: {b:?} should be the back (teal) colour");
}

#[test]
fn showcase_matches_reference_png() {
    let mut headless = headless();
    let image = headless.render(&showcase_frame()).unwrap();
    dump(&image, "showcase.png");
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/reference");
    let reference_path = dir.join("render_headless.png");
    if !reference_path.exists() {
        if std::env::var("SHELLWARP_BLESS").as_deref() == Ok("1") {
            save_png(&image, &reference_path).unwrap();
            eprintln!("wrote reference {}", reference_path.display());
            return;
        }
        panic!("missing reference {}: run once with SHELLWARP_BLESS=1 to create it", reference_path.display());
    }
    let reference = load_png(&reference_path).unwrap();
    let diff = compare_images(&image, &reference).unwrap();
    if diff.mean_abs >= 0.01 || diff.frac_over_threshold >= 0.01 {
        let actual = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("render_headless.actual.png");
        let saved = save_png(&image, &actual).map(|()| actual.display().to_string());
        panic!("render differs from {}: {diff}; actual image: {saved:?}", reference_path.display());
    }
}

#[test]
fn unorm_target_matches_srgb_target_and_errors_are_returned() {
    use shellwarp::render::{Gpu, RenderError, Renderer, compare_images, render_to_image};
    let gpu = Gpu::new_headless().unwrap_or_else(|e| panic!("this test needs a wgpu adapter: {e}"));
    eprintln!("adapter: {}", gpu.adapter_name());
    let frame = sphere_frame();

    // The shader encodes sRGB itself for a non-sRGB target: both pictures must agree, except at edges
    // (MSAA resolve and line blending then happen on encoded rather than linear values).
    let mut srgb = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8UnormSrgb, 4).unwrap();
    let mut unorm = Renderer::new(&gpu, wgpu::TextureFormat::Rgba8Unorm, 4).unwrap();
    assert!([1, 4].contains(&srgb.sample_count()));
    let a = render_to_image(&gpu, &mut srgb, &frame, WIDTH, HEIGHT).unwrap();
    let b = render_to_image(&gpu, &mut unorm, &frame, WIDTH, HEIGHT).unwrap();
    let diff = compare_images(&a, &b).unwrap();
    assert!(diff.mean_abs < 0.005 && diff.frac_over_threshold < 0.01, "{diff}");

    // Runtime problems come back as errors, not panics.
    let err = render_to_image(&gpu, &mut srgb, &frame, 0, 10).unwrap_err();
    assert!(matches!(err, RenderError::BadSize { .. }), "{err}");
    let mut broken = frame.clone();
    broken.meshes[0].triangles.push([0, 1, 1_000_000]);
    let err = render_to_image(&gpu, &mut srgb, &broken, WIDTH, HEIGHT).unwrap_err();
    assert!(matches!(err, RenderError::BadMesh { mesh: 0, .. }), "{err}");
    // A target view whose format differs from the renderer's is a wgpu validation error.
    let err = render_to_image(&gpu, &mut srgb, &frame, WIDTH, HEIGHT).and_then(|_| {
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d { width: 8, height: 8, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Bgra8Unorm,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
        srgb.render(&gpu, &frame, &texture.create_view(&Default::default()), (8, 8))
    });
    match err {
        Err(RenderError::Gpu { message, .. }) => {
            eprintln!("validation error: {message}");
            // wgpu's report is several lines ("Caused by: ..."): it must come back as one, root cause kept.
            assert!(!message.contains('\n') && !message.contains("Caused by"), "{message}");
            assert!(message.contains("Bgra8Unorm") && message.contains("Rgba8UnormSrgb"), "{message}");
        }
        other => panic!("expected a GPU validation error, got {other:?}"),
    }
    // The renderer still works afterwards.
    let again = render_to_image(&gpu, &mut srgb, &frame, WIDTH, HEIGHT).unwrap();
    assert!(compare_images(&a, &again).unwrap().mean_abs < 1e-3);
}
