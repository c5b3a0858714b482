//! Events as input spikes for a spiking network: per time step of `dt_us`, the list of input
//! neurons that received events, in a compressed sparse form.
//!
//! Input neuron index is `(polarity * height + row) * width + col` over the pooled grid, the same
//! layout as one bin of a [`crate::heatmap::Heatmap`], so the dense and the sparse views agree.

use crate::error::{Error, Result};
use crate::event::{Event, Resolution};
use crate::pooling::{self, PoolMap};
use serde::{Deserialize, Serialize};
use std::ops::Range;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpikeTrainConfig {
    /// Simulation time step.
    pub dt_us: i64,
    /// Spatial pooling factor along x and y.
    pub pool: u16,
    pub sensor: Resolution,
    /// Keep only these pooled columns (half-open).
    pub mask_cols: Option<Range<u16>>,
    /// Clamp counts to 1: an input spikes at most once per step.
    pub binary: bool,
    /// ON and OFF events of a cell into one input (unipolar input): `n_inputs` is then the pooled
    /// grid's size, not twice it.
    #[serde(default)]
    pub merge_polarities: bool,
}

impl Default for SpikeTrainConfig {
    fn default() -> Self {
        Self {
            dt_us: 1_000,
            pool: 4,
            sensor: Resolution::DVXPLORER,
            mask_cols: None,
            binary: false,
            merge_polarities: false,
        }
    }
}

impl SpikeTrainConfig {
    pub fn new(sensor: Resolution) -> Self {
        Self { sensor, ..Self::default() }
    }

    pub fn output(&self) -> Resolution {
        pooling::pooled(self.sensor, self.pool)
    }

    /// Number of input neurons: two polarities over the pooled grid (one with
    /// `merge_polarities`).
    pub fn n_inputs(&self) -> usize {
        if self.merge_polarities { self.output().pixels() } else { 2 * self.output().pixels() }
    }
}

/// Input spikes, step by step: the inputs of step `k` are `inputs[offsets[k]..offsets[k + 1]]`,
/// sorted and distinct, with the number of events each received in `counts`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpikeTrain {
    pub t_start_us: i64,
    pub dt_us: i64,
    pub n_inputs: usize,
    pub offsets: Vec<u32>,
    pub inputs: Vec<u32>,
    pub counts: Vec<u16>,
}

impl SpikeTrain {
    pub fn n_steps(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The active inputs of step `k` and their counts.
    pub fn step(&self, k: usize) -> (&[u32], &[u16]) {
        let r = self.offsets[k] as usize..self.offsets[k + 1] as usize;
        (&self.inputs[r.clone()], &self.counts[r])
    }

    /// Sum of all counts.
    pub fn total(&self) -> u64 {
        self.counts.iter().map(|&c| c as u64).sum()
    }

    /// The sparse form of a dense `[step][input]` matrix of event counts (the inverse of
    /// [`SpikeTrain::to_dense`]; a heat map's bins read this way are its spike train). Counts are
    /// rounded and saturate at `u16::MAX`; zero and negative entries are no spike.
    pub fn from_dense(t_start_us: i64, dt_us: i64, n_inputs: usize, dense: &[f32]) -> SpikeTrain {
        let steps = dense.len().checked_div(n_inputs).unwrap_or(0);
        let mut t =
            SpikeTrain { t_start_us, dt_us, n_inputs, offsets: vec![0], inputs: Vec::new(), counts: Vec::new() };
        for k in 0..steps {
            for (i, &v) in dense[k * n_inputs..(k + 1) * n_inputs].iter().enumerate() {
                let c = v.round();
                if c >= 1.0 {
                    t.inputs.push(i as u32);
                    t.counts.push(c.min(u16::MAX as f32) as u16);
                }
            }
            t.offsets.push(t.inputs.len() as u32);
        }
        t
    }

    /// The dense `[step][input]` matrix, for time-stepped networks.
    pub fn to_dense(&self) -> Vec<f32> {
        let mut d = vec![0f32; self.n_steps() * self.n_inputs];
        for k in 0..self.n_steps() {
            let (inputs, counts) = self.step(k);
            for (&i, &c) in inputs.iter().zip(counts) {
                d[k * self.n_inputs + i as usize] = c as f32;
            }
        }
        d
    }
}

#[derive(Debug, Clone)]
pub struct SpikeTrainEncoder {
    config: SpikeTrainConfig,
    plane: u32,
    map: PoolMap,
}

impl SpikeTrainEncoder {
    pub fn new(config: SpikeTrainConfig) -> Result<Self> {
        if config.dt_us <= 0 {
            return Err(Error::config("dt_us", format!("must be positive, got {}", config.dt_us)));
        }
        let map = PoolMap::new(config.sensor, config.pool, config.mask_cols.as_ref())?;
        Ok(Self { plane: if config.merge_polarities { 0 } else { map.output.pixels() as u32 }, config, map })
    }

    pub fn config(&self) -> &SpikeTrainConfig {
        &self.config
    }

    /// The input index of an event, or `None` if it falls outside the sensor or the mask.
    #[inline]
    pub fn input_of(&self, e: &Event) -> Option<u32> {
        self.map.cell(e.x, e.y).map(|cell| e.polarity.index() as u32 * self.plane + cell)
    }

    /// The spike train of `steps` steps from `t_start_us`, from events in time order (events out
    /// of order are placed correctly too).
    pub fn encode(&self, events: &[Event], t_start_us: i64, steps: usize) -> SpikeTrain {
        let dt = self.config.dt_us;
        let t_end = t_start_us + dt * steps as i64;
        let mut per_step: Vec<Vec<u32>> = vec![Vec::new(); steps];
        for e in events {
            if e.t_us < t_start_us || e.t_us >= t_end {
                continue;
            }
            if let Some(i) = self.input_of(e) {
                per_step[((e.t_us - t_start_us) / dt) as usize].push(i);
            }
        }
        let mut train = SpikeTrain {
            t_start_us,
            dt_us: dt,
            n_inputs: self.config.n_inputs(),
            offsets: Vec::with_capacity(steps + 1),
            inputs: Vec::new(),
            counts: Vec::new(),
        };
        train.offsets.push(0);
        for mut step in per_step {
            step.sort_unstable();
            let mut k = 0;
            while k < step.len() {
                let mut j = k;
                while j < step.len() && step[j] == step[k] {
                    j += 1;
                }
                let n = (j - k).min(u16::MAX as usize) as u16;
                train.inputs.push(step[k]);
                train.counts.push(if self.config.binary { 1 } else { n });
                k = j;
            }
            train.offsets.push(train.inputs.len() as u32);
        }
        train
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event::Polarity;
    use crate::heatmap::{HeatmapConfig, HeatmapEncoder};
    use proptest::prelude::*;

    proptest! {
        /// The dense view of the spike train equals the heat map with the same bins.
        #[test]
        fn agrees_with_heatmap(raw in prop::collection::vec((0i64..50_000, 0u16..40, 0u16..30, any::<bool>()), 0..300),
                               pool in 1u16..5) {
            let mut raw = raw;
            raw.sort_by_key(|e| e.0);
            let events: Vec<Event> = raw.into_iter().map(|(t, x, y, on)| Event::new(t, x, y, Polarity::from_on(on))).collect();
            let sensor = Resolution::new(40, 30);
            let st = SpikeTrainEncoder::new(SpikeTrainConfig { dt_us: 2_500, pool, sensor, mask_cols: None, binary: false, merge_polarities: false }).unwrap();
            let hm = HeatmapEncoder::new(HeatmapConfig::new(sensor).with_pool(pool).with_bin_us(2_500)).unwrap();
            let train = st.encode(&events, 0, 20);
            prop_assert_eq!(train.total(), events.len() as u64);
            let map = hm.encode(&events, 0, 20);
            prop_assert_eq!(&train.to_dense(), &map.counts);
            // and the heat map read back as spikes is the same train
            prop_assert_eq!(SpikeTrain::from_dense(0, 2_500, train.n_inputs, &map.counts), train.clone());
            for k in 0..train.n_steps() {
                let (inputs, _) = train.step(k);
                prop_assert!(inputs.windows(2).all(|w| w[0] < w[1]));
            }
        }
    }

    #[test]
    fn binary_clamps_counts() {
        let sensor = Resolution::new(8, 8);
        let cfg =
            SpikeTrainConfig { dt_us: 1000, pool: 1, sensor, mask_cols: None, binary: true, merge_polarities: false };
        let e = Event::new(10, 3, 2, Polarity::Off);
        let train = SpikeTrainEncoder::new(cfg).unwrap().encode(&[e, e, e], 0, 2);
        assert_eq!(train.step(0), (&[2 * 8 + 3][..], &[1][..]));
        assert_eq!(train.step(1).0.len(), 0);
    }

    #[test]
    fn merged_polarities_share_one_input_per_cell() {
        let sensor = Resolution::new(8, 8);
        let cfg =
            SpikeTrainConfig { dt_us: 1000, pool: 1, sensor, mask_cols: None, binary: true, merge_polarities: true };
        let enc = SpikeTrainEncoder::new(cfg.clone()).unwrap();
        assert_eq!(cfg.n_inputs(), 64);
        let (on, off) = (Event::new(10, 3, 2, Polarity::On), Event::new(20, 3, 2, Polarity::Off));
        assert_eq!(enc.input_of(&on), enc.input_of(&off));
        // an OR of the step's events: ON and OFF at one cell in one step give one spike
        let train = enc.encode(&[on, off], 0, 1);
        assert_eq!(train.step(0), (&[2 * 8 + 3][..], &[1][..]));
        let counts =
            SpikeTrainEncoder::new(SpikeTrainConfig { binary: false, ..cfg }).unwrap().encode(&[on, off], 0, 1);
        assert_eq!(counts.step(0).1, &[2][..]);
    }
}
