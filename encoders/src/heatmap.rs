//! The paper's heat map (eq. 4): events counted per pixel in time bins of fixed width, after
//! spatial sum-pooling, with ON and OFF kept apart.

use crate::error::{Error, Result};
use crate::event::{Event, Resolution};
use crate::pooling::{self, PoolMap};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// How events become heat maps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeatmapConfig {
    /// Width of one time bin (the paper: 10 ms).
    pub bin_us: i64,
    /// Spatial sum-pooling factor, the same along x and y (the paper: 4, 640x480 to 160x120).
    pub pool: u16,
    /// The sensor's resolution.
    pub sensor: Resolution,
    /// Keep only these columns of the pooled map (half-open, in pooled pixels); events elsewhere
    /// are dropped. The paper's labeler keeps columns 20..100.
    pub mask_cols: Option<Range<u16>>,
}

impl Default for HeatmapConfig {
    fn default() -> Self {
        Self { bin_us: 10_000, pool: 4, sensor: Resolution::DVXPLORER, mask_cols: None }
    }
}

impl HeatmapConfig {
    pub fn new(sensor: Resolution) -> Self {
        Self { sensor, ..Self::default() }
    }

    pub fn with_bin_us(mut self, bin_us: i64) -> Self {
        self.bin_us = bin_us;
        self
    }

    pub fn with_pool(mut self, pool: u16) -> Self {
        self.pool = pool;
        self
    }

    pub fn with_mask_cols(mut self, cols: Range<u16>) -> Self {
        self.mask_cols = Some(cols);
        self
    }

    /// The pooled size: each side rounded up, so that every pixel lands in a cell.
    pub fn output(&self) -> Resolution {
        pooling::pooled(self.sensor, self.pool)
    }

    pub fn validate(&self) -> Result<()> {
        if self.bin_us <= 0 {
            return Err(Error::config("bin_us", format!("must be positive, got {}", self.bin_us)));
        }
        pooling::validate(self.sensor, self.pool, self.mask_cols.as_ref())
    }
}

/// Counts in `[bin][polarity][row][col]` order (polarity 0 = OFF, 1 = ON), as `f32` for networks.
#[derive(Debug, Clone, PartialEq)]
pub struct Heatmap {
    pub t_start_us: i64,
    pub bin_us: i64,
    pub bins: usize,
    pub height: usize,
    pub width: usize,
    pub counts: Vec<f32>,
}

impl Heatmap {
    pub fn zeros(t_start_us: i64, bin_us: i64, bins: usize, size: Resolution) -> Self {
        let (h, w) = (size.height as usize, size.width as usize);
        Self { t_start_us, bin_us, bins, height: h, width: w, counts: vec![0.0; bins * 2 * h * w] }
    }

    /// The end of the last bin (exclusive).
    pub fn t_end_us(&self) -> i64 {
        self.t_start_us + self.bin_us * self.bins as i64
    }

    #[inline]
    pub fn index(&self, bin: usize, polarity: usize, row: usize, col: usize) -> usize {
        ((bin * 2 + polarity) * self.height + row) * self.width + col
    }

    pub fn get(&self, bin: usize, polarity: usize, row: usize, col: usize) -> f32 {
        self.counts[self.index(bin, polarity, row, col)]
    }

    /// One bin's two channels, `[polarity][row][col]`.
    pub fn bin(&self, bin: usize) -> &[f32] {
        let n = 2 * self.height * self.width;
        &self.counts[bin * n..(bin + 1) * n]
    }

    pub fn total(&self) -> f64 {
        self.counts.iter().map(|&c| c as f64).sum()
    }
}

/// Turns events into heat maps. Build once per configuration; encoding allocates nothing but the
/// output.
#[derive(Debug, Clone)]
pub struct HeatmapEncoder {
    config: HeatmapConfig,
    map: PoolMap,
}

impl HeatmapEncoder {
    pub fn new(config: HeatmapConfig) -> Result<Self> {
        config.validate()?;
        let map = PoolMap::new(config.sensor, config.pool, config.mask_cols.as_ref())?;
        Ok(Self { config, map })
    }

    pub fn config(&self) -> &HeatmapConfig {
        &self.config
    }

    pub fn output(&self) -> Resolution {
        self.map.output
    }

    /// The heat map of `bins` bins starting at `t_start_us`, from events in time order.
    pub fn encode(&self, events: &[Event], t_start_us: i64, bins: usize) -> Heatmap {
        let mut map = Heatmap::zeros(t_start_us, self.config.bin_us, bins, self.map.output);
        self.accumulate(events, &mut map);
        map
    }

    /// Adds events to `map`; events outside its time span, outside the sensor or masked out are
    /// ignored. Streams feed chunks one after another. Events in time order take a fast path;
    /// any order gives the same counts.
    pub fn accumulate(&self, events: &[Event], map: &mut Heatmap) {
        if map.bins == 0 {
            return;
        }
        let plane = self.map.output.pixels();
        let bin_us = map.bin_us;
        let t0 = map.t_start_us;
        let t_end = map.t_end_us();
        let counts = &mut map.counts[..];
        // The bin of the previous event and its time span, so that events in order need no
        // division.
        let mut bin = 0usize;
        let mut lo = t0;
        let mut hi = t0 + bin_us;
        for e in events {
            let t = e.t_us;
            if t < lo || t >= hi {
                if t < t0 || t >= t_end {
                    continue;
                }
                bin = ((t - t0) / bin_us) as usize;
                lo = t0 + bin as i64 * bin_us;
                hi = lo + bin_us;
            }
            let Some(cell) = self.map.cell(e.x, e.y) else { continue };
            let i = (bin * 2 + e.polarity.index()) * plane + cell as usize;
            counts[i] += 1.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event::Polarity;
    use proptest::prelude::*;

    fn sensor() -> Resolution {
        Resolution::new(64, 48)
    }

    #[test]
    fn paper_defaults_pool_640x480_to_160x120() {
        assert_eq!(HeatmapConfig::default().output(), Resolution::new(160, 120));
        assert_eq!(HeatmapConfig::default().bin_us, 10_000);
    }

    #[test]
    fn one_event_lands_in_its_cell() {
        let enc = HeatmapEncoder::new(HeatmapConfig::new(sensor())).unwrap();
        let map = enc.encode(&[Event::new(25_000, 13, 9, Polarity::On)], 0, 5);
        assert_eq!(map.get(2, 1, 9 / 4, 13 / 4), 1.0);
        assert_eq!(map.total(), 1.0);
    }

    #[test]
    fn bad_configs_are_rejected() {
        assert!(HeatmapEncoder::new(HeatmapConfig::new(sensor()).with_bin_us(0)).is_err());
        assert!(HeatmapEncoder::new(HeatmapConfig::new(sensor()).with_pool(0)).is_err());
        assert!(HeatmapEncoder::new(HeatmapConfig::new(sensor()).with_mask_cols(5..5)).is_err());
        assert!(HeatmapEncoder::new(HeatmapConfig::new(sensor()).with_mask_cols(0..17)).is_err());
    }

    fn arb_events() -> impl Strategy<Value = Vec<Event>> {
        prop::collection::vec((0i64..200_000, 0u16..64, 0u16..48, any::<bool>()), 0..400).prop_map(|mut v| {
            v.sort_by_key(|e| e.0);
            v.into_iter().map(|(t, x, y, on)| Event::new(t, x, y, Polarity::from_on(on))).collect()
        })
    }

    proptest! {
        /// Every event inside the time range and the mask is counted exactly once, in its cell.
        #[test]
        fn counts_are_conserved(events in arb_events(), t0 in -20_000i64..100_000, bins in 0usize..25,
                                pool in 1u16..7, mask in prop::option::of((0u16..8, 1u16..8)), shuffle in any::<bool>()) {
            let mut config = HeatmapConfig::new(sensor()).with_pool(pool).with_bin_us(7_000);
            let width = config.output().width;
            if let Some((a, len)) = mask {
                let a = a.min(width - 1);
                config = config.with_mask_cols(a..(a + len).min(width));
            }
            let enc = HeatmapEncoder::new(config.clone()).unwrap();
            let mut input = events.clone();
            if shuffle { input.reverse(); }
            let map = enc.encode(&input, t0, bins);
            let mut expected = vec![0f32; map.counts.len()];
            for e in &events {
                let in_time = e.t_us >= t0 && e.t_us < t0 + 7_000 * bins as i64;
                let col = e.x / pool;
                let in_mask = config.mask_cols.as_ref().is_none_or(|m| m.contains(&col));
                if in_time && in_mask {
                    let bin = ((e.t_us - t0) / 7_000) as usize;
                    expected[map.index(bin, e.polarity.index(), (e.y / pool) as usize, col as usize)] += 1.0;
                }
            }
            prop_assert_eq!(&map.counts, &expected);
        }

        /// Feeding a stream in chunks gives the same map as feeding it at once.
        #[test]
        fn chunks_equal_whole(events in arb_events(), split in 0usize..400) {
            let enc = HeatmapEncoder::new(HeatmapConfig::new(sensor())).unwrap();
            let whole = enc.encode(&events, 0, 20);
            let mut map = Heatmap::zeros(0, 10_000, 20, enc.output());
            let k = split.min(events.len());
            enc.accumulate(&events[..k], &mut map);
            enc.accumulate(&events[k..], &mut map);
            prop_assert_eq!(whole, map);
        }
    }
}
