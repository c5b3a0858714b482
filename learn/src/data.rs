//! Labelled spike trains for training and evaluation, and how they were encoded (recorded in
//! the model file so that evaluation encodes its input the same way).

use encoders::dataset::{Dataset, SampleData, Split};
use encoders::sigma_delta::{self, SigmaDeltaConfig};
use encoders::spike_train::{SpikeTrain, SpikeTrainConfig, SpikeTrainEncoder};
use serde::{Deserialize, Serialize};

/// How a tactile dataset (a folder in the layout of [`encoders::dataset`]) becomes input spikes:
/// analog frames through the sigma-delta encoder, events as they are; then per step of `dt_us`,
/// input `polarity * channels + channel` (OFF first), counts of events, `steps` steps from the
/// sample's start.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TactileEncoding {
    pub channels: usize,
    /// Analog data only.
    pub sigma_delta: Option<SigmaDeltaConfig>,
    /// Sampling period of analog data.
    pub period_us: i64,
    pub dt_us: i64,
    pub steps: usize,
    /// ON and OFF events of a channel into one input (unipolar input: `channels` inputs).
    #[serde(default)]
    pub merge_polarities: bool,
    /// At most one spike per input and step (an OR of the step's events).
    #[serde(default)]
    pub binary: bool,
    /// Only these classes, relabelled in this order (`None`: all of the dataset's).
    #[serde(default)]
    pub classes: Option<Vec<String>>,
    /// Neighbouring channels (by index) summed in groups of this many (1: none).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub channel_pool: usize,
}

fn one() -> usize {
    1
}

fn is_one(v: &usize) -> bool {
    *v == 1
}

/// Labelled spike trains, all of the same input size and step.
#[derive(Debug, Clone)]
pub struct SpikeSet {
    pub n_inputs: usize,
    pub steps: usize,
    pub dt_us: i64,
    pub classes: Vec<String>,
    pub trains: Vec<SpikeTrain>,
    pub labels: Vec<usize>,
    /// Events that fell after the last step (dropped), in all.
    pub dropped_events: u64,
}

impl SpikeSet {
    pub fn len(&self) -> usize {
        self.labels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }

    /// The samples at `idx`, in that order.
    pub fn subset(&self, idx: &[usize]) -> SpikeSet {
        SpikeSet {
            trains: idx.iter().map(|&i| self.trains[i].clone()).collect(),
            labels: idx.iter().map(|&i| self.labels[i]).collect(),
            ..self.empty_like()
        }
    }

    fn empty_like(&self) -> SpikeSet {
        SpikeSet {
            n_inputs: self.n_inputs,
            steps: self.steps,
            dt_us: self.dt_us,
            classes: self.classes.clone(),
            trains: Vec::new(),
            labels: Vec::new(),
            dropped_events: 0,
        }
    }

    /// A stratified split: about `fraction` of each class (at least one where a class has two or
    /// more samples) goes to the second set, chosen by `seed`.
    pub fn stratified_split(&self, fraction: f64, seed: u64) -> (SpikeSet, SpikeSet) {
        use rand::SeedableRng;
        use rand::seq::SliceRandom;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (mut keep, mut held) = (Vec::new(), Vec::new());
        for c in 0..self.classes.len() {
            let mut idx: Vec<usize> = (0..self.len()).filter(|&i| self.labels[i] == c).collect();
            idx.shuffle(&mut rng);
            let n = if idx.len() >= 2 { ((idx.len() as f64 * fraction).round() as usize).max(1) } else { 0 };
            held.extend_from_slice(&idx[..n]);
            keep.extend_from_slice(&idx[n..]);
        }
        keep.sort_unstable();
        held.sort_unstable();
        (self.subset(&keep), self.subset(&held))
    }
}

/// The events of `sample` (sigma-delta encoded when analog).
fn sample_events(
    data: &Dataset,
    sample: &encoders::dataset::Sample,
    enc: &TactileEncoding,
) -> encoders::Result<Vec<encoders::event::Event>> {
    match &sample.data {
        SampleData::Events(ev) => Ok(ev.clone()),
        SampleData::Analog { frames } => {
            let sd = enc.sigma_delta.clone().unwrap_or_default();
            sigma_delta::encode(&sd, frames, data.channels, enc.period_us).map_err(|e| match e {
                encoders::Error::Config { setting, what } => {
                    encoders::Error::Config { setting, what: format!("sample {}: {what}", sample.id) }
                }
                other => other,
            })
        }
    }
}

impl TactileEncoding {
    /// The encoding for `data` with step `dt_us`, sized to the longest sample of its training
    /// split: validation and test samples choose nothing (a longer one is cut at the last step,
    /// as a stream longer than a model's window would be). Before 2026-11-26 every split sized it.
    pub fn fit(data: &Dataset, sigma_delta: SigmaDeltaConfig, dt_us: i64) -> encoders::Result<TactileEncoding> {
        let mut enc = TactileEncoding {
            channels: data.channels,
            sigma_delta: (data.kind == encoders::dataset::DatasetKind::Analog).then_some(sigma_delta),
            period_us: data.period_us,
            dt_us,
            steps: 0,
            merge_polarities: false,
            binary: false,
            classes: None,
            channel_pool: 1,
        };
        let mut end = 0i64;
        for s in data.samples.iter().filter(|s| s.split == Split::Train) {
            end = end.max(match &s.data {
                SampleData::Events(ev) => ev.last().map_or(0, |e| e.t_us + 1),
                SampleData::Analog { frames } => (frames.len() / data.channels.max(1)) as i64 * data.period_us,
            });
        }
        enc.steps = (end.max(1) as u64).div_ceil(dt_us as u64) as usize;
        Ok(enc)
    }

    pub fn n_inputs(&self) -> usize {
        let cells = self.channels.div_ceil(self.channel_pool.max(1));
        if self.merge_polarities { cells } else { 2 * cells }
    }

    /// The spike-train encoder of this encoding for a sensor of `resolution` (channels along x).
    pub fn encoder(&self, resolution: encoders::Resolution) -> encoders::Result<SpikeTrainEncoder> {
        let mut cfg = SpikeTrainConfig::new(resolution);
        cfg.dt_us = self.dt_us;
        cfg.pool = self.channel_pool.max(1).min(u16::MAX as usize) as u16;
        cfg.binary = self.binary;
        cfg.merge_polarities = self.merge_polarities;
        SpikeTrainEncoder::new(cfg)
    }

    /// The dataset as this encoding sees it: its class subset, if it has one.
    pub fn select<'d>(&self, data: &'d Dataset) -> encoders::Result<std::borrow::Cow<'d, Dataset>> {
        Ok(match &self.classes {
            Some(names) => std::borrow::Cow::Owned(data.select_classes(names)?),
            None => std::borrow::Cow::Borrowed(data),
        })
    }

    /// One sample's input events as the engine takes them, `(t_us, input)` in time order, within
    /// the encoding's `steps` (events after them are left out, as [`Self::encode`] leaves them).
    /// Unlike a spike train, every sensor event stays an event, so that an engine summing a step's
    /// events (value 1 each) gets the train's counts; with `binary`, only the first event of an
    /// input in a step is kept (the OR). `data` is the dataset as [`Self::select`] gives it.
    pub fn events_of(
        &self,
        data: &Dataset,
        sample: &encoders::dataset::Sample,
        encoder: &SpikeTrainEncoder,
    ) -> encoders::Result<Vec<(i64, u32)>> {
        let end = self.dt_us * self.steps as i64;
        let mut out: Vec<(i64, u32)> = sample_events(data, sample, self)?
            .iter()
            .filter(|e| (0..end).contains(&e.t_us))
            .filter_map(|e| encoder.input_of(e).map(|i| (e.t_us, i)))
            .collect();
        out.sort_by_key(|&(t, _)| t);
        if self.binary {
            let mut seen = std::collections::HashSet::new();
            out.retain(|&(t, i)| seen.insert((t / self.dt_us, i)));
        }
        Ok(out)
    }

    /// Encodes the samples of `split` (all samples for `None`).
    pub fn encode(&self, data: &Dataset, split: Option<Split>) -> encoders::Result<SpikeSet> {
        if data.channels != self.channels {
            return Err(encoders::Error::config(
                "channels",
                format!(
                    "{}: {} channels, the model was trained on {}",
                    data.dir.display(),
                    data.channels,
                    self.channels
                ),
            ));
        }
        let data = &*self.select(data)?;
        let encoder = self.encoder(data.resolution())?;
        let mut set = SpikeSet {
            n_inputs: self.n_inputs(),
            steps: self.steps,
            dt_us: self.dt_us,
            classes: data.classes.clone(),
            trains: Vec::new(),
            labels: Vec::new(),
            dropped_events: 0,
        };
        for s in data.samples.iter().filter(|s| split.is_none_or(|sp| s.split == sp)) {
            let events = sample_events(data, s, self)?;
            let train = encoder.encode(&events, 0, self.steps);
            set.dropped_events += events.len() as u64 - train.total();
            set.trains.push(train);
            set.labels.push(s.label);
        }
        Ok(set)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use encoders::dataset::{DatasetKind, Sample};
    use encoders::{Event, Polarity};

    #[test]
    fn the_encoding_is_fitted_on_the_training_split_alone() {
        let sample = |id, split, end_us: i64| Sample {
            id,
            label: 0,
            split,
            data: SampleData::Events(vec![Event::new(0, 0, 0, Polarity::On), Event::new(end_us, 1, 0, Polarity::Off)]),
        };
        let mut data = Dataset {
            dir: "in-memory".into(),
            kind: DatasetKind::Events,
            classes: vec!["A".into()],
            channels: 2,
            period_us: 0,
            samples: vec![sample(0, Split::Train, 49_999), sample(1, Split::Train, 99_999)],
        };
        let fitted = |d: &Dataset| TactileEncoding::fit(d, SigmaDeltaConfig::default(), 10_000).unwrap().steps;
        // the longest training sample ends at 99 999 us: ten steps of 10 ms
        assert_eq!(fitted(&data), 10);
        // a test sample ten times as long, and a validation one, change nothing
        data.samples.push(sample(2, Split::Test, 999_999));
        data.samples.push(sample(3, Split::Validation, 499_999));
        assert_eq!(fitted(&data), 10);
        // and the long test sample is encoded within those steps, cut at their end
        let enc = TactileEncoding::fit(&data, SigmaDeltaConfig::default(), 10_000).unwrap();
        let test = enc.encode(&data, Some(Split::Test)).unwrap();
        assert_eq!((test.steps, test.len()), (10, 1));
    }
}
