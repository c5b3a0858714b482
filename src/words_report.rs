//! `braille words-report`: the paper's speed table on SIMULATED EV scans for both architectures,
//! with and without spelling (Markdown, JSON and a plot).

use crate::charts::{LineChart, Series, Target};
use crate::common::Bar;
use anyhow::{Context, Result};
use experiments::reports::words::{WordsReport, markdown, words_report};
use plotters::prelude::SeriesLabelPosition;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Where to write `words.md`, `words.json` and `words_speed.png`.
    #[arg(long, default_value = "docs")]
    out: PathBuf,
    /// EV scans per row and speed (the paper: 30).
    #[arg(long, default_value_t = 30)]
    trials: u64,
    #[arg(long, value_delimiter = ',', default_value = "8,16,24,32")]
    speeds: Vec<f64>,
    #[arg(long, default_value_t = 1.5)]
    depth: f64,
    #[arg(long, default_value_t = 1_000_003)]
    seed: u64,
}

pub fn run(args: Args) -> Result<()> {
    let models = crate::common::repo_path("models");
    let r = words_report(&models, &args.speeds, args.depth, args.trials, args.seed, &Bar::default())?;
    write(&r, &args.out)
}

/// The report's three files in `out`.
pub fn write(r: &WordsReport, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    experiments::write_json(&out.join("words.json"), r, true)?;
    plot(r, &out.join("words_speed.png"))?;
    std::fs::write(out.join("words.md"), markdown(r)).with_context(|| format!("writing {}", out.display()))?;
    eprintln!("wrote {}/words.md, words.json, words_speed.png", out.display());
    Ok(())
}

fn plot(r: &WordsReport, path: &Path) -> Result<()> {
    let mut series = Vec::new();
    for arch in [snn::model_file::Arch::Resnet, snn::model_file::Arch::Snn] {
        for spell in experiments::words::SPELLS {
            let points: Vec<(f64, f64)> = r
                .scores
                .iter()
                .zip(&r.speeds_mm_s)
                .filter_map(|(row, &sp)| {
                    let s = row.iter().find(|s| s.arch == arch)?;
                    let v = s.by_spell.iter().find(|b| b.spell == spell)?.correct_words;
                    v.is_finite().then_some((sp, 100.0 * v))
                })
                .collect();
            series.push(Series {
                name: format!("{arch}, {spell:?}"),
                points,
                emphasis: arch == snn::model_file::Arch::Snn,
            });
        }
    }
    let lo = series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).fold(100.0f64, f64::min).min(60.0);
    let (x0, x1) = (
        r.speeds_mm_s.iter().copied().fold(f64::INFINITY, f64::min) - 2.0,
        r.speeds_mm_s.iter().copied().fold(0.0, f64::max) + 2.0,
    );
    LineChart {
        title: "SIMULATED: correct words against speed, EV board",
        x_desc: "speed (mm/s)",
        y_desc: "correct words (%)",
        x: x0..x1,
        y: (lo - 5.0).max(0.0)..101.0,
        x_log10: false,
        series,
        targets: vec![
            Target { label: "target with the lexicon: 97%".into(), y: 97.0 },
            Target { label: "target without spelling: 90%".into(), y: 90.0 },
        ],
        legend: SeriesLabelPosition::LowerLeft,
        size: (900, 520),
    }
    .draw(path)
}
