//! `braille icub-report`: the shipped SNNs on the real iCub Braille recordings (fixed test
//! splits), run by the event-driven engine, beside the published and measured baselines; a
//! Markdown table and a bar chart.

use anyhow::{Context, Result, bail};
use experiments::reports::icub::{IcubRow, baselines, icub_rows, markdown};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Folder holding the dataset folders `raw1350` and `th10`.
    #[arg(long, default_value = "data/icub_braille")]
    data: PathBuf,
    /// Folder holding `snn-raw1350.safetensors` and `snn-th10.safetensors`.
    #[arg(long, default_value = "models")]
    models: PathBuf,
    /// Where to write `icub.md`, `icub.json` and `icub.png`.
    #[arg(long, default_value = "docs")]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let md = write(&args.data, &args.models, &args.out)?;
    print!("{md}");
    Ok(())
}

/// The report's files in `out`; its Markdown.
pub fn write(data: &Path, models: &Path, out: &Path) -> Result<String> {
    let rows = icub_rows(data, models)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let md = markdown(&rows)?;
    std::fs::write(out.join("icub.md"), &md)?;
    std::fs::write(out.join("icub.json"), serde_json::to_string_pretty(&rows)? + "\n")?;
    plot(&rows, &out.join("icub.png"))?;
    Ok(md)
}

fn plot(rows: &[IcubRow], path: &std::path::Path) -> Result<()> {
    crate::charts::register_fonts();
    let root = BitMapBackend::new(path, (900, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, rows.len()));
    for (area, r) in panels.iter().zip(rows) {
        let b = baselines(&r.dataset);
        let mid = |s: &str| -> f64 {
            let v: Vec<f64> = s.split(['-', ' ', '%']).filter_map(|x| x.parse().ok()).collect();
            if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 }
        };
        let bars = [
            ("our SNN", 100.0 * r.accuracy_stepped),
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
    }
    root.present().map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    if !path.exists() {
        bail!("{}: not written", path.display());
    }
    Ok(())
}
