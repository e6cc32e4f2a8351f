//! Every built-in scene renders headless on llvmpipe, and matches its reference picture (made on
//! lavapipe) within a per-pixel tolerance. Run with `SHELLWARP_BLESS=1` to (re)write references.

use std::path::PathBuf;

use shellwarp::app::scene_view::{SceneView, ViewOptions};
use shellwarp::render::{Headless, compare_images, load_png, save_png};
use shellwarp::scene;

fn reference(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/reference").join(format!("scene-{name}.png"))
}

#[test]
fn every_builtin_scene_renders_and_matches_its_reference() {
    let mut headless = Headless::new(320, 200).expect("a GPU adapter (llvmpipe is enough)");
    let bless = std::env::var_os("SHELLWARP_BLESS").is_some();
    for name in scene::builtin_names() {
        // The rest shape (rigid method, no steps): the reference pins the view, not the physics.
        let setup = scene::load(name, &["solver.method=rigid".into()]).unwrap_or_else(|e| panic!("{name}: {e}"));
        let view = SceneView::new(&setup);
        let frame = view.frame(view.camera(), setup.mesh.positions(), 0.0, &[], ViewOptions { wireframe: true });
        let image = headless.render(&frame).unwrap_or_else(|e| panic!("{name}: {e}"));
        // Something other than background is visible: the mesh covers part of the picture.
        let bg = *image.get_pixel(0, 0);
        let covered = image.pixels().filter(|p| p.0.iter().zip(bg.0).any(|(a, b)| a.abs_diff(b) > 40)).count();
        let fraction = covered as f64 / (320.0 * 200.0);
        assert!(fraction > 0.005, "{name}: only {fraction:.4} of the picture differs from the background");
        let path = reference(name);
        if bless {
            save_png(&image, &path).unwrap();
            continue;
        }
        let want = load_png(&path).unwrap_or_else(|e| panic!("{name}: {e} (run with SHELLWARP_BLESS=1 to create)"));
        let diff = compare_images(&image, &want).unwrap();
        assert!(
            diff.mean_abs < 0.01 && diff.frac_over_threshold < 0.01,
            "{name}: differs from its reference: {diff:?}"
        );
    }
}
