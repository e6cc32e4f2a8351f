//! Tolerant image comparison for rendering tests: GPUs and drivers differ slightly, so never compare
//! rendered pictures for exact equality.

use image::RgbaImage;

use super::error::RenderError;

/// Default per-pixel threshold for [`compare_images`]: a pixel counts as different when one of its
/// channels differs by more than 10 % of the full range.
pub const DEFAULT_PIXEL_THRESHOLD: f32 = 0.1;

/// How different two images of the same size are. All values are on the `[0, 1]` channel scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageDiff {
    /// Mean absolute difference over every channel (RGBA) of every pixel.
    pub mean_abs: f32,
    /// Largest absolute difference of any channel of any pixel.
    pub max_abs: f32,
    /// Fraction of pixels whose largest channel difference exceeds `threshold`.
    pub frac_over_threshold: f32,
    /// The per-pixel threshold used for `frac_over_threshold`.
    pub threshold: f32,
}

impl std::fmt::Display for ImageDiff {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "mean |diff| {:.5}, max |diff| {:.3}, {:.3}% of pixels differ by more than {}",
            self.mean_abs,
            self.max_abs,
            100.0 * self.frac_over_threshold,
            self.threshold
        )
    }
}

/// Compare `a` and `b` pixel by pixel with [`DEFAULT_PIXEL_THRESHOLD`].
///
/// Fails with [`RenderError::SizeMismatch`] if the sizes differ.
pub fn compare_images(a: &RgbaImage, b: &RgbaImage) -> Result<ImageDiff, RenderError> {
    compare_images_with_threshold(a, b, DEFAULT_PIXEL_THRESHOLD)
}

/// Compare `a` and `b`: per-channel absolute differences, and the fraction of pixels whose largest
/// channel difference exceeds `threshold` (on `[0, 1]`).
pub fn compare_images_with_threshold(a: &RgbaImage, b: &RgbaImage, threshold: f32) -> Result<ImageDiff, RenderError> {
    if a.dimensions() != b.dimensions() {
        return Err(RenderError::SizeMismatch {
            a_width: a.width(),
            a_height: a.height(),
            b_width: b.width(),
            b_height: b.height(),
        });
    }
    let (mut sum, mut max, mut over) = (0u64, 0u8, 0usize);
    for (pa, pb) in a.pixels().zip(b.pixels()) {
        let worst = pa.0.iter().zip(pb.0).map(|(&x, y)| x.abs_diff(y)).inspect(|&d| sum += u64::from(d)).max();
        let worst = worst.unwrap_or(0);
        max = max.max(worst);
        if f32::from(worst) / 255.0 > threshold {
            over += 1;
        }
    }
    let pixels = (a.width() as usize * a.height() as usize).max(1);
    Ok(ImageDiff {
        mean_abs: (sum as f64 / (pixels as f64 * 4.0 * 255.0)) as f32,
        max_abs: f32::from(max) / 255.0,
        frac_over_threshold: over as f32 / pixels as f32,
        threshold,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgba;

    #[test]
    fn identical_images_have_no_difference() {
        let a = RgbaImage::from_pixel(4, 3, Rgba([10, 20, 30, 255]));
        let d = compare_images(&a, &a).unwrap();
        assert_eq!((d.mean_abs, d.max_abs, d.frac_over_threshold), (0.0, 0.0, 0.0));
    }

    #[test]
    fn small_and_large_differences() {
        let a = RgbaImage::from_pixel(10, 10, Rgba([100, 100, 100, 255]));
        let mut b = a.clone();
        b.put_pixel(0, 0, Rgba([100, 100, 100 + 51, 255])); // 0.2 on one channel: over the threshold
        b.put_pixel(1, 0, Rgba([105, 100, 100, 255])); // ~0.02: under it
        let d = compare_images(&a, &b).unwrap();
        assert!((d.frac_over_threshold - 0.01).abs() < 1e-6, "{d}");
        assert!((d.max_abs - 0.2).abs() < 1e-6);
        assert!((d.mean_abs - 56.0 / (400.0 * 255.0)).abs() < 1e-7);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = RgbaImage::new(2, 2);
        let b = RgbaImage::new(2, 3);
        assert!(matches!(compare_images(&a, &b), Err(RenderError::SizeMismatch { .. })));
    }
}
