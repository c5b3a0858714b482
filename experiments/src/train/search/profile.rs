//! What the training split looks like, measured before any choice, and the recipe derived from it.

use super::*;

/// What the training split looks like, measured before any choice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataProfile {
    /// The folder's name.
    pub data: String,
    /// `events` or `analog`.
    pub kind: String,
    pub channels: usize,
    pub classes: usize,
    pub train_samples: usize,
    /// The 95th percentile of the training samples' durations (last event, or frames times
    /// the sampling period).
    pub duration_us: i64,
    /// Event data: mean events per training sample.
    pub events_per_sample: Option<f64>,
    /// Analog data: the median of the non-zero absolute changes between consecutive frames of a
    /// channel (the signal's step), which becomes the sigma-delta threshold.
    pub signal_step: Option<f32>,
    pub period_us: i64,
}

impl DataProfile {
    /// Measures the training split of `data`.
    pub fn of(data: &Dataset) -> Result<DataProfile> {
        let mut durations = Vec::new();
        let (mut events, mut steps) = (0usize, Vec::new());
        for s in data.split(Split::Train) {
            match &s.data {
                SampleData::Events(ev) => {
                    events += ev.len();
                    durations.push(ev.last().map_or(0, |e| e.t_us + 1));
                }
                SampleData::Analog { frames } => {
                    let c = data.channels.max(1);
                    durations.push((frames.len() / c) as i64 * data.period_us);
                    for ch in 0..c {
                        let mut last: Option<f32> = None;
                        for v in frames.iter().skip(ch).step_by(c) {
                            if let Some(l) = last {
                                let d = (v - l).abs();
                                if d > 0.0 {
                                    steps.push(d);
                                }
                            }
                            last = Some(*v);
                        }
                    }
                }
            }
        }
        if durations.is_empty() {
            return Err(Error::Data { path: data.dir.clone(), what: "no training samples".into() });
        }
        durations.sort_unstable();
        let p95 = durations[((durations.len() - 1) as f64 * 0.95).round() as usize];
        let n = durations.len();
        let signal_step = (!steps.is_empty()).then(|| {
            steps.sort_unstable_by(f32::total_cmp);
            steps[steps.len() / 2]
        });
        Ok(DataProfile {
            data: data.dir.file_name().map_or_else(|| data.dir.display().to_string(), |f| f.to_string_lossy().into()),
            kind: match data.kind {
                DatasetKind::Events => "events".into(),
                DatasetKind::Analog => "analog".into(),
            },
            channels: data.channels,
            classes: data.classes.len(),
            train_samples: n,
            duration_us: p95.max(1),
            events_per_sample: (data.kind == DatasetKind::Events).then(|| events as f64 / n as f64),
            signal_step,
            period_us: data.period_us,
        })
    }
}

impl std::fmt::Display for DataProfile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} data, {} channels, {} classes, {} training samples, duration (95th percentile) {:.0} ms",
            self.data,
            self.kind,
            self.channels,
            self.classes,
            self.train_samples,
            self.duration_us as f64 / 1000.0
        )?;
        if let Some(e) = self.events_per_sample {
            write!(f, ", {e:.1} events per sample")?;
        }
        if let Some(v) = self.signal_step {
            write!(f, ", the signal's median step {v}")?;
        }
        Ok(())
    }
}

/// The largest of 1, 2 and 5 times a power of ten that is at most `x` (at least 1).
pub fn nice_floor(x: f64) -> f64 {
    if x < 1.0 {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    [5.0, 2.0, 1.0].into_iter().map(|m| m * p).find(|&v| v <= x).unwrap_or(p)
}

/// The recipe the data implies (docs/training.md, "Defaults from the data"):
/// - step: the 1-2-5 value at most 1/100 of the samples' duration (95th percentile);
/// - hidden membrane time constant 1/12 of the duration, synaptic half of that, readout 1/3;
/// - analog data: the sigma-delta threshold at the signal's median step;
/// - the hidden layer recurrent with its recurrent weights starting at zero (the network starts
///   feed-forward and grows its recurrence), neuron dropout 0.2, a bias, weights at half
///   PyTorch's initial scale, Adam 1e-3 with the gradient norm clipped to 1, 100 epochs, the
///   weights averaged over the last 30 (competing with the best checkpoint on a 10% hold-out);
///   these fixed choices come from the th10 recipe; the search's neighbour trials measure each of
///   them again on validation (docs/training.md);
/// - a learning-rate warm-up over the first [`WARMUP_STEPS`] steps (chosen on validation).
pub fn derived_recipe(p: &DataProfile) -> SnnRecipe {
    let d = p.duration_us as f64;
    let dt_us = (nice_floor(d / 100.0) as i64).max(1);
    let tau_mem_us = (d / 12.0).max(dt_us as f64);
    let base = SnnRecipe::default();
    SnnRecipe {
        period_us: if p.period_us > 0 { p.period_us } else { base.period_us },
        sigma_delta: p.signal_step.unwrap_or(base.sigma_delta),
        dt_us,
        tau_mem_us,
        tau_syn_us: tau_mem_us / 2.0,
        tau_out_us: (d / 3.0).max(dt_us as f64),
        recurrent: true,
        recurrent_init_gain: Some(0.0),
        dropout: 0.2,
        bias: true,
        init_gain: 0.5,
        lr: 1e-3,
        warmup_steps: WARMUP_STEPS,
        clip_norm: 1.0,
        epochs: 100,
        average_epochs: 30,
        ..base
    }
}
