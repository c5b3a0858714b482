//! The shipped SNNs on the real iCub Braille recordings (fixed test splits), run by the
//! event-driven engine, beside the published and measured baselines.

use crate::error::Result;
use crate::eval::tactile::{SplitChoice, async_capable, encoding_of, load_split, snn_accuracy};
use serde::Serialize;
use snn::engine::Mode;
use std::fmt::Write as _;
use std::path::Path;

/// Baselines on exactly these files and splits (../shared/data/icub_braille/README.md): peers'
/// snnTorch / torch runs, 10 ms bins, 256 hidden, BPTT, early stopping.
pub struct Baselines {
    pub recurrent_snn: f64,
    pub feedforward_snn: &'static str,
    pub ridge: f64,
    pub lstm: &'static str,
}

pub fn baselines(name: &str) -> Baselines {
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

/// One shipped model on its test split.
#[derive(Debug, Clone, Serialize)]
pub struct IcubRow {
    pub dataset: String,
    pub model: String,
    pub target_percent: f64,
    pub accuracy_stepped: f64,
    pub accuracy_async: Option<f64>,
    pub n: usize,
    pub input_events_per_sample: f64,
    pub synops_per_sample: f64,
    pub spikes_per_sample: f64,
    pub network: String,
    pub provenance: serde_json::Value,
}

/// The shipped SNNs under `models` (`snn-raw1350`, `snn-th10`) on the test splits of the
/// dataset folders under `data`, run by the event-driven engine.
pub fn icub_rows(data: &Path, models: &Path) -> Result<Vec<IcubRow>> {
    let mut rows = Vec::new();
    for (name, target) in [("raw1350", 95.0), ("th10", 75.0)] {
        let model_path = models.join(format!("snn-{name}.safetensors"));
        let model = pipeline::models::load_snn(&model_path)?;
        let encoding = encoding_of(&model, &model_path)?;
        let test = load_split(&data.join(name), &encoding, SplitChoice::Test)?;
        let stepped = snn_accuracy(&model.network, &model.config, &test, Mode::Stepped)?;
        // Async mode runs LIF and IF layers without bias or recurrence.
        let asynchronous = if async_capable(&model.network, model.config.dt_us) {
            Some(snn_accuracy(&model.network, &model.config, &test, Mode::Async)?.accuracy)
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
        rows.push(IcubRow {
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
    Ok(rows)
}

/// The rows as Markdown, beside the baselines and with energy estimates.
pub fn markdown(rows: &[IcubRow]) -> Result<String> {
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
    for r in rows {
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
    for r in rows {
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
    Ok(md)
}
