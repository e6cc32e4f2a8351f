//! Chart text set properly: a drawing backend that passes everything to the bitmap backend but
//! sets text itself, glyph by glyph from the bundled font (egui's Ubuntu Light), each glyph at its
//! pen position plus its own left side bearing, advanced by its advance width and the font's
//! kerning. plotters' `ab_glyph` text drops the bearing (it draws each glyph's ink from the pen
//! position), so narrow letters crowd and wide ones part: "cloth" read as "doth", "mwts" as "mw ts".
//!
//! The layout box is the pen's advance by the font's ascent-to-descent height at the requested
//! pixel size, as plotters measures it, so charts keep their geometry; anchors and the quarter-turn
//! transforms behave as plotters' own text does.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
    text_anchor::{HPos, VPos},
};

/// The font every chart's text is set in.
fn font() -> Option<FontRef<'static>> {
    FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT).ok()
}

/// Lay `text` out at `size` pixels: the glyphs on a baseline at the font's ascent (so the box's top
/// is y = 0), and the box's width and height.
fn layout(text: &str, size: f64) -> (Vec<ab_glyph::Glyph>, (i32, i32)) {
    let Some(font) = font() else { return (Vec::new(), (0, 0)) };
    let scaled = font.as_scaled(PxScale::from(size as f32));
    let mut pen = 0.0f32;
    let mut previous = None;
    let mut glyphs = Vec::new();
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = previous {
            pen += scaled.kern(p, id);
        }
        glyphs.push(id.with_scale_and_position(scaled.scale(), point(pen, scaled.ascent())));
        pen += scaled.h_advance(id);
        previous = Some(id);
    }
    let height = scaled.ascent() - scaled.descent();
    (glyphs, (pen.ceil() as i32, height.ceil() as i32))
}

/// Rasterise laid-out glyphs: `plot(x, y, coverage)` for every covered pixel of the box.
fn rasterise(glyphs: Vec<ab_glyph::Glyph>, mut plot: impl FnMut(i32, i32, f32)) {
    let Some(font) = font() else { return };
    for glyph in glyphs {
        if let Some(outline) = font.outline_glyph(glyph) {
            let min = outline.px_bounds().min;
            outline.draw(|x, y, c| plot(min.x as i32 + x as i32, min.y as i32 + y as i32, c));
        }
    }
}

/// A backend that sets its text with [`layout`] and draws everything else through `B`.
pub struct Typeset<B>(pub B);

impl<B: DrawingBackend> DrawingBackend for Typeset<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let (w, h) = layout(text, style.size()).1;
        Ok((w.max(0) as u32, h.max(0) as u32))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let (glyphs, (width, height)) = layout(text, style.size());
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let (transform, (w, h)) = (style.transform(), self.get_size());
        let mut result = Ok(());
        rasterise(glyphs, |x, y, coverage| {
            let (x, y) = transform.transform(x + dx, y + dy);
            let (x, y) = (pos.0 + x, pos.1 + y);
            if result.is_ok() && x >= 0 && y >= 0 && x < w as i32 && y < h as i32 {
                let pixel = BackendColor { alpha: color.alpha * f64::from(coverage), rgb: color.rgb };
                result = self.0.draw_pixel((x, y), pixel);
            }
        });
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The runs of inked columns of `text` drawn at `size` px through plotters onto a white bitmap,
    /// with this backend's text (`typeset`) or plotters' own `ab_glyph` text.
    fn ink_runs(text: &str, size: u32, typeset: bool) -> usize {
        use plotters::prelude::*;
        super::super::chart::register_font();
        let (w, h) = (200u32, 60u32);
        let mut buffer = vec![255u8; (w * h * 3) as usize];
        {
            let style = ("sans-serif", size).into_font().color(&BLACK);
            let bitmap = BitMapBackend::with_buffer(&mut buffer, (w, h));
            if typeset {
                let root = Typeset(bitmap).into_drawing_area();
                root.draw(&Text::new(text, (4, 4), style)).unwrap();
                root.present().unwrap();
            } else {
                let root = bitmap.into_drawing_area();
                root.draw(&Text::new(text, (4, 4), style)).unwrap();
                root.present().unwrap();
            }
        }
        let dark = |x: u32, y: u32| buffer[((y * w + x) * 3) as usize] < 160;
        let inked: Vec<bool> = (0..w).map(|x| (0..h).any(|y| dark(x, y))).collect();
        inked.windows(2).filter(|p| p[1] && !p[0]).count() + usize::from(inked[0])
    }

    #[test]
    fn letters_stand_apart_where_the_font_sets_them_apart() {
        // "c" and "l" are two glyphs with white between them at the charts' sizes; plotters' own
        // text drops the bearings, so at the panels' 17 px they touch and "cloth" reads "doth".
        for size in [12, 13, 15, 16, 17, 18, 24] {
            assert_eq!(ink_runs("cl", size, true), 2, "`cl` at {size} px");
            assert_eq!(ink_runs("lo", size, true), 2, "`lo` at {size} px");
        }
        assert_eq!(ink_runs("cl", 17, false), 1, "plotters' own text joins `cl` at 17 px");
    }

    #[test]
    fn glyph_ink_never_overlaps_the_next_glyphs_ink_in_a_word() {
        // Each glyph's ink box starts at or after the previous one's (allowing the font's own overlap
        // of at most a pixel), and the box grows with the text.
        let Some(font) = font() else { panic!("the bundled font loads") };
        for word in ["cloth", "mwts", "stiffness", "displacement"] {
            let (glyphs, (w, _)) = layout(word, 15.0);
            let boxes: Vec<(f32, f32)> = glyphs
                .into_iter()
                .filter_map(|g| font.outline_glyph(g))
                .map(|o| (o.px_bounds().min.x, o.px_bounds().max.x))
                .collect();
            for pair in boxes.windows(2) {
                assert!(pair[1].0 >= pair[0].1 - 1.0, "`{word}`: {:?} then {:?}", pair[0], pair[1]);
            }
            assert!(w > 5 * word.len() as i32, "`{word}` is {w} px wide");
        }
    }
}
