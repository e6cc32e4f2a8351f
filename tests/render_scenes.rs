//! Every built-in scene renders headless on llvmpipe, shaded and without wireframe, and matches its
//! reference picture (made on lavapipe) within a per-pixel tolerance — over the whole picture and over
//! the shell's own screen rectangle, so that a shading change on a shell covering little of the
//! picture still fails. Run with `SHELLWARP_BLESS=1` to (re)write references.

use std::path::PathBuf;

use image::RgbaImage;
use shellwarp::app::orbit::project;
use shellwarp::app::scene_view::{SceneView, ViewOptions};
use shellwarp::render::{Headless, compare_images, load_png, save_png};
use shellwarp::scene::{self, Setup};

const WIDTH: u32 = 480;
const HEIGHT: u32 = 300;

fn reference(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/reference").join(format!("scene-{name}.png"))
}

/// The pixel rectangle `(x, y, width, height)` the shell's vertices project into (a few pixels of margin).
fn shell_rect(view: &SceneView, setup: &Setup) -> (u32, u32, u32, u32) {
    let size = glam::Vec2::new(WIDTH as f32, HEIGHT as f32);
    let (mut lo, mut hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
    for p in setup.mesh.positions() {
        let pixel = project(&view.camera(), p.as_vec3(), size).expect("every vertex is in front of the camera");
        (lo, hi) = (lo.min(pixel), hi.max(pixel));
    }
    let lo = (lo - 3.0).max(glam::Vec2::ZERO).as_uvec2();
    let hi = (hi + 3.0).min(glam::Vec2::new(WIDTH as f32, HEIGHT as f32)).as_uvec2();
    (lo.x, lo.y, hi.x.saturating_sub(lo.x).max(1), hi.y.saturating_sub(lo.y).max(1))
}

fn crop(image: &RgbaImage, (x, y, w, h): (u32, u32, u32, u32)) -> RgbaImage {
    image::imageops::crop_imm(image, x, y, w, h).to_image()
}

#[test]
fn every_builtin_scene_renders_shaded_and_matches_its_reference() {
    let mut headless = Headless::new(WIDTH, HEIGHT).expect("a GPU adapter (llvmpipe is enough)");
    let bless = std::env::var_os("SHELLWARP_BLESS").is_some();
    for name in scene::builtin_names() {
        // The rest shape (rigid method, no steps): the reference pins the view and the shading, not the physics.
        let setup = scene::load(name, &["solver.method=rigid".into()]).unwrap_or_else(|e| panic!("{name}: {e}"));
        let view = SceneView::new(&setup);
        let frame = view.frame(view.camera(), setup.mesh.positions(), 0.0, &[], ViewOptions { wireframe: false }, &[]);
        let image = headless.render(&frame).unwrap_or_else(|e| panic!("{name}: {e}"));
        let rect = shell_rect(&view, &setup);
        // The shell is in the picture, and most of its rectangle is the shell (not background).
        let shell = crop(&image, rect);
        let bg = *image.get_pixel(0, 0);
        let covered = shell.pixels().filter(|p| p.0.iter().zip(bg.0).any(|(a, b)| a.abs_diff(b) > 40)).count();
        let fraction = covered as f64 / f64::from(shell.width() * shell.height());
        assert!(
            shell.width() * shell.height() > 2000 && fraction > 0.2,
            "{name}: shell rectangle {rect:?}, {fraction:.3} of it differs from the background"
        );
        let path = reference(name);
        if bless {
            save_png(&image, &path).unwrap();
            continue;
        }
        let want = load_png(&path).unwrap_or_else(|e| panic!("{name}: {e} (run with SHELLWARP_BLESS=1 to create)"));
        let whole = compare_images(&image, &want).unwrap();
        let on_shell = compare_images(&shell, &crop(&want, rect)).unwrap();
        if !(whole.mean_abs < 0.01 && whole.frac_over_threshold < 0.01 && on_shell.frac_over_threshold < 0.02) {
            let actual = std::env::temp_dir().join(format!("shellwarp-scene-{name}-actual.png"));
            let saved = save_png(&image, &actual).map(|()| actual.display().to_string());
            panic!(
                "{name}: differs from {}: whole picture {whole}; shell {on_shell}; actual: {saved:?}",
                path.display()
            );
        }
    }
}
