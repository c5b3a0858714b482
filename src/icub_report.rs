//! `braille icub-report`: the shipped SNNs on the real iCub Braille recordings (fixed test
//! splits), run by the event-driven engine, beside the published and measured baselines; a
//! Markdown table and a bar chart.

use anyhow::{Context, Result, bail};
use encoders::dataset::{Dataset, Split};
use learn::data::TactileEncoding;
use plotters::prelude::*;
use serde::Serialize;
use snn::engine::Mode;
use snn::model_file::SnnModel;
use std::fmt::Write as _;
use std::path::PathBuf;

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

/// Baselines on exactly these files and splits (../shared/data/icub_braille/README.md): peers'
/// snnTorch / torch runs, 10 ms bins, 256 hidden, BPTT, early stopping.
struct Baselines {
    recurrent_snn: f64,
    feedforward_snn: &'static str,
    ridge: f64,
    lstm: &'static str,
}

fn baselines(name: &str) -> Baselines {
    match name {
        "raw1350" => Baselines {
            recurrent_snn: 78.9,
            feedforward_snn: "80.4-84.8%",
            ridge: 91.1,
            lstm: "93.3-98.9% (raw frames)",
        },
        _ => Baselines { recurrent_snn: 62.7, feedforward_snn: "31.9%", ridge: 41.6, lstm: "65.6-67.4%" },
    }
}

#[derive(Serialize)]
struct Row {
    dataset: String,
    model: String,
    target_percent: f64,
    accuracy_stepped: f64,
    accuracy_async: Option<f64>,
    n: usize,
    input_events_per_sample: f64,
    synops_per_sample: f64,
    spikes_per_sample: f64,
    network: String,
    provenance: serde_json::Value,
}

pub fn run(args: Args) -> Result<()> {
    let mut rows = Vec::new();
    for (name, target) in [("raw1350", 95.0), ("th10", 75.0)] {
        let model_path = args.models.join(format!("snn-{name}.safetensors"));
        let model = SnnModel::load(&model_path)?;
        let encoding: TactileEncoding = serde_json::from_value(model.preprocess.clone())
            .with_context(|| format!("{}: header `preprocess` is not a tactile encoding", model_path.display()))?;
        let data = Dataset::load(&args.data.join(name), encoding.period_us)?;
        let test = encoding.encode(&data, Some(Split::Test))?;
        let stepped = crate::eval::snn_accuracy_in(&model.network, &model.config, &test, Mode::Stepped)?;
        // Async mode runs LIF and IF layers without bias or recurrence.
        let async_ok = crate::chars::async_capable(&model.network, model.config.dt_us);
        let asynchronous = if async_ok {
            Some(crate::eval::snn_accuracy_in(&model.network, &model.config, &test, Mode::Async)?.accuracy)
        } else {
            None
        };
        let spec = &model.config.network;
        let network = spec
            .layers
            .iter()
            .map(|l| {
                let n = match l.op {
                    snn::spec::OpSpec::Dense { n_out } => n_out.to_string(),
                    other => format!("{other:?}"),
                };
                let kind = l.neurons.map_or("-".to_string(), |p| format!("{:?}", p.kind));
                format!("{n} {kind}{}", if l.recurrent { " (recurrent)" } else { "" })
            })
            .collect::<Vec<_>>()
            .join(" -> ");
        rows.push(Row {
            dataset: name.to_string(),
            model: model_path.display().to_string(),
            target_percent: target,
            accuracy_stepped: stepped.accuracy,
            accuracy_async: asynchronous,
            n: stepped.n,
            input_events_per_sample: stepped.input_events_per_sample,
            synops_per_sample: stepped.synops_per_sample,
            spikes_per_sample: stepped.spikes_per_sample,
            network: format!("{} inputs -> {network}, dt {} ms", spec.input_shape[0], model.config.dt_us as f64 / 1e3),
            provenance: model.provenance.clone(),
        });
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut md = String::new();
    writeln!(md, "# The SNN on real tactile Braille (iCub fingertip, 12 taxels)\n")?;
    writeln!(
        md,
        "Regenerate: `braille icub-report` (models from `scripts/train_icub.sh`). Test splits fixed by the data's `split.csv`; accuracy of the shipped models run by the event-driven engine. Baselines: snnTorch / torch runs on exactly these files and splits (data/icub_braille/README.md).\n"
    )?;
    writeln!(
        md,
        "| data | target | our SNN (engine, stepped) | async engine | peers' recurrent SNN | peers' feed-forward SNN | ridge on 100 ms counts | LSTM |"
    )?;
    writeln!(md, "| --- | --- | --- | --- | --- | --- | --- | --- |")?;
    for r in &rows {
        let b = baselines(&r.dataset);
        writeln!(
            md,
            "| {} | {:.0}% | **{:.1}%** ({}/{}) | {} | {:.1}% | {} | {:.1}% | {} |",
            r.dataset,
            r.target_percent,
            100.0 * r.accuracy_stepped,
            (r.accuracy_stepped * r.n as f64).round(),
            r.n,
            r.accuracy_async.map_or("n/a (CubaLIF needs stepped mode)".to_string(), |a| format!("{:.1}%", 100.0 * a)),
            b.recurrent_snn,
            b.feedforward_snn,
            b.ridge,
            b.lstm
        )?;
    }
    use snn::energy::{CMOS45_ADD, LOIHI_SYNOP, TRUENORTH_SYNOP};
    writeln!(
        md,
        "\n| data | network | input events / sample | synops / sample | spikes / sample | energy / sample: Loihi | TrueNorth | 45 nm float add |"
    )?;
    writeln!(md, "| --- | --- | --- | --- | --- | --- | --- | --- |")?;
    for r in &rows {
        writeln!(
            md,
            "| {} | {} | {:.0} | {:.0} | {:.0} | {:.2} uJ | {:.2} uJ | {:.3} uJ |",
            r.dataset,
            r.network,
            r.input_events_per_sample,
            r.synops_per_sample,
            r.spikes_per_sample,
            LOIHI_SYNOP.nanojoules(r.synops_per_sample) / 1e3,
            TRUENORTH_SYNOP.nanojoules(r.synops_per_sample) / 1e3,
            CMOS45_ADD.nanojoules(r.synops_per_sample) / 1e3
        )?;
    }
    writeln!(
        md,
        "\nEnergy: SynOps times published energies per synaptic operation (`snn::energy`; {} pJ, {}; {} pJ, {}; {} pJ, {}), synaptic work only.",
        LOIHI_SYNOP.pj_per_op,
        LOIHI_SYNOP.source,
        TRUENORTH_SYNOP.pj_per_op,
        TRUENORTH_SYNOP.source,
        CMOS45_ADD.pj_per_op,
        CMOS45_ADD.source
    )?;
    std::fs::write(args.out.join("icub.md"), &md)?;
    std::fs::write(args.out.join("icub.json"), serde_json::to_string_pretty(&rows)? + "\n")?;
    plot(&rows, &args.out.join("icub.png"))?;
    print!("{md}");
    Ok(())
}

fn plot(rows: &[Row], path: &std::path::Path) -> Result<()> {
    crate::plot::register_fonts();
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
