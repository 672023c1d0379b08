//! Plots of the results (paper section 7's tables drawn as charts): a line chart of y against
//! x per series, a grouped bar chart and a stacked one (shares of a whole), each written as PNG and SVG under `DIR/plots/`.
//!
//! Text is drawn with a font embedded in the binary (Ubuntu Light from `epaint_default_fonts`)
//! through plotters' pure-Rust `ab_glyph` route, so plotting needs no system font libraries.

use anyhow::{Context, anyhow};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{
    AsRangedCoord, DefaultFormatting, KeyPointHint, Ranged, ValueFormatter,
};
use plotters::prelude::*;
use std::fmt::Display;
use std::path::{Path, PathBuf};

/// Pixel size of every chart.
const SIZE: (u32, u32) = (900, 560);
/// The font family name the charts use (registered from embedded bytes).
const FONT: &str = coherent::plot_font::FAMILY;

/// One line of a [`LineChart`].
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub name: String,
    /// Points `(x, y)`, drawn in the given order; non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Draw dashed and without markers (for references such as "ideal: speedup = lanes").
    pub dashed: bool,
}

impl Series {
    /// A solid line with markers.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            name: name.into(),
            points,
            dashed: false,
        }
    }

    /// A dashed reference line without markers.
    pub fn reference(name: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            dashed: true,
            ..Series::new(name, points)
        }
    }
}

/// A line chart of y against x, one line per series (e.g. speedup against lane count, one
/// line per kernel).
#[derive(Clone, Debug, Default)]
pub struct LineChart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Logarithmic x axis with base 2 (lane counts 1, 2, 4, 8, 16); x must be positive.
    pub log2_x: bool,
    /// Logarithmic y axis (errors over decades); points with y <= 0 are left out.
    pub log_y: bool,
}

/// A grouped bar chart: for each category one bar per series (e.g. Mrays/s per scene, one
/// bar per accel).
#[derive(Clone, Debug, Default)]
pub struct BarChart {
    pub title: String,
    pub y_label: String,
    /// The groups along the x axis.
    pub categories: Vec<String>,
    /// `(legend label, one value per category)`; NaN leaves a gap.
    pub series: Vec<(String, Vec<f64>)>,
}

/// The files one chart was written to, relative to the output folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlotFiles {
    pub png: PathBuf,
    pub svg: PathBuf,
}

/// Series colours: distinct on white and for common colour blindness (Okabe-Ito), then two
/// greys for charts with more series (the accel comparison has nine).
const COLOURS: [RGBColor; 10] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(213, 94, 0),
    RGBColor(240, 228, 66),
    RGBColor(0, 0, 0),
    RGBColor(150, 150, 150),
    RGBColor(90, 90, 90),
];

fn colour(i: usize) -> RGBColor {
    COLOURS[i % COLOURS.len()]
}

/// Registers the embedded font once per process.
fn ensure_font() -> anyhow::Result<()> {
    coherent::plot_font::register().map_err(|e| anyhow!(e))
}

/// Writes `chart` as `out/plots/{stem}.png` and `.svg`.
pub fn line_chart(out: &Path, stem: &str, chart: &LineChart) -> anyhow::Result<PlotFiles> {
    let points = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|&p| drawable(chart, p));
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in points {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        return Err(anyhow!("plot {stem}: no finite points to draw"));
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let y1 = if y1 > 0.0 { y1 * 1.1 } else { 1.0 };
    // A log axis starts below the smallest point; a linear one at 0.
    let y0 = if chart.log_y { y0 / 1.1 } else { 0.0 };
    write_both(
        out,
        stem,
        &Lines {
            chart,
            x0,
            x1,
            y0,
            y1,
        },
    )
}

/// Whether a point can be drawn on the chart's axes (positive where an axis is logarithmic).
fn drawable(chart: &LineChart, (x, y): (f64, f64)) -> bool {
    x.is_finite() && y.is_finite() && (!chart.log2_x || x > 0.0) && (!chart.log_y || y > 0.0)
}

/// A bar chart's data is drawable: categories and series, one value per category each.
fn check_bars(stem: &str, chart: &BarChart) -> anyhow::Result<()> {
    if chart.categories.is_empty() || chart.series.is_empty() {
        return Err(anyhow!("plot {stem}: no categories or no series"));
    }
    if let Some((name, values)) = chart
        .series
        .iter()
        .find(|(_, v)| v.len() != chart.categories.len())
    {
        return Err(anyhow!(
            "plot {stem}: series {name} has {} values for {} categories",
            values.len(),
            chart.categories.len()
        ));
    }
    Ok(())
}

/// Writes `chart` as `out/plots/{stem}.png` and `.svg`.
pub fn bar_chart(out: &Path, stem: &str, chart: &BarChart) -> anyhow::Result<PlotFiles> {
    check_bars(stem, chart)?;
    write_both(out, stem, chart)
}

/// Writes `chart` with its series stacked in each category (e.g. the shares of frame time
/// per stage) as `out/plots/{stem}.png` and `.svg`.
pub fn stacked_bar_chart(out: &Path, stem: &str, chart: &BarChart) -> anyhow::Result<PlotFiles> {
    check_bars(stem, chart)?;
    write_both(out, stem, &Stacked(chart))
}

/// A bar chart drawn stacked.
struct Stacked<'a>(&'a BarChart);

impl Draw for Stacked<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        draw_bars(root, self.0, true)
    }
}

/// A chart that can draw itself on any plotters backend.
trait Draw {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> anyhow::Result<()>;
}

/// A line chart with its computed axis ranges.
struct Lines<'a> {
    chart: &'a LineChart,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Draw for Lines<'_> {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        let (x, y) = (self.x0..self.x1, self.y0..self.y1);
        match (self.chart.log2_x, self.chart.log_y) {
            (true, true) => draw_lines(root, self.chart, x.log_scale().base(2.0), y.log_scale()),
            (true, false) => draw_lines(root, self.chart, x.log_scale().base(2.0), y),
            (false, true) => draw_lines(root, self.chart, x, y.log_scale()),
            (false, false) => draw_lines(root, self.chart, x, y),
        }
    }
}

impl Draw for BarChart {
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> anyhow::Result<()> {
        draw_bars(root, self, false)
    }
}

/// Renders one chart into a PNG and an SVG file.
fn write_both(out: &Path, stem: &str, chart: &impl Draw) -> anyhow::Result<PlotFiles> {
    ensure_font()?;
    let dir = out.join("plots");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let files = PlotFiles {
        png: Path::new("plots").join(format!("{stem}.png")),
        svg: Path::new("plots").join(format!("{stem}.svg")),
    };
    let (png, svg) = (out.join(&files.png), out.join(&files.svg));
    {
        chart
            .draw(BitMapBackend::new(&png, SIZE).into_drawing_area())
            .with_context(|| format!("cannot draw {}", png.display()))?;
    }
    {
        chart
            .draw(SVGBackend::new(&svg, SIZE).into_drawing_area())
            .with_context(|| format!("cannot draw {}", svg.display()))?;
    }
    Ok(files)
}

/// Turns a plotters error (whose backend error type varies) into an `anyhow` error.
fn err(e: impl Display) -> anyhow::Error {
    anyhow!("{e}")
}

fn draw_lines<DB: DrawingBackend, X, Y>(
    root: DrawingArea<DB, Shift>,
    chart: &LineChart,
    x_spec: X,
    y_spec: Y,
) -> anyhow::Result<()>
where
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    root.fill(&WHITE).map_err(err)?;
    let mut ctx = ChartBuilder::on(&root)
        .caption(&chart.title, (FONT, 24))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(x_spec, y_spec)
        .map_err(err)?;
    let label_style = (FONT, 16);
    ctx.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .label_style(label_style)
        .axis_desc_style((FONT, 18))
        .x_label_formatter(&|x| fmt_tick(*x))
        .y_label_formatter(&|y| fmt_tick(*y))
        .light_line_style(RGBColor(238, 238, 238))
        .max_light_lines(2)
        .draw()
        .map_err(err)?;
    for (i, series) in chart.series.iter().enumerate() {
        let style = colour(i).stroke_width(2);
        let points: Vec<(f64, f64)> = series
            .points
            .iter()
            .copied()
            .filter(|&p| drawable(chart, p))
            .collect();
        if series.dashed {
            ctx.draw_series(DashedLineSeries::new(points, 8, 6, style))
                .map_err(err)?
                .label(&series.name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        } else {
            ctx.draw_series(LineSeries::new(points.clone(), style))
                .map_err(err)?
                .label(&series.name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
            ctx.draw_series(
                points
                    .iter()
                    .map(|&p| Circle::new(p, 4, colour(i).filled())),
            )
            .map_err(err)?;
        }
    }
    ctx.configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font(label_style)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

fn draw_bars<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    chart: &BarChart,
    stacked: bool,
) -> anyhow::Result<()> {
    root.fill(&WHITE).map_err(err)?;
    let n = chart.categories.len();
    let finite = |v: f64| if v.is_finite() { v.max(0.0) } else { 0.0 };
    let y_max = if stacked {
        (0..n)
            .map(|i| chart.series.iter().map(|(_, v)| finite(v[i])).sum())
            .fold(0.0f64, f64::max)
    } else {
        chart
            .series
            .iter()
            .flat_map(|(_, v)| v.iter().copied())
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max)
    };
    let y_max = if y_max > 0.0 { y_max * 1.15 } else { 1.0 };
    let mut ctx = ChartBuilder::on(&root)
        .caption(&chart.title, (FONT, 24))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(Categories(n), 0.0..y_max)
        .map_err(err)?;
    let label_style = (FONT, 16);
    let category = |x: &f64| {
        let i = x.floor();
        if i >= 0.0 && (i as usize) < n {
            chart.categories[i as usize].clone()
        } else {
            String::new()
        }
    };
    ctx.configure_mesh()
        .disable_x_mesh()
        .y_desc(&chart.y_label)
        .label_style(label_style)
        .axis_desc_style((FONT, 18))
        .x_label_formatter(&category)
        .y_label_formatter(&|y| fmt_tick(*y))
        .light_line_style(RGBColor(238, 238, 238))
        .max_light_lines(2)
        .draw()
        .map_err(err)?;
    let groups = if stacked {
        1.0
    } else {
        chart.series.len() as f64
    };
    let width = 0.8 / groups;
    // Stacked: where each category's next bar starts.
    let mut base = vec![0.0f64; n];
    for (s, (name, values)) in chart.series.iter().enumerate() {
        let fill = colour(s).filled();
        let mut rects = Vec::new();
        for (i, &v) in values.iter().enumerate() {
            if !v.is_finite() {
                continue;
            }
            if stacked {
                let x0 = i as f64 + 0.1;
                let y0 = base[i];
                base[i] += finite(v);
                rects.push(Rectangle::new([(x0, y0), (x0 + width, base[i])], fill));
            } else {
                let x0 = i as f64 + 0.1 + s as f64 * width;
                rects.push(Rectangle::new([(x0, 0.0), (x0 + width * 0.92, v)], fill));
            }
        }
        let bars = rects;
        ctx.draw_series(bars)
            .map_err(err)?
            .label(name)
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], fill));
    }
    ctx.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(label_style)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// The x axis of a bar chart: `0..n` with one tick at the centre of each category.
struct Categories(usize);

impl Ranged for Categories {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = value / self.0.max(1) as f64;
        limit.0 + (t * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, _hint: Hint) -> Vec<f64> {
        (0..self.0).map(|i| i as f64 + 0.5).collect()
    }

    fn range(&self) -> std::ops::Range<f64> {
        0.0..self.0 as f64
    }
}

/// Axis tick text: integers without decimals, others with up to 3 significant digits.
fn fmt_tick(v: f64) -> String {
    if v == v.round() && v.abs() < 1e9 {
        format!("{v:.0}")
    } else {
        crate::table::fmt_num(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charts_are_written_as_png_and_svg() {
        let dir = tempfile::tempdir().unwrap();
        let lines = LineChart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![
                Series::new("a", vec![(1.0, 1.0), (2.0, f64::NAN), (4.0, 3.0)]),
                Series::reference("ideal", vec![(1.0, 1.0), (4.0, 4.0)]),
            ],
            log2_x: true,
            log_y: false,
        };
        let files = line_chart(dir.path(), "lines", &lines).unwrap();
        assert_eq!(files.png, Path::new("plots/lines.png"));
        let bars = BarChart {
            title: "t".into(),
            y_label: "y".into(),
            categories: vec!["p".into(), "q".into()],
            series: vec![
                ("a".into(), vec![1.0, f64::NAN]),
                ("b".into(), vec![2.0, 3.0]),
            ],
        };
        bar_chart(dir.path(), "bars", &bars).unwrap();
        for file in ["lines.png", "lines.svg", "bars.png", "bars.svg"] {
            let path = dir.path().join("plots").join(file);
            let bytes = std::fs::read(&path).unwrap();
            assert!(
                bytes.len() > 1000,
                "{} is {} bytes",
                path.display(),
                bytes.len()
            );
        }
        let svg = std::fs::read_to_string(dir.path().join("plots/bars.svg")).unwrap();
        assert!(svg.contains("\np\n</text>"), "category label drawn: {svg}");
    }

    #[test]
    fn empty_or_mismatched_data_is_an_error_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let empty = LineChart {
            series: vec![Series::new("a", vec![(0.0, 1.0)])],
            log2_x: true, // x = 0 cannot be drawn on a log axis
            log_y: false,
            ..LineChart::default()
        };
        let e = line_chart(dir.path(), "e", &empty).unwrap_err();
        assert!(e.to_string().contains("no finite points"), "{e}");
        let bars = BarChart {
            categories: vec!["p".into()],
            series: vec![("a".into(), vec![1.0, 2.0])],
            ..BarChart::default()
        };
        let e = bar_chart(dir.path(), "b", &bars).unwrap_err();
        assert!(e.to_string().contains("2 values for 1 categories"), "{e}");
    }
}
