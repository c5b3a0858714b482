//! The one place for shared chart code: the font, a palette of distinct colours and markers, and
//! line charts with labelled target lines. Every figure of the reports is drawn with it.

use anyhow::Result;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use std::path::Path;

/// Registers the bundled DejaVu Sans as "sans-serif" (plotters draws text with it).
pub fn register_fonts() {
    static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
    let _ = register_font("sans-serif", FontStyle::Normal, FONT);
}

/// Distinct colours (Okabe and Ito's colour-blind-safe set, then greys), one per series.
pub const PALETTE: [RGBColor; 9] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
    RGBColor(240, 228, 66),
    RGBColor(128, 128, 128),
];

/// A marker shape per series, cycling with the palette at another period so that no two of the
/// first 36 series look alike.
#[derive(Clone, Copy)]
pub enum Marker {
    Circle,
    Triangle,
    Square,
    Cross,
}

const MARKERS: [Marker; 4] = [Marker::Circle, Marker::Triangle, Marker::Square, Marker::Cross];

/// One line of a chart.
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// Drawn thicker (the series the figure is about).
    pub emphasis: bool,
}

/// A horizontal target line with its label.
pub struct Target {
    pub label: String,
    pub y: f64,
}

/// A line chart: axes, series with their own colour and marker, labelled target lines, a legend.
pub struct LineChart<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub x: std::ops::Range<f64>,
    pub y: std::ops::Range<f64>,
    /// The x values are log10 of the quantity: the axis labels show the quantity.
    pub x_log10: bool,
    pub series: Vec<Series>,
    pub targets: Vec<Target>,
    pub legend: SeriesLabelPosition,
    pub size: (u32, u32),
}

impl LineChart<'_> {
    /// Draws the chart into `path` (PNG).
    pub fn draw(&self, path: &Path) -> Result<()> {
        register_fonts();
        let root = BitMapBackend::new(path, self.size).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(self.title, ("sans-serif", 20))
            .margin(14)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(self.x.clone(), self.y.clone())?;
        let log = self.x_log10;
        let fmt = move |v: &f64| if log { format!("{}", 10f64.powf(*v)) } else { format!("{v}") };
        chart.configure_mesh().x_desc(self.x_desc).y_desc(self.y_desc).x_label_formatter(&fmt).draw()?;
        for (i, s) in self.series.iter().enumerate() {
            let c = PALETTE[i % PALETTE.len()];
            let m = MARKERS[(i / PALETTE.len() + i) % MARKERS.len()];
            let style = c.stroke_width(if s.emphasis { 3 } else { 2 });
            chart.draw_series(LineSeries::new(s.points.clone(), style))?.label(s.name.clone()).legend(move |(x, y)| {
                EmptyElement::at((x, y)) + PathElement::new(vec![(0, 0), (20, 0)], style) + shape(m, (10, 0), c)
            });
            chart.draw_series(s.points.iter().map(|&p| EmptyElement::at(p) + shape(m, (0, 0), c)))?;
        }
        for t in &self.targets {
            let line = BLACK.stroke_width(1);
            chart
                .draw_series(std::iter::once(PathElement::new(vec![(self.x.start, t.y), (self.x.end, t.y)], line)))?
                .label(t.label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], line));
        }
        chart
            .configure_series_labels()
            .position(self.legend.clone())
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()?;
        root.present().map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        Ok(())
    }
}

/// A marker of shape `m` at pixel offset `at`.
fn shape<DB: DrawingBackend>(m: Marker, at: (i32, i32), c: RGBColor) -> DynElement<'static, DB, (i32, i32)> {
    match m {
        Marker::Circle => Circle::new(at, 4, c.filled()).into_dyn(),
        Marker::Triangle => TriangleMarker::new(at, 5, c.filled()).into_dyn(),
        Marker::Square => Rectangle::new([(at.0 - 4, at.1 - 4), (at.0 + 4, at.1 + 4)], c.filled()).into_dyn(),
        Marker::Cross => Cross::new(at, 4, c.stroke_width(2)).into_dyn(),
    }
}
