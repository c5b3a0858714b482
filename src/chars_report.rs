//! `braille chars-report`: the paper's Table I (Raw / Norm / Aug / NormAug) and its depth figure
//! on SIMULATED scans of the RAB board at 8 mm/s, with the SNN beside the ResNet on the same
//! windows, and confusion matrices. Markdown, JSON and PNG.

use crate::charts::{LineChart, Series, Target};
use crate::common::Bar;
use anyhow::{Context, Result};
use experiments::reports::chars::{CharsReport, chars_report, markdown};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Folder holding `resnet-lite-{raw,norm,aug,normaug}.safetensors` and `snn-chars.safetensors`
    /// (`scripts/table1.sh`), and the `+ words` models (`scripts/words.sh`); missing models are
    /// left out.
    #[arg(long, default_value = "models")]
    models: PathBuf,
    /// Where to write `chars.md`, `chars.json`, `chars_depth.png` and the confusion PNGs.
    #[arg(long, default_value = "docs")]
    out: PathBuf,
    /// RAB scans per board row and depth. 30 (about 720 windows a depth): the same model scored
    /// 97.9% and 99.1% at 1.5 mm on two sets of 10 scans, too coarse for a 1.5-point comparison.
    #[arg(long, default_value_t = 30)]
    trials: u64,
    /// Scan seed of the test scans (training used others).
    #[arg(long, default_value_t = 1_000_003)]
    seed: u64,
    /// Depths to test, in mm [default: the paper's 0.2-1.5 mm].
    #[arg(long, value_delimiter = ',')]
    depths: Vec<f64>,
}

pub fn run(args: Args) -> Result<()> {
    let report = chars_report(&args.models, &args.depths, args.trials, args.seed, &Bar::default())?;
    let md = write(&report, &args.out)?;
    print!("{md}");
    Ok(())
}

/// The report's files in `out`; its Markdown.
pub fn write(report: &CharsReport, out: &Path) -> Result<String> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let md = markdown(report)?;
    std::fs::write(out.join("chars.md"), &md)?;
    std::fs::write(out.join("chars.json"), serde_json::to_string_pretty(report)? + "\n")?;
    plot_depth(report, &out.join("chars_depth.png"))?;
    let at = report.table_depth();
    for e in report.entries.iter().filter(|e| ["normaug", "snn"].contains(&e.key)) {
        let file = format!("chars_confusion_{}.png", e.key);
        let title = format!("{}: RAB {} mm, SIMULATED (rows truth, columns predicted)", e.name, report.depths_mm[at]);
        plot_confusion(&e.scores[at].confusion, &title, &out.join(file))?;
    }
    Ok(md)
}

fn plot_depth(r: &CharsReport, path: &Path) -> Result<()> {
    let series: Vec<Series> = r
        .entries
        .iter()
        .map(|e| Series {
            name: e.name.clone(),
            points: r.depths_mm.iter().zip(&e.scores).map(|(&d, s)| (d, 100.0 * s.accuracy)).collect(),
            emphasis: e.arch == snn::model_file::Arch::Snn,
        })
        .collect();
    let lo = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).fold(100.0f64, f64::min).min(90.0);
    LineChart {
        title: "SIMULATED: accuracy against depth, RAB at 8 mm/s",
        x_desc: "indentation depth (mm)",
        y_desc: "accuracy (%)",
        x: 0.1..1.6,
        y: (lo - 2.0).max(0.0)..100.5,
        x_log10: false,
        series,
        targets: vec![Target { label: "target: 95% from 0.6 mm".into(), y: 95.0 }],
        legend: SeriesLabelPosition::LowerRight,
        size: (900, 520),
    }
    .draw(path)
}

fn plot_confusion(confusion: &[Vec<u32>], title: &str, path: &Path) -> Result<()> {
    crate::charts::register_fonts();
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
    root.present().map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(())
}
