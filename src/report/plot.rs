//! Figures as SVG and PNG (plotters; the PNG font is embedded, no system libraries).
//!
//! A figure is a vertical stack of panels; each panel has lines and point clouds. Both files
//! are written through [`crate::files`] (atomic; all together with the command's other
//! outputs). Series longer than the figure can show are thinned to a few points per pixel.

use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // Only fails when the bytes are not a font, which the embedded file is.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// A polyline.
    Line,
    /// Small dots (for scatter plots such as residual vs velocity).
    Points,
}

/// One data series.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
    /// Drawing style.
    pub style: Style,
}

/// One panel (axes) of a figure.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Title above the axes.
    pub title: String,
    /// Label of the x axis (with unit).
    pub x_label: String,
    /// Label of the y axis (with unit).
    pub y_label: String,
    /// Series, drawn in order.
    pub series: Vec<Series>,
}

const COLORS: [RGBColor; 5] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
];

fn range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    if hi - lo < 1e-12 * (1.0 + hi.abs()) {
        return (lo - 1.0, hi + 1.0);
    }
    let pad = 0.04 * (hi - lo);
    (lo - pad, hi + pad)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    panels: &[Panel],
    (rows, cols): (usize, usize),
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("{e:?}"))?;
    let areas = root.split_evenly((rows, cols));
    for (panel, area) in panels.iter().zip(areas) {
        let (x0, x1) = range(panel.series.iter().flat_map(|s| s.x.iter().copied()));
        let (y0, y1) = range(panel.series.iter().flat_map(|s| s.y.iter().copied()));
        let mut chart = ChartBuilder::on(&area)
            .caption(&panel.title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(38)
            .y_label_area_size(62)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| anyhow!("{e:?}"))?;
        // A panel whose x values are all whole numbers (steps, indices) labels only whole
        // numbers: "1.5" is no step.
        let whole_x = panel
            .series
            .iter()
            .flat_map(|s| s.x.iter())
            .all(|v| !v.is_finite() || v.fract() == 0.0);
        let whole = |v: &f64| -> String {
            if (v - v.round()).abs() < 1e-9 {
                format!("{}", v.round())
            } else {
                String::new()
            }
        };
        let mut mesh = chart.configure_mesh();
        if whole_x {
            mesh.x_label_formatter(&whole);
        }
        mesh.x_desc(&panel.x_label)
            .y_desc(&panel.y_label)
            .label_style(("sans-serif", 13))
            // No minor grid: thousands of lines per figure for little reading (a joint's
            // figure's SVG was a third grid lines).
            .max_light_lines(0)
            .draw()
            .map_err(|e| anyhow!("{e:?}"))?;
        for (i, s) in panel.series.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            let pts =
                s.x.iter()
                    .copied()
                    .zip(s.y.iter().copied())
                    .filter(|(a, b)| a.is_finite() && b.is_finite());
            let anno = match s.style {
                Style::Line => chart
                    .draw_series(LineSeries::new(pts, color.stroke_width(1)))
                    .map_err(|e| anyhow!("{e:?}"))?,
                Style::Points => {
                    // One dot per pixel it lands on: dots drawn on top of each other add
                    // bytes, not ink.
                    let mut seen = std::collections::HashSet::new();
                    let dots: Vec<(f64, f64)> = pts
                        .filter(|p| seen.insert(chart.backend_coord(p)))
                        .collect();
                    chart
                        .draw_series(dots.into_iter().map(|p| Circle::new(p, 1, color.filled())))
                        .map_err(|e| anyhow!("{e:?}"))?
                }
            };
            if !s.name.is_empty() {
                anno.label(s.name.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                });
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(|e| anyhow!("{e:?}"))?;
    }
    root.present().map_err(|e| anyhow!("{e:?}"))?;
    Ok(())
}

/// `s` thinned for a `width`-pixel axis: a line keeps the first, smallest, largest and last
/// point of each pixel's bucket of consecutive samples (its drawn envelope is unchanged), a
/// point cloud every k-th point, about one per pixel.
fn thin(s: &Series, width: usize) -> Series {
    let n = s.x.len().min(s.y.len());
    let buckets = width.max(100);
    let enough = match s.style {
        Style::Points => buckets / 2,
        Style::Line => 4 * buckets,
    };
    if n <= enough {
        return s.clone();
    }
    let (mut x, mut y) = (Vec::new(), Vec::new());
    match s.style {
        Style::Points => {
            // One point per two pixel columns on average: a cloud of a few hundred dots
            // shows its shape, and a seven-joint report stays under 3 MB.
            let k = n.div_ceil(buckets / 2);
            for i in (0..n).step_by(k) {
                x.push(s.x[i]);
                y.push(s.y[i]);
            }
        }
        Style::Line => {
            for b in 0..buckets {
                let (lo, hi) = (b * n / buckets, ((b + 1) * n / buckets).min(n));
                if lo >= hi {
                    continue;
                }
                let by = |f: fn(f64, f64) -> bool| {
                    (lo..hi).fold(lo, |best, i| if f(s.y[i], s.y[best]) { i } else { best })
                };
                let (imin, imax) = (by(|a, b| a < b), by(|a, b| a > b));
                let mut keep = vec![lo, imin, imax, hi - 1];
                keep.sort_unstable();
                keep.dedup();
                for i in keep {
                    x.push(s.x[i]);
                    y.push(s.y[i]);
                }
            }
        }
    }
    Series {
        name: s.name.clone(),
        x,
        y,
        style: s.style,
    }
}

/// Panels in one column of a figure at most: 5 × 300 px keeps a figure within 1600 px, a
/// screen's height; more panels go into further columns.
pub const MAX_ROWS: usize = 5;

/// The grid of a figure of `n` panels, `(rows, columns)`, and each cell's width (px) for a
/// one-column `width`: at most [`MAX_ROWS`] rows; two columns keep the width, more are
/// narrowed to 2·width/columns (at least 500 px).
pub fn grid(n: usize, width: u32) -> ((usize, usize), u32) {
    let n = n.max(1);
    let cols = n.div_ceil(MAX_ROWS);
    let rows = n.div_ceil(cols);
    let cell = if cols <= 2 {
        width
    } else {
        (2 * width / cols as u32).max(500)
    };
    ((rows, cols), cell)
}

/// Write `<stem>.svg` and `<stem>.png` and return both paths: the panels in a grid of at
/// most [`MAX_ROWS`] rows of 300 px ([`grid`]), each `width` wide (narrower beyond two
/// columns).
///
/// # Errors
/// The directory cannot be created or a file cannot be written (named).
pub fn figure(stem: &Path, panels: &[Panel], width: u32) -> Result<[PathBuf; 2]> {
    register_font();
    let ((rows, cols), cell) = grid(panels.len(), width);
    // A long record draws no better than a few points per pixel; the file size stays
    // bounded (a 200 MB record once made a 138 MB SVG).
    let thinned: Vec<Panel> = panels
        .iter()
        .map(|p| Panel {
            series: p.series.iter().map(|s| thin(s, cell as usize)).collect(),
            ..p.clone()
        })
        .collect();
    let panels = &thinned[..];
    let (width, height) = (cell * cols as u32, 300 * rows as u32);
    let svg_path = stem.with_extension("svg");
    let mut svg = String::new();
    draw(
        SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area(),
        panels,
        (rows, cols),
    )
    .with_context(|| format!("drawing {}", svg_path.display()))?;
    crate::files::write_atomic(&svg_path, svg.as_bytes())?;
    let png_path = stem.with_extension("png");
    let png = crate::files::Staged::new(&png_path)?;
    draw(
        BitMapBackend::new(png.tmp_path(), (width, height)).into_drawing_area(),
        panels,
        (rows, cols),
    )
    .with_context(|| format!("drawing {}", png_path.display()))?;
    crate::files::commit(vec![png])?;
    Ok([svg_path, png_path])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_stay_within_a_screens_height() {
        // One joint's 19 compare panels: 4 columns of 5 rows, 1500 px tall, 2000 px wide.
        assert_eq!(grid(19, 1000), ((5, 4), 500));
        assert_eq!(grid(3, 1000), ((3, 1), 1000));
        assert_eq!(grid(7, 1000), ((4, 2), 1000));
        for n in 1..60 {
            let ((rows, cols), _) = grid(n, 1000);
            assert!(
                rows * cols >= n && rows <= MAX_ROWS && 300 * rows <= 1600,
                "{n}"
            );
        }
    }

    #[test]
    fn thinning_keeps_a_lines_envelope_and_bounds_its_length() {
        let n = 1_000_000;
        let x: Vec<f64> = (0..n).map(|k| k as f64 * 1e-4).collect();
        // A slow sine with one isolated spike that must survive.
        let mut y: Vec<f64> = x.iter().map(|t| t.sin()).collect();
        y[123_457] = 5.0;
        let s = Series {
            name: "q".into(),
            x,
            y,
            style: Style::Line,
        };
        let t = thin(&s, 1000);
        assert!(t.x.len() <= 4000, "{}", t.x.len());
        let max = t.y.iter().copied().fold(f64::MIN, f64::max);
        let min = t.y.iter().copied().fold(f64::MAX, f64::min);
        assert_eq!(max, 5.0);
        let true_min = s.y.iter().copied().fold(f64::MAX, f64::min);
        assert_eq!(min, true_min);
        assert_eq!(t.x.first(), s.x.first());
        assert_eq!(t.x.last(), s.x.last());
        assert!(t.x.windows(2).all(|w| w[0] < w[1]), "time order kept");
        let short = thin(
            &Series {
                x: vec![0.0, 1.0],
                y: vec![1.0, 2.0],
                ..s.clone()
            },
            1000,
        );
        assert_eq!(short.y, vec![1.0, 2.0]);
    }
}
