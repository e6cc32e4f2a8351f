//! Charts as PNG, drawn by plotters with the font egui ships (no system fonts): line charts,
//! cost–error scatter plots with their Pareto front, and categorical maps. One colour per method,
//! the same in every chart ([`method_color`]).

use std::ops::Range;
use std::path::Path;
use std::sync::Once;

use image::{RgbImage, RgbaImage};
use plotters::coord::ranged1d::{AsRangedCoord, DefaultFormatting, KeyPointHint, Ranged, ValueFormatter};
use plotters::prelude::*;

use super::EvalError;
use super::typeset::Typeset;

/// Size of every chart, pixels.
pub const SIZE: (u32, u32) = (960, 600);

/// The font family name the charts use (registered from egui's bundled Ubuntu Light).
const FONT: &str = "sans-serif";

pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font compiled into egui; failure would be a build defect,
        // and charts then show no text rather than failing.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT);
    });
}

/// A method's points in a scatter chart, in its colour ([`method_color`]).
pub fn method_points(method: &str, points: Vec<(f64, f64)>) -> Series {
    Series { label: method.to_string(), color: method_color(method), style: Style::Points, points }
}

/// The colour of a method, the same in every chart. Known methods have fixed colours; any other
/// name (a method added later) gets one derived from its name.
pub fn method_color(method: &str) -> RGBColor {
    match method {
        "lma" => RGBColor(214, 39, 40),
        "mwts" => RGBColor(31, 119, 180),
        "mwts-rs" => RGBColor(23, 190, 207),
        "rds" => RGBColor(0, 0, 128),
        "ds-static" => RGBColor(0, 0, 0),
        "ds" => RGBColor(127, 127, 127),
        "ds-implicit" => RGBColor(44, 160, 44),
        "cloth" => RGBColor(148, 103, 189),
        "cloth-quad" => RGBColor(140, 86, 75),
        "pbd" => RGBColor(255, 127, 14),
        "xpbd" => RGBColor(227, 119, 194),
        "rigid" => RGBColor(188, 189, 34),
        other => {
            let h = other.bytes().fold(2166136261u32, |h, b| (h ^ u32::from(b)).wrapping_mul(16777619));
            RGBColor((h & 0xff) as u8 / 2 + 64, ((h >> 8) & 0xff) as u8 / 2 + 64, ((h >> 16) & 0xff) as u8 / 2 + 64)
        }
    }
}

/// An axis: label (with unit) and whether it is logarithmic.
#[derive(Debug, Clone)]
pub struct Axis {
    /// Label, including the unit, e.g. `"gravity (m/s²)"`.
    pub label: String,
    /// Logarithmic scale (for data spanning decades).
    pub log: bool,
}

impl Axis {
    /// A linear axis.
    pub fn linear(label: impl Into<String>) -> Self {
        Self { label: label.into(), log: false }
    }

    /// A logarithmic axis.
    pub fn log(label: impl Into<String>) -> Self {
        Self { label: label.into(), log: true }
    }
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Markers joined by a line.
    Line,
    /// A dashed line with markers (a second quantity of the same method, or a reference).
    Dashed,
    /// Markers only.
    Points,
    /// A dashed line without markers (a front or a guide over other series' markers).
    Guide,
}

/// One named series of points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend entry.
    pub label: String,
    /// Colour (usually [`method_color`]).
    pub color: RGBColor,
    /// Drawing style.
    pub style: Style,
    /// The points (non-finite ones, and non-positive ones on log axes, are skipped).
    pub points: Vec<(f64, f64)>,
}

/// A chart of series on two axes.
#[derive(Debug, Clone)]
pub struct Plot {
    /// Title drawn above the chart.
    pub title: String,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// The series.
    pub series: Vec<Series>,
}

/// The range of `values` padded for drawing (log axes by a factor, linear by 5% of the span).
fn extent(values: impl Iterator<Item = f64>, log: bool) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && (!log || *v > 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() {
        return if log { 0.1..10.0 } else { 0.0..1.0 };
    }
    if log {
        let (lo, hi) = if hi / lo < 1.5 { (lo / 1.5, hi * 1.5) } else { (lo, hi) };
        lo / 1.25..hi * 1.25
    } else {
        let pad = if hi > lo { 0.05 * (hi - lo) } else { 0.5 * lo.abs().max(1.0) };
        lo - pad..hi + pad
    }
}

impl Plot {
    /// Draw to a PNG of [`SIZE`].
    pub fn save(&self, path: &Path) -> Result<(), EvalError> {
        let points = || self.series.iter().flat_map(|s| s.points.iter().copied());
        let xr = extent(points().map(|p| p.0), self.x.log);
        let yr = extent(points().map(|p| p.1), self.y.log);
        let log = |r: &Range<f64>| {
            let (bold, light) = log_ticks(r);
            r.clone().log_scale().with_key_points(bold).with_light_points(light)
        };
        draw_png(path, None, |root| match (self.x.log, self.y.log) {
            (false, false) => self.draw(root, xr.clone(), yr.clone()),
            (true, false) => self.draw(root, log(&xr), yr.clone()),
            (false, true) => self.draw(root, xr.clone(), log(&yr)),
            (true, true) => self.draw(root, log(&xr), log(&yr)),
        })
    }

    /// The corner of the plot with the fewest points, for the legend.
    fn emptiest_corner(&self) -> SeriesLabelPosition {
        let points: Vec<(f64, f64)> = self.series.iter().flat_map(|s| s.points.iter().copied()).collect();
        let scale = |v: f64, log: bool| if log { v.max(f64::MIN_POSITIVE).ln() } else { v };
        let xs = extent(points.iter().map(|p| p.0), self.x.log);
        let ys = extent(points.iter().map(|p| p.1), self.y.log);
        let frac = |v: f64, r: &Range<f64>, log: bool| {
            (scale(v, log) - scale(r.start, log)) / (scale(r.end, log) - scale(r.start, log)).max(f64::MIN_POSITIVE)
        };
        let count = |right: bool, top: bool| {
            points
                .iter()
                .filter(|p| {
                    let (fx, fy) = (frac(p.0, &xs, self.x.log), frac(p.1, &ys, self.y.log));
                    (if right { fx > 0.6 } else { fx < 0.4 }) && (if top { fy > 0.55 } else { fy < 0.45 })
                })
                .count()
        };
        [
            (SeriesLabelPosition::UpperLeft, count(false, true)),
            (SeriesLabelPosition::UpperRight, count(true, true)),
            (SeriesLabelPosition::LowerLeft, count(false, false)),
            (SeriesLabelPosition::LowerRight, count(true, false)),
        ]
        .into_iter()
        .min_by_key(|c| c.1)
        .map_or(SeriesLabelPosition::UpperLeft, |c| c.0)
    }

    fn draw<X, Y>(&self, root: &Root, x: X, y: Y) -> Result<(), String>
    where
        X: AsRangedCoord<Value = f64>,
        Y: AsRangedCoord<Value = f64>,
        X::CoordDescType: ValueFormatter<f64>,
        Y::CoordDescType: ValueFormatter<f64>,
    {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, 24))
            .margin(16)
            .x_label_area_size(56)
            .y_label_area_size(86)
            .build_cartesian_2d(x, y)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc(&self.x.label)
            .y_desc(&self.y.label)
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 18))
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|x| e(&x))?;
        let (x_log, y_log) = (self.x.log, self.y.log);
        let keep =
            move |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite() && (!x_log || p.0 > 0.0) && (!y_log || p.1 > 0.0);
        for s in &self.series {
            let pts: Vec<(f64, f64)> = s.points.iter().filter(keep).copied().collect();
            let color = s.color;
            let line = color.stroke_width(2);
            match s.style {
                Style::Line => {
                    chart.draw_series(LineSeries::new(pts.clone(), line)).map_err(|x| e(&x))?;
                }
                Style::Dashed => {
                    chart.draw_series(DashedLineSeries::new(pts.clone(), 8, 5, line)).map_err(|x| e(&x))?;
                }
                Style::Points => {}
                Style::Guide => {
                    chart
                        .draw_series(DashedLineSeries::new(pts.clone(), 8, 5, line))
                        .map_err(|x| e(&x))?
                        .label(&s.label)
                        .legend(move |(x, y)| PathElement::new(vec![(x - 8, y), (x + 8, y)], color.stroke_width(2)));
                    continue;
                }
            }
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 4, color.filled())))
                .map_err(|x| e(&x))?
                .label(&s.label)
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(-8, 0), (8, 0)], color.stroke_width(2))
                        + Circle::new((0, 0), 4, color.filled())
                });
        }
        chart
            .configure_series_labels()
            .position(self.emptiest_corner())
            .label_font((FONT, 15))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(|x| e(&x))?;
        Ok(())
    }
}

/// The labelled and the grid-only values of a log axis over `range`: every decade, and 2× and 5×
/// each decade where the axis spans under two decades (every integer multiple under one); the grid
/// at every integer multiple.
fn log_ticks(range: &Range<f64>) -> (Vec<f64>, Vec<f64>) {
    let (lo, hi) = (range.start.max(f64::MIN_POSITIVE), range.end.max(f64::MIN_POSITIVE));
    let decades = (hi / lo).log10();
    let labelled: &[f64] = if decades < 1.0 {
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
    } else if decades < 2.0 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let (first, last) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let within = |v: &f64| *v >= lo * (1.0 - 1e-12) && *v <= hi * (1.0 + 1e-12);
    let at = |multiples: &[f64]| -> Vec<f64> {
        (first..=last).flat_map(|k| multiples.iter().map(move |m| m * 10f64.powi(k))).filter(within).collect()
    };
    (at(labelled), at(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]))
}

/// Tick label: plain for moderate magnitudes, scientific otherwise.
fn tick(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&a) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// One cell of a categorical map.
#[derive(Debug, Clone)]
pub struct Cell {
    /// Column index (x).
    pub column: usize,
    /// Row index (y).
    pub row: usize,
    /// Category index into [`MapPanel`]'s legend.
    pub category: usize,
}

/// A grid of categorical cells (e.g. stable / diverged / inaccurate over step × stiffness).
#[derive(Debug, Clone)]
pub struct MapPanel {
    /// Panel title (the method).
    pub title: String,
    /// Labels of the columns (x), left to right.
    pub columns: Vec<String>,
    /// Labels of the rows (y), bottom to top.
    pub rows: Vec<String>,
    /// The filled cells.
    pub cells: Vec<Cell>,
    /// Optional vertical marker at a fractional column position, with its label (an estimated limit).
    pub marker: Option<(f64, String)>,
}

/// Several maps side by side under one title, sharing a legend of categories.
#[derive(Debug, Clone)]
pub struct Maps {
    /// Title.
    pub title: String,
    /// Horizontal axis label.
    pub x_label: String,
    /// Vertical axis label.
    pub y_label: String,
    /// Category names and colours.
    pub legend: Vec<(String, RGBColor)>,
    /// The panels.
    pub panels: Vec<MapPanel>,
}

impl Maps {
    /// Draw to a PNG of [`SIZE`] (height grows with the number of panel rows).
    pub fn save(&self, path: &Path) -> Result<(), EvalError> {
        draw_png(path, None, |root| self.draw(root))
    }

    fn draw(&self, root: &Root) -> Result<(), String> {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let titled = root.titled(&self.title, (FONT, 24)).map_err(|x| e(&x))?;
        let (body, legend) = titled.split_vertically(SIZE.1 as i32 - 80);
        let per_row = 3.min(self.panels.len().max(1));
        let rows = self.panels.len().div_ceil(per_row).max(1);
        let areas = body.split_evenly((rows, per_row));
        for (panel, area) in self.panels.iter().zip(&areas) {
            let (nx, ny) = (panel.columns.len().max(1), panel.rows.len().max(1));
            // Cells are unit squares on continuous axes (a single row or column is a panel like any
            // other); the labels sit at the cells' centres, at most about six along x.
            let every = nx.div_ceil(6).max(1);
            let centres = |n: usize, every: usize| (0..n).step_by(every).map(|i| i as f64 + 0.5).collect::<Vec<f64>>();
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, (FONT, 17))
                .margin(6)
                .x_label_area_size(40)
                .y_label_area_size(48)
                .build_cartesian_2d(
                    CellAxis { cells: nx as f64, keys: centres(nx, every) },
                    CellAxis { cells: ny as f64, keys: centres(ny, 1) },
                )
                .map_err(|x| e(&x))?;
            let label =
                |labels: &[String], v: f64| labels.get(v.floor().max(0.0) as usize).cloned().unwrap_or_default();
            chart
                .configure_mesh()
                .disable_mesh()
                .x_label_formatter(&|v| label(&panel.columns, *v))
                .y_label_formatter(&|v| label(&panel.rows, *v))
                .x_desc(&self.x_label)
                .y_desc(&self.y_label)
                .label_style((FONT, 12))
                .axis_desc_style((FONT, 13))
                .draw()
                .map_err(|x| e(&x))?;
            chart
                .draw_series(panel.cells.iter().map(|c| {
                    let color = self.legend.get(c.category).map_or(BLACK, |l| l.1);
                    let (x, y) = (c.column as f64, c.row as f64);
                    Rectangle::new([(x, y), (x + 1.0, y + 1.0)], color.filled())
                }))
                .map_err(|x| e(&x))?;
            if let Some((at, text)) = &panel.marker {
                // A vertical line at a fractional column position.
                let (x, bottom) = chart.backend_coord(&(*at, 0.0));
                let top = chart.backend_coord(&(*at, ny as f64)).1;
                let style = BLACK.stroke_width(2);
                root.draw(&PathElement::new(vec![(x, bottom), (x, top)], style)).map_err(|x| e(&x))?;
                root.draw(&Text::new(text.clone(), (x + 4, top + 2), (FONT, 12))).map_err(|x| e(&x))?;
            }
        }
        // The legend: a swatch and a name per category, in one row.
        let mut x = 20;
        for (name, color) in &self.legend {
            legend.draw(&Rectangle::new([(x, 30), (x + 18, 48)], color.filled())).map_err(|x| e(&x))?;
            legend.draw(&Text::new(name.clone(), (x + 24, 32), (FONT, 16))).map_err(|x| e(&x))?;
            x += 30 + 9 * name.chars().count() as i32;
        }
        Ok(())
    }
}

type Root<'a> = DrawingArea<Typeset<BitMapBackend<'a>>, plotters::coord::Shift>;

/// A continuous axis over `cells` unit cells, labelled at the chosen `keys` (cell centres).
struct CellAxis {
    cells: f64,
    keys: Vec<f64>,
}

impl Ranged for CellAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        limit.0 + (value / self.cells * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, _: Hint) -> Vec<f64> {
        self.keys.clone()
    }

    fn range(&self) -> Range<f64> {
        0.0..self.cells
    }
}

/// One bar: its label, value and colour.
pub type Bar = (String, f64, RGBColor);

/// Grouped bars on a logarithmic value axis: one group per label, one bar per entry.
#[derive(Debug, Clone)]
pub struct Bars {
    /// Title.
    pub title: String,
    /// Value axis label (with unit); the axis is logarithmic.
    pub y_label: String,
    /// Groups: label and its bars.
    pub groups: Vec<(String, Vec<Bar>)>,
}

impl Bars {
    /// Draw to a PNG of [`SIZE`].
    pub fn save(&self, path: &Path) -> Result<(), EvalError> {
        draw_png(path, None, |root| self.draw(root))
    }

    fn draw(&self, root: &Root) -> Result<(), String> {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        let values = self.groups.iter().flat_map(|g| g.1.iter().map(|b| b.1));
        // Bars rise from 1 (no speed-up) or from below the smallest value.
        let padded = extent(values, true);
        let yr = padded.start.min(1.0)..padded.end;
        let n = self.groups.len().max(1) as u32;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT, 24))
            .margin(16)
            .x_label_area_size(56)
            .y_label_area_size(86)
            .build_cartesian_2d((0..n - 1).into_segmented(), yr.clone().log_scale())
            .map_err(|x| e(&x))?;
        let labels: Vec<String> = self.groups.iter().map(|g| g.0.clone()).collect();
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n as usize)
            .x_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) => labels.get(*i as usize).cloned().unwrap_or_default(),
                _ => String::new(),
            })
            .y_label_formatter(&|v| tick(*v))
            .y_desc(&self.y_label)
            .label_style((FONT, 15))
            .axis_desc_style((FONT, 18))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(|x| e(&x))?;
        let pixel = |i: u32, v: f64| chart.backend_coord(&(SegmentValue::Exact(i), v));
        for (gi, (_, bars)) in self.groups.iter().enumerate() {
            let (left, _) = pixel(gi as u32, yr.start);
            let (right, _) = pixel(gi as u32 + 1, yr.start);
            let width = (right - left) as f64 * 0.8 / bars.len().max(1) as f64;
            for (bi, (label, value, color)) in bars.iter().enumerate() {
                if !(value.is_finite() && *value > 0.0) {
                    continue;
                }
                let x0 = left + ((right - left) as f64 * 0.1 + width * bi as f64) as i32;
                let (_, top) = pixel(gi as u32, *value);
                let (_, bottom) = pixel(gi as u32, yr.start);
                root.draw(&Rectangle::new([(x0, top), (x0 + width as i32 - 2, bottom)], color.filled()))
                    .map_err(|x| e(&x))?;
                let text = format!("{label}: {}", super::report::number(*value));
                root.draw(&Text::new(text, (x0, top - 16), (FONT, 13))).map_err(|x| e(&x))?;
            }
        }
        Ok(())
    }
}

/// Draw into an RGB buffer of [`SIZE`] (white, or starting from `under`) and save it as PNG, atomically.
fn draw_png(
    path: &Path,
    under: Option<RgbImage>,
    draw: impl FnOnce(&Root) -> Result<(), String>,
) -> Result<(), EvalError> {
    register_font();
    let (w, h) = SIZE;
    let fail = |reason: String| EvalError::Chart { path: path.to_path_buf(), reason };
    let mut buffer = under.map_or_else(|| vec![255u8; (w * h * 3) as usize], RgbImage::into_raw);
    if buffer.len() != (w * h * 3) as usize {
        return Err(fail("the picture under the chart is not of the chart's size".into()));
    }
    {
        let root = Typeset(BitMapBackend::with_buffer(&mut buffer, (w, h))).into_drawing_area();
        draw(&root).map_err(fail)?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let image = RgbImage::from_raw(w, h, buffer).ok_or_else(|| fail("buffer size".into()))?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| fail(e.to_string()))?;
    }
    Ok(crate::render::save_png(&image::DynamicImage::ImageRgb8(image).to_rgba8(), path)?)
}

/// Pictures (renders) in a grid, each with a caption under it, under one title.
#[derive(Debug, Clone)]
pub struct Tiles {
    /// Title.
    pub title: String,
    /// Pictures per row.
    pub columns: usize,
    /// The pictures and their captions, row by row.
    pub tiles: Vec<(RgbaImage, String)>,
}

/// Height of a chart's title band and of a tile's caption band, pixels.
const TITLE_HEIGHT: u32 = 44;
const CAPTION_HEIGHT: u32 = 30;

impl Tiles {
    /// The size each picture must have for `columns` × `rows` tiles in a chart of [`SIZE`].
    pub fn tile_size(columns: usize, rows: usize) -> (u32, u32) {
        let (c, r) = (columns.max(1) as u32, rows.max(1) as u32);
        (SIZE.0 / c, (SIZE.1 - TITLE_HEIGHT) / r - CAPTION_HEIGHT)
    }

    /// Compose and save (pictures of another size than [`Tiles::tile_size`] are refused).
    pub fn save(&self, path: &Path) -> Result<(), EvalError> {
        let columns = self.columns.max(1);
        let rows = self.tiles.len().div_ceil(columns);
        let (tw, th) = Self::tile_size(columns, rows);
        let mut canvas = RgbImage::from_pixel(SIZE.0, SIZE.1, image::Rgb([255, 255, 255]));
        let origin =
            |i: usize| ((i % columns) as u32 * tw, TITLE_HEIGHT + (i / columns) as u32 * (th + CAPTION_HEIGHT));
        for (i, (picture, _)) in self.tiles.iter().enumerate() {
            if picture.dimensions() != (tw, th) {
                let reason = format!("tile {i} is {:?}, expected {:?}", picture.dimensions(), (tw, th));
                return Err(EvalError::Chart { path: path.to_path_buf(), reason });
            }
            let (x0, y0) = origin(i);
            for (x, y, p) in picture.enumerate_pixels() {
                canvas.put_pixel(x0 + x, y0 + y, image::Rgb([p.0[0], p.0[1], p.0[2]]));
            }
        }
        draw_png(path, Some(canvas), |root| {
            let e = |e: &dyn std::fmt::Display| e.to_string();
            root.draw(&Text::new(self.title.clone(), (16, 10), (FONT, 24))).map_err(|x| e(&x))?;
            for (i, (_, caption)) in self.tiles.iter().enumerate() {
                let (x0, y0) = origin(i);
                let at = ((x0 + 10) as i32, (y0 + th + 6) as i32);
                root.draw(&Text::new(caption.clone(), at, (FONT, 17))).map_err(|x| e(&x))?;
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plot_with_text_is_drawn_at_its_size_and_is_not_blank() {
        let dir = std::env::temp_dir().join(format!("shellwarp-chart-{}", std::process::id()));
        let path = dir.join("c.png");
        let plot = Plot {
            title: "test".into(),
            x: Axis::log("x (m)"),
            y: Axis::linear("y (1)"),
            series: vec![Series {
                label: "mwts".into(),
                color: method_color("mwts"),
                style: Style::Line,
                points: vec![(1.0, 0.0), (10.0, 1.0), (100.0, 0.5), (f64::NAN, 1.0)],
            }],
        };
        plot.save(&path).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), SIZE);
        let blue = img.pixels().filter(|p| p.0 == [31, 119, 180]).count();
        assert!(blue > 200, "the series is drawn ({blue} pixels)");
        // Text: dark grey anti-aliased pixels that are neither white nor the series' colour.
        let text = img.pixels().filter(|p| p.0[0] < 100 && p.0[0] == p.0[1] && p.0[1] == p.0[2]).count();
        assert!(text > 500, "labels are drawn with the bundled font ({text} pixels)");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn every_map_panel_is_drawn_a_single_row_and_a_single_column_too() {
        let dir = std::env::temp_dir().join(format!("shellwarp-maps-{}", std::process::id()));
        let path = dir.join("m.png");
        let green = RGBColor(0, 200, 0);
        let panel = |title: &str, columns: usize, rows: usize| MapPanel {
            title: title.into(),
            columns: (0..columns).map(|c| format!("c{c}")).collect(),
            rows: (0..rows).map(|r| format!("r{r}")).collect(),
            cells: (0..columns).flat_map(|c| (0..rows).map(move |r| Cell { column: c, row: r, category: 0 })).collect(),
            marker: None,
        };
        let maps = Maps {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            legend: vec![("ok".into(), green)],
            panels: vec![panel("grid", 5, 4), panel("row", 5, 1), panel("column", 1, 4)],
        };
        maps.save(&path).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        // Three panels side by side: each third of the panels' band has green cells.
        for (third, name) in ["grid", "row", "column"].iter().enumerate() {
            let (x0, x1) = (third as u32 * SIZE.0 / 3, (third as u32 + 1) * SIZE.0 / 3);
            let cells = (x0..x1).flat_map(|x| (40..SIZE.1 - 90).map(move |y| (x, y)));
            let drawn = cells.filter(|&(x, y)| img.get_pixel(x, y).0 == [0, 200, 0]).count();
            assert!(drawn > 2000, "panel `{name}` has {drawn} drawn cell pixels");
        }
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn log_axes_are_labelled_at_every_decade_and_at_2_and_5_over_a_short_span() {
        let near =
            |a: &[f64], b: &[f64]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x / y - 1.0).abs() < 1e-12);
        let (bold, light) = log_ticks(&(0.003..40.0));
        assert!(near(&bold, &[0.01, 0.1, 1.0, 10.0]), "every decade within the axis: {bold:?}");
        assert_eq!(light.len(), 7 + 9 + 9 + 9 + 4, "the grid at every multiple: {light:?}");
        let (bold, _) = log_ticks(&(0.03..0.35));
        assert!(near(&bold, &[0.05, 0.1, 0.2]), "a decade and a bit: 1, 2 and 5 of each: {bold:?}");
        let (bold, _) = log_ticks(&(1.5..4.0));
        assert!(near(&bold, &[2.0, 3.0, 4.0]), "under a decade: every multiple: {bold:?}");
    }

    #[test]
    fn colours_are_fixed_per_method_and_distinct() {
        let names = ["lma", "mwts", "mwts-rs", "ds-static", "ds", "ds-implicit", "cloth", "cloth-quad", "pbd", "xpbd"];
        let colors: Vec<_> = names.iter().map(|n| method_color(n)).collect();
        for (i, a) in colors.iter().enumerate() {
            assert!(colors[i + 1..].iter().all(|b| b != a), "{} shares its colour", names[i]);
        }
        assert_eq!(method_color("new-method"), method_color("new-method"));
    }
}
