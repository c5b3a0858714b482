//! The one place for charts: the font, a palette of distinct colours and markers, line charts with
//! labelled target lines, the scan figure, and each report part's files (Markdown, JSON and its
//! figures), which the part's own command and `braille report` both write through. From Rust, any
//! figure of the report is one call.

use crate::error::{Error, Result};
use crate::reports::chars::CharsReport;
use crate::reports::icub::{IcubRow, baselines, icub_rows};
use crate::reports::words::WordsReport;
use encoders::{Event, Polarity};
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use std::path::{Path, PathBuf};

/// A drawing's result: plotters' errors, boxed, until [`figure`] names the file.
type Drawn<T = ()> = std::result::Result<T, Box<dyn std::error::Error + Send + Sync>>;

/// A drawing's error as the crate's, naming the figure's file.
fn figure<T>(path: &Path, r: Drawn<T>) -> Result<T> {
    r.map_err(|e| Error::Figure { path: path.to_path_buf(), what: e.to_string() })
}

/// Writes `text` to `path`.
fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

/// Creates the folder `dir`.
fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })
}

/// Registers the bundled DejaVu Sans as "sans-serif" (plotters draws text with it).
pub fn register_fonts() {
    static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
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
    /// Where the line starts (None: the left edge).
    pub from_x: Option<f64>,
}

/// A number for an axis label: at most three decimals, no trailing zeros.
fn short(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
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
        figure(path, self.draw_png(path))
    }

    fn draw_png(&self, path: &Path) -> Drawn {
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
        let fmt = move |v: &f64| short(if log { 10f64.powf(*v) } else { *v });
        let fmt_y = |v: &f64| short(*v);
        chart
            .configure_mesh()
            .x_desc(self.x_desc)
            .y_desc(self.y_desc)
            .x_label_formatter(&fmt)
            .y_label_formatter(&fmt_y)
            .draw()?;
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
                .draw_series(std::iter::once(PathElement::new(
                    vec![(t.from_x.unwrap_or(self.x.start), t.y), (self.x.end, t.y)],
                    line,
                )))?
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
        root.present().map_err(|e| format!("{}: {e}", path.display()))?;
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

/// What of a scan [`scan_figure`] shows.
pub struct ScanWindow {
    /// Spatial pooling of the pictures (the paper: 4).
    pub pool: u16,
    /// The heat map's window: start in seconds from the first event (None: the busiest), length.
    pub start_s: Option<f64>,
    pub length_s: f64,
}

/// A scan as a heat map (events per pooled pixel, ON and OFF, over one window) above an event
/// raster (pooled column against time), as a PNG. `events` must not be empty.
pub fn scan_figure(
    events: &[Event],
    resolution: Option<encoders::Resolution>,
    window: &ScanWindow,
    title: &str,
    out: &Path,
) -> Result<()> {
    figure(out, scan_png(events, resolution, window, title, out))
}

fn scan_png(
    events: &[Event],
    resolution: Option<encoders::Resolution>,
    window: &ScanWindow,
    title: &str,
    out: &Path,
) -> Drawn {
    let res = resolution.unwrap_or_else(|| {
        let (w, h) = events.iter().fold((0, 0), |(w, h), e| (w.max(e.x), h.max(e.y)));
        encoders::Resolution::new(w + 1, h + 1)
    });
    let pool = window.pool.max(1) as usize;
    let (pw, ph) = ((res.width as usize).div_ceil(pool), (res.height as usize).div_ceil(pool));
    let t0 = events[0].t_us;
    let t1 = events[events.len() - 1].t_us;
    let span_s = ((t1 - t0) as f64 * 1e-6).max(1e-6);

    // Raster: pooled column against time.
    let time_bins = 900usize;
    let mut raster = vec![(0u32, 0u32); time_bins * pw];
    for e in events {
        let b = (((e.t_us - t0) as f64 * 1e-6 / span_s) * (time_bins - 1) as f64) as usize;
        let cell = &mut raster[b * pw + e.x as usize / pool];
        if e.polarity == Polarity::On { cell.0 += 1 } else { cell.1 += 1 }
    }
    // Heat map over a window: by default the one with the most events.
    let win_us = (window.length_s * 1e6) as i64;
    let start_us = match window.start_s {
        Some(s) => t0 + (s * 1e6) as i64,
        None => busiest_window(events, win_us),
    };
    let mut heat = vec![(0u32, 0u32); pw * ph];
    for e in events.iter().filter(|e| e.t_us >= start_us && e.t_us < start_us + win_us) {
        let cell = &mut heat[(e.y as usize / pool) * pw + e.x as usize / pool];
        if e.polarity == Polarity::On { cell.0 += 1 } else { cell.1 += 1 }
    }

    register_fonts();
    let root = BitMapBackend::new(out, (1200, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let (top, bottom) = root.split_vertically(420);
    let heat_title = format!(
        "heat map: {:.2}-{:.2} s, {}x{} (pooled by {pool}); orange ON, blue OFF",
        (start_us - t0) as f64 * 1e-6,
        (start_us - t0 + win_us) as f64 * 1e-6,
        pw,
        ph
    );
    draw_grid(&top, &heat, pw, ph, (0.0, pw as f64), (0.0, ph as f64), &heat_title, "column", "row", true)?;
    let raster_title = format!("event raster: pooled column against time ({} events)", events.len());
    draw_grid(
        &bottom,
        &raster,
        pw,
        time_bins,
        (0.0, pw as f64),
        (0.0, span_s),
        &raster_title,
        "column",
        "time (s)",
        false,
    )
    .map(|_| ())?;
    root.present().map_err(|e| format!("writing {}: {e}", out.display()))?;
    Ok(())
}

fn busiest_window(events: &[encoders::Event], win_us: i64) -> i64 {
    let (mut best, mut best_start, mut j) = (0usize, events[0].t_us, 0usize);
    for i in 0..events.len() {
        while events[j].t_us < events[i].t_us - win_us {
            j += 1;
        }
        if i - j > best {
            best = i - j;
            best_start = events[j].t_us;
        }
    }
    best_start
}

/// Draws counts `(on, off)` of an `nx` by `ny` grid as coloured cells: orange for ON, blue for OFF,
/// brightness by the log count.
#[allow(clippy::too_many_arguments)]
fn draw_grid(
    area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    grid: &[(u32, u32)],
    nx: usize,
    ny: usize,
    x_range: (f64, f64),
    y_range: (f64, f64),
    caption: &str,
    x_label: &str,
    y_label: &str,
    flip_y: bool,
) -> Drawn {
    let y = if flip_y { y_range.1..y_range.0 } else { y_range.0..y_range.1 };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(50)
        .build_cartesian_2d(x_range.0..x_range.1, y)?;
    chart.configure_mesh().disable_mesh().x_desc(x_label).y_desc(y_label).draw()?;
    let max = grid.iter().map(|&(a, b)| a + b).max().unwrap_or(1).max(1) as f64;
    let (dx, dy) = ((x_range.1 - x_range.0) / nx as f64, (y_range.1 - y_range.0) / ny as f64);
    chart.draw_series(grid.iter().enumerate().filter(|(_, c)| c.0 + c.1 > 0).map(|(i, &(on, off))| {
        let (ix, iy) = (i % nx, i / nx);
        let level = ((1.0 + (on + off) as f64).ln() / (1.0 + max).ln()).clamp(0.0, 1.0);
        let on_share = on as f64 / (on + off) as f64;
        let v = |share: f64| (255.0 * (1.0 - level * share)) as u8;
        let color = RGBColor(v(1.0 - on_share), v(0.5), v(on_share));
        let x0 = x_range.0 + ix as f64 * dx;
        let y0 = y_range.0 + iy as f64 * dy;
        Rectangle::new([(x0, y0), (x0 + dx, y0 + dy)], color.filled())
    }))?;
    Ok(())
}

/// The report's files in `out`; its Markdown.
pub fn write_chars_report(report: &CharsReport, out: &Path) -> Result<String> {
    create_dir(out)?;
    let md = crate::reports::chars::markdown(report)?;
    write(&out.join("chars.md"), &md)?;
    crate::write_json(&out.join("chars.json"), report, true)?;
    let depth = out.join("chars_depth.png");
    figure(&depth, plot_depth(report, &depth))?;
    let at = report.table_depth();
    for e in report.entries.iter().filter(|e| ["normaug", "snn"].contains(&e.key)) {
        let file = format!("chars_confusion_{}.png", e.key);
        let title = format!("{}: RAB {} mm, SIMULATED (rows truth, columns predicted)", e.name, report.depths_mm[at]);
        let path = out.join(file);
        figure(&path, plot_confusion(&e.scores[at].confusion, &title, &path))?;
    }
    Ok(md)
}

fn plot_depth(r: &CharsReport, path: &Path) -> Drawn {
    let series: Vec<Series> = r
        .entries
        .iter()
        .map(|e| Series {
            name: e.name.clone(),
            points: r.depths_mm.iter().zip(&e.accuracy_all).map(|(&d, &a)| (d, 100.0 * a)).collect(),
            emphasis: e.arch == snn::model_file::Arch::Snn,
        })
        .collect();
    let lo = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).fold(100.0f64, f64::min).min(90.0);
    LineChart {
        title: "SIMULATED: accuracy over every printed character against depth, RAB at 8 mm/s",
        x_desc: "indentation depth (mm)",
        y_desc: "accuracy (%)",
        x: 0.1..1.6,
        y: (lo - 2.0).max(0.0)..100.5,
        x_log10: false,
        series,
        targets: vec![Target { label: "target: 95% from 0.6 mm".into(), y: 95.0, from_x: Some(0.55) }],
        legend: SeriesLabelPosition::LowerRight,
        size: (900, 520),
    }
    .draw_png(path)
}

fn plot_confusion(confusion: &[Vec<u32>], title: &str, path: &Path) -> Drawn {
    register_fonts();
    let k = confusion.len();
    let root = BitMapBackend::new(path, (760, 760)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(30)
        .y_label_area_size(30)
        .build_cartesian_2d((0..k).into_segmented(), (0..k).into_segmented())?;
    let letter = |v: &SegmentValue<usize>, flip: bool| match v {
        SegmentValue::CenterOf(i) if *i < k => {
            let i = if flip { k - 1 - i } else { *i };
            ((b'A' + i.min(25) as u8) as char).to_string()
        }
        _ => String::new(),
    };
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(k)
        .y_labels(k)
        .x_label_formatter(&|v| letter(v, false))
        .y_label_formatter(&|v| letter(v, true))
        .draw()?;
    chart.draw_series((0..k).flat_map(|t| (0..k).map(move |p| (t, p))).map(|(t, p)| {
        let row: u32 = confusion[t].iter().sum();
        let f = if row == 0 { 0.0 } else { confusion[t][p] as f64 / row as f64 };
        let shade = (255.0 * (1.0 - f)) as u8;
        let color = if t == p { RGBColor(shade, shade, 255) } else { RGBColor(255, shade, shade) };
        let (x, y) = (SegmentValue::Exact(p), SegmentValue::Exact(k - 1 - t));
        let (x1, y1) = (SegmentValue::Exact(p + 1), SegmentValue::Exact(k - t));
        Rectangle::new([(x, y), (x1, y1)], color.filled())
    }))?;
    root.present().map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(())
}

/// The all-letters report's files in `out`: `letters.md` and `letters.json` (`val_letters.*`
/// for the validation board); the Markdown's path.
pub fn write_letters_report(r: &crate::reports::letters::LettersReport, out: &Path) -> Result<PathBuf> {
    create_dir(out)?;
    let stem = if r.board == "VAL-LETTERS" { "val_letters" } else { "letters" };
    crate::write_json(&out.join(format!("{stem}.json")), r, true)?;
    let md = out.join(format!("{stem}.md"));
    write(&md, &crate::reports::letters::markdown(r))?;
    Ok(md)
}

/// The robustness sweep's files in `out`: `robustness.md`, `robustness.json` and a PNG per
/// nuisance; the Markdown back.
pub fn write_robustness_report(r: &crate::eval::robustness::Report, out: &Path) -> Result<String> {
    create_dir(out)?;
    let md = crate::eval::robustness::markdown(r);
    write(&out.join("robustness.md"), &md)?;
    crate::write_json(&out.join("robustness.json"), r, true)?;
    robustness_figures(r, out)?;
    Ok(md)
}

/// The report's three files in `out`.
pub fn write_words_report(r: &WordsReport, out: &Path) -> Result<()> {
    create_dir(out)?;
    crate::write_json(&out.join("words.json"), r, true)?;
    let speed = out.join("words_speed.png");
    figure(&speed, plot_words(r, &speed))?;
    write(&out.join("words.md"), &crate::reports::words::markdown(r))?;
    Ok(())
}

fn plot_words(r: &WordsReport, path: &Path) -> Drawn {
    use pipeline::reader::{Spell, TimingMode};
    let mut series = Vec::new();
    let lines = [
        (TimingMode::Estimated, Spell::Lexicon),
        (TimingMode::Estimated, Spell::None),
        (TimingMode::Paper, Spell::Lexicon),
        (TimingMode::Given, Spell::Lexicon),
    ];
    for arch in [snn::model_file::Arch::Resnet, snn::model_file::Arch::Snn] {
        for (timing, spell) in lines.into_iter().filter(|(t, _)| r.timings.contains(t)) {
            let points: Vec<(f64, f64)> = r
                .speeds_mm_s
                .iter()
                .filter_map(|&sp| {
                    let s = r.get(arch, timing, sp, false)?;
                    let v = s.by_spell.iter().find(|b| b.spell == spell)?.word_accuracy;
                    // 1 - WER can fall below 0; the plot clips it there (the tables do not)
                    v.is_finite().then_some((sp, 100.0 * v.max(0.0)))
                })
                .collect();
            series.push(Series {
                name: format!("{arch}, {timing} timing, {spell:?}"),
                points,
                emphasis: timing == TimingMode::Estimated,
            });
        }
    }
    word_accuracy_chart(
        "SIMULATED: word accuracy (1 - WER, all printed words) against speed, EV board",
        &r.speeds_mm_s,
        series,
        60.0,
        [("target with the lexicon, 8-32 mm/s: 95%", 95.0), ("target without spelling, 8-32 mm/s: 85%", 85.0)],
    )
    .draw_png(path)
}

/// Word accuracy (%) against speed (mm/s) over `speeds_mm_s`: the y axis from 5 points under the
/// lowest point (or under `floor`, whichever is lower) to 101, with labelled target lines.
fn word_accuracy_chart<'a>(
    title: &'a str,
    speeds_mm_s: &[f64],
    series: Vec<Series>,
    floor: f64,
    targets: [(&str, f64); 2],
) -> LineChart<'a> {
    let lo = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).fold(100.0f64, f64::min).min(floor);
    let (x0, x1) = (
        speeds_mm_s.iter().copied().fold(f64::INFINITY, f64::min) - 2.0,
        speeds_mm_s.iter().copied().fold(0.0, f64::max) + 2.0,
    );
    LineChart {
        title,
        x_desc: "speed (mm/s)",
        y_desc: "word accuracy (%)",
        x: x0..x1,
        y: (lo - 5.0).max(0.0)..101.0,
        x_log10: false,
        series,
        targets: targets.iter().map(|&(label, y)| Target { label: label.into(), y, from_x: None }).collect(),
        legend: SeriesLabelPosition::LowerLeft,
        size: (900, 560),
    }
}

/// The UEB report's files in `out`: `ueb.md`, `ueb.json` and `ueb_speed.png` (validation:
/// `ueb_validation.*`).
pub fn write_ueb_report(r: &crate::reports::ueb::UebReport, out: &Path) -> Result<()> {
    use crate::reports::ueb::markdown;
    create_dir(out)?;
    let stem = if r.spec.held_out == corpus::boards::HeldOut::Test { "ueb" } else { "ueb_validation" };
    crate::write_json(&out.join(format!("{stem}.json")), r, true)?;
    let mut series = Vec::new();
    for arch in [snn::model_file::Arch::Snn, snn::model_file::Arch::Resnet] {
        for (blind, what) in [(false, "exact"), (true, "blind to case and punctuation")] {
            let points: Vec<(f64, f64)> = r
                .sentences
                .iter()
                .filter(|w| w.arch == arch)
                .filter_map(|w| {
                    let p = w.by_spell.iter().find(|p| p.spell == pipeline::reader::Spell::Lexicon)?;
                    let v = if blind { p.blind_word_accuracy } else { p.word_accuracy };
                    v.is_finite().then_some((w.speed_mm_s, 100.0 * v.max(0.0)))
                })
                .collect();
            series.push(Series { name: format!("{arch}, words {what}, lexicon"), points, emphasis: !blind });
        }
    }
    word_accuracy_chart(
        "SIMULATED: UEB contracted sentences, word accuracy (1 - WER, all printed words) against speed",
        &r.spec.speeds_mm_s,
        series,
        80.0,
        [("target at 16 mm/s: 90% (goal 95%)", 90.0), ("target at 32 mm/s: 85%", 85.0)],
    )
    .draw(&out.join(format!("{stem}_speed.png")))?;
    write(&out.join(format!("{stem}.md")), &markdown(r))
}

/// The report's files in `out`; its Markdown.
pub fn write_icub_report(
    data: &Path,
    models: &Path,
    search: Option<&crate::reports::icub::SearchFolders>,
    out: &Path,
) -> Result<String> {
    let rows = icub_rows(data, models, search)?;
    create_dir(out)?;
    let md = crate::reports::icub::markdown(&rows)?;
    write(&out.join("icub.md"), &md)?;
    crate::write_json(&out.join("icub.json"), &rows, true)?;
    let png = out.join("icub.png");
    figure(&png, plot_icub(&rows, &png))?;
    Ok(md)
}

fn plot_icub(rows: &[IcubRow], path: &std::path::Path) -> Drawn {
    register_fonts();
    let root = BitMapBackend::new(path, (900, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, rows.len()));
    for (area, r) in panels.iter().zip(rows) {
        let b = baselines(&r.dataset);
        let mid = |s: &str| -> f64 {
            let v: Vec<f64> = s.split(['-', ' ', '%']).filter_map(|x| x.parse().ok()).collect();
            if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 }
        };
        // the headline (the search's seed mean) where shipped, else the hand-found model
        let ours = r.search.as_ref().map_or(("our SNN (chosen run)", 100.0 * r.accuracy_stepped), |s| {
            ("our SNN, mean of seeds", 100.0 * s.mean)
        });
        let bars = [
            ours,
            ("peer RSNN", b.recurrent_snn),
            ("peer FF", mid(b.feedforward_snn)),
            ("ridge", b.ridge),
            ("LSTM", mid(b.lstm)),
        ];
        let mut chart = ChartBuilder::on(area)
            .caption(format!("iCub {} (real data), test accuracy %", r.dataset), ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(40)
            .build_cartesian_2d((0..bars.len()).into_segmented(), 0.0..100.0)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_label_formatter(&|x| match x {
                SegmentValue::CenterOf(i) => bars.get(*i).map_or(String::new(), |b| b.0.to_string()),
                _ => String::new(),
            })
            .draw()?;
        chart.draw_series(bars.iter().enumerate().map(|(i, &(_, v))| {
            let color = if i == 0 { RGBColor(200, 60, 40) } else { RGBColor(110, 130, 160) };
            let mut bar =
                Rectangle::new([(SegmentValue::Exact(i), 0.0), (SegmentValue::Exact(i + 1), v)], color.filled());
            bar.set_margin(0, 0, 8, 8);
            bar
        }))?;
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(SegmentValue::Exact(0), r.target_percent), (SegmentValue::Exact(bars.len()), r.target_percent)],
            BLACK.stroke_width(1),
        )))?;
        chart.draw_series(std::iter::once(Text::new(
            format!("target {:.0}%", r.target_percent),
            (SegmentValue::Exact(bars.len() - 1), r.target_percent + 2.0),
            ("sans-serif", 13),
        )))?;
    }
    root.present().map_err(|e| format!("{}: {e}", path.display()))?;
    if !path.exists() {
        return Err(format!("{}: not written", path.display()).into());
    }
    Ok(())
}

/// One dot's events against its position (positive: where the dot has been) at 8 and 32 mm/s,
/// with the gel's dynamics and without, normalised to each profile's peak.
pub fn dot_lag_figure(r: &sim::checks::CheckReport, path: &Path) -> Result<()> {
    let mut series = Vec::new();
    for speed in ["8", "32"] {
        let Some(p) = r.dot_profiles.get(speed) else { continue };
        for (name, counts, emphasis) in [
            (format!("{speed} mm/s, gel with dynamics"), &p.events, true),
            (format!("{speed} mm/s, gel without"), &p.events_without_dynamics, false),
        ] {
            let peak = counts.iter().copied().max().unwrap_or(1).max(1) as f64;
            let points = p.position_mm.iter().zip(counts).map(|(&x, &c)| (x, c as f64 / peak)).collect();
            series.push(Series { name, points, emphasis });
        }
    }
    let title = format!("SIMULATED one dot at 1 mm ({} realism): events by position", r.realism);
    LineChart {
        title: &title,
        x_desc: "pixel's position behind the dot (mm; + where the dot has been)",
        y_desc: "events (of the profile's peak)",
        x: -2.0..3.0,
        y: 0.0..1.05,
        x_log10: false,
        series,
        targets: Vec::new(),
        legend: SeriesLabelPosition::UpperRight,
        size: (900, 520),
    }
    .draw(path)
}

/// The robustness sweeps: one PNG per nuisance, `{stem}_{nuisance}.png` beside `stem`.
pub fn robustness_figures(r: &crate::eval::robustness::Report, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for c in &r.curves {
        let name = serde_json::to_value(c.nuisance)
            .map_err(|source| Error::Json { path: dir.to_path_buf(), source })?
            .as_str()
            .unwrap_or("nuisance")
            .to_string();
        let path = dir.join(format!("robustness_{name}.png"));
        // Rates span decades: a log axis.
        let log = c.nuisance == crate::eval::robustness::Nuisance::NoiseRate;
        let x_of = |x: f64| if log { x.log10() } else { x };
        let series = r
            .models
            .iter()
            .enumerate()
            .map(|(k, m)| Series {
                name: m.clone(),
                points: c.levels.iter().zip(&c.accuracy_all_windows[k]).map(|(&x, &a)| (x_of(x), 100.0 * a)).collect(),
                emphasis: true,
            })
            .collect();
        let lo = c.levels.iter().map(|&x| x_of(x)).fold(f64::INFINITY, f64::min);
        let hi = c.levels.iter().map(|&x| x_of(x)).fold(f64::NEG_INFINITY, f64::max);
        let pad = (hi - lo).max(1e-9) * 0.05;
        let title = format!("SIMULATED {} ({} base)", c.label, r.spec.base);
        LineChart {
            title: &title,
            x_desc: c.label,
            y_desc: "characters read right, of all printed (%)",
            x: lo - pad..hi + pad,
            y: 0.0..101.0,
            x_log10: log,
            series,
            targets: Vec::new(),
            legend: SeriesLabelPosition::LowerLeft,
            size: (800, 480),
        }
        .draw(&path)?;
        out.push(path);
    }
    Ok(out)
}
