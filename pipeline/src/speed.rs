//! The scanning speed, estimated online from the events alone.
//!
//! A slide moves the gel's image along the sensor's x axis. The estimator is contrast
//! maximisation (Gallego, Rebecq and Scaramuzza, "A unifying contrast maximization framework for
//! event cameras", CVPR 2018) restricted to that one motion: the events of the last `window_ms`
//! are moved back along x to a common time at a candidate image velocity, and at the true velocity
//! the events of each dot edge land on the same pixels, so the image of moved events is sharpest.
//! Sharpness is the sum of squared counts of that image (ON and OFF apart). The candidates are a
//! log-spaced grid of speeds in both directions, refined by a parabola through the best candidate
//! and its neighbours.
//!
//! Events of noise alone are about as sharp at every velocity, so an estimate is given only when
//! the sharpest candidate stands out from the median candidate by `min_gain`: silence and noise
//! keep the previous estimate. A hot pixel is sharpest at no motion; the slowest candidate
//! (`min_mm_s`) bounds how much it can pull.
//!
//! Pixels become millimetres through the sensor's calibration, the width of its field of view on
//! the gel (a property of the device, like its resolution; not of the scan).

use crate::error::{Error, Result};
use encoders::{Event, Resolution};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpeedEstimatorConfig {
    /// The sensor's calibration: the width of its field of view on the gel (Evetac: 18.6 mm).
    pub fov_width_mm: f64,
    /// Events of this much stream time go into one estimate.
    pub window_ms: f64,
    /// Stream time between estimates.
    pub update_ms: f64,
    /// The range of speeds searched.
    pub min_mm_s: f64,
    pub max_mm_s: f64,
    /// Candidate speeds per direction, log-spaced over the range.
    pub candidates: usize,
    /// At most this many events (every k-th of the window) are moved per candidate.
    pub max_events: usize,
    /// Fewer events in the window than this give no estimate.
    pub min_events: usize,
    /// The sharpest candidate must be this many times as sharp as the median candidate.
    pub min_gain: f64,
    /// Bin sizes of the image of moved events, in pixels.
    pub bin_x_px: u16,
    pub bin_y_px: u16,
}

impl Default for SpeedEstimatorConfig {
    fn default() -> Self {
        Self {
            fov_width_mm: 18.6,
            window_ms: 250.0,
            update_ms: 50.0,
            min_mm_s: 2.0,
            max_mm_s: 100.0,
            candidates: 48,
            max_events: 6000,
            min_events: 300,
            min_gain: 1.3,
            bin_x_px: 2,
            bin_y_px: 8,
        }
    }
}

impl SpeedEstimatorConfig {
    fn validate(&self) -> Result<()> {
        let ok = self.fov_width_mm > 0.0
            && self.window_ms > 0.0
            && self.update_ms > 0.0
            && self.min_mm_s > 0.0
            && self.max_mm_s > self.min_mm_s
            && self.candidates >= 3
            && self.max_events >= 1
            && self.min_gain >= 1.0
            && self.bin_x_px >= 1
            && self.bin_y_px >= 1;
        if ok { Ok(()) } else { Err(Error::Config(format!("speed estimator configuration out of range: {self:?}"))) }
    }
}

/// One estimate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SpeedEstimate {
    /// The stream time of the newest event it used.
    pub t_us: i64,
    pub speed_mm_s: f64,
    /// The image moves towards decreasing x (a forward scan).
    pub forward: bool,
    /// Sharpness of the best candidate over the median's.
    pub gain: f64,
}

/// The online estimator of one stream: the events of the last window, and the last estimate.
#[derive(Debug, Clone)]
pub struct SpeedEstimator {
    cfg: SpeedEstimatorConfig,
    width: u16,
    height: u16,
    window_us: i64,
    update_us: i64,
    /// (t, x, y bin and polarity) of the window's events, oldest first.
    events: VecDeque<(i64, u16, u16)>,
    /// The largest number of events kept (the busiest window the readout can fill, bounded).
    cap: usize,
    next_update_us: Option<i64>,
    last: Option<SpeedEstimate>,
    /// Candidate image speeds, pixels per microsecond.
    speeds_px_us: Vec<f64>,
    /// The image of moved events: columns wide enough for the fastest candidate's shift either
    /// way (`max_shift_px` each side), rows of y bins times two polarities.
    max_shift_px: f64,
    cols: usize,
    hist: Vec<u32>,
    touched: Vec<u32>,
    /// The events of one update, as the candidates move them (reused).
    sample: Vec<(f64, f64, u32)>,
    /// Estimates given so far.
    pub estimates: u64,
}

impl SpeedEstimator {
    pub fn new(cfg: SpeedEstimatorConfig, resolution: Resolution) -> Result<SpeedEstimator> {
        cfg.validate()?;
        let px_per_mm = resolution.width as f64 / cfg.fov_width_mm;
        let n = cfg.candidates;
        let ratio = (cfg.max_mm_s / cfg.min_mm_s).ln();
        let speeds_px_us: Vec<f64> =
            (0..n).map(|k| cfg.min_mm_s * (ratio * k as f64 / (n - 1) as f64).exp() * px_per_mm * 1e-6).collect();
        let window_us = (cfg.window_ms * 1e3) as i64;
        let max_shift_px = speeds_px_us[n - 1] * window_us as f64;
        let cols = ((resolution.width as f64 + 2.0 * max_shift_px) / cfg.bin_x_px as f64) as usize + 2;
        let rows = (resolution.height / cfg.bin_y_px + 1) as usize * 2;
        Ok(SpeedEstimator {
            width: resolution.width,
            height: resolution.height,
            window_us,
            update_us: (cfg.update_ms * 1e3).max(1.0) as i64,
            events: VecDeque::new(),
            cap: 2_000_000,
            next_update_us: None,
            last: None,
            speeds_px_us,
            max_shift_px,
            cols,
            hist: vec![0; cols * rows],
            touched: Vec::new(),
            sample: Vec::new(),
            estimates: 0,
            cfg,
        })
    }

    /// The latest estimate, if one was given.
    pub fn last(&self) -> Option<SpeedEstimate> {
        self.last
    }

    /// Hands in one event (in time order; events outside the sensor are ignored).
    #[inline]
    pub fn push(&mut self, e: &Event) {
        if e.x >= self.width || e.y >= self.height {
            return;
        }
        let yb = (e.y / self.cfg.bin_y_px) * 2 + e.polarity.index() as u16;
        self.events.push_back((e.t_us, e.x, yb));
        if self.events.len() > self.cap {
            self.events.pop_front();
        }
    }

    /// The stream time of the next update (`None` before the first event).
    #[inline]
    pub fn next_update_us(&self) -> Option<i64> {
        self.next_update_us
    }

    /// Whether an update is due at stream time `t_us`.
    #[inline]
    pub fn due(&self, t_us: i64) -> bool {
        self.next_update_us.is_none_or(|n| t_us >= n)
    }

    /// Estimates from the window ending at `t_us` when an update is due; the new estimate, if
    /// the window gave one.
    pub fn update(&mut self, t_us: i64) -> Option<SpeedEstimate> {
        if !self.due(t_us) {
            return None;
        }
        self.next_update_us = Some(t_us + self.update_us);
        while self.events.front().is_some_and(|e| e.0 < t_us - self.window_us) {
            self.events.pop_front();
        }
        let est = self.estimate_window(t_us)?;
        self.last = Some(est);
        self.estimates += 1;
        Some(est)
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.events.capacity() * std::mem::size_of::<(i64, u16, u16)>()
            + (self.hist.capacity() + self.touched.capacity()) * 4
            + self.sample.capacity() * std::mem::size_of::<(f64, f64, u32)>()
    }

    /// Sharpness of the sampled events (`sample`: x, time before `t_ref` and the row's offset in
    /// the image) moved to `t_ref` at `v` pixels per microsecond (signed: negative for an image
    /// moving towards decreasing x).
    fn sharpness(&mut self, sample: &[(f64, f64, u32)], v: f64) -> f64 {
        let (bx, cols) = (self.cfg.bin_x_px as f64, self.cols);
        for &(x, dt, row) in sample {
            // where the event's pixel content is at t_ref
            let x_ref = x + v * dt + self.max_shift_px;
            let c = ((x_ref / bx) as usize).min(cols - 1);
            let i = row as usize + c;
            if self.hist[i] == 0 {
                self.touched.push(i as u32);
            }
            self.hist[i] += 1;
        }
        let mut s = 0f64;
        for &i in &self.touched {
            let h = std::mem::take(&mut self.hist[i as usize]) as f64;
            s += h * h;
        }
        self.touched.clear();
        s
    }

    fn estimate_window(&mut self, t_ref: i64) -> Option<SpeedEstimate> {
        let n = self.events.len();
        if n < self.cfg.min_events {
            return None;
        }
        let stride = n.div_ceil(self.cfg.max_events);
        let k = self.speeds_px_us.len();
        // every stride-th event, taken once for all candidates
        let cols = self.cols;
        let mut sample = std::mem::take(&mut self.sample);
        sample.clear();
        sample.extend(
            self.events
                .iter()
                .step_by(stride)
                .map(|&(t, x, yb)| (x as f64, (t_ref - t) as f64, yb as u32 * cols as u32)),
        );
        // [forward candidates..., reverse candidates...]
        let mut s = Vec::with_capacity(2 * k);
        for dir in [-1.0, 1.0] {
            for j in 0..k {
                let v = dir * self.speeds_px_us[j];
                s.push(self.sharpness(&sample, v));
            }
        }
        self.sample = sample;
        let (best, &peak) = s.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
        let mut sorted = s.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let gain = peak / median.max(f64::MIN_POSITIVE);
        if gain < self.cfg.min_gain {
            return None;
        }
        let (forward, j) = (best < k, best % k);
        let base = if forward { 0 } else { k };
        // a parabola through the best and its neighbours, in log speed (an even grid)
        let offset = if j > 0 && j + 1 < k {
            let (a, b, c) = (s[base + j - 1], s[base + j], s[base + j + 1]);
            let d = a - 2.0 * b + c;
            if d < 0.0 { (0.5 * (a - c) / d).clamp(-0.5, 0.5) } else { 0.0 }
        } else {
            0.0
        };
        let step = (self.cfg.max_mm_s / self.cfg.min_mm_s).ln() / (k - 1) as f64;
        let speed_mm_s = self.cfg.min_mm_s * (step * (j as f64 + offset)).exp();
        Some(SpeedEstimate { t_us: t_ref, speed_mm_s, forward, gain })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use encoders::Polarity;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Edges at random places of a board moving under the sensor at `speed` mm/s (forward: the
    /// image moves towards x = 0), plus uniform noise at `noise_hz` per pixel.
    pub(crate) fn moving(speed: f64, forward: bool, noise_hz: f64, seconds: f64, seed: u64) -> Vec<Event> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let px_per_mm = 640.0 / 18.6;
        let board_px = (speed * seconds * px_per_mm + 700.0) as usize;
        // dots: (board x in px, y) every ~2.5 mm
        let dots: Vec<(f64, u16)> = (0..board_px / 86)
            .map(|k| (k as f64 * 86.0 + rng.random_range(0.0..20.0), rng.random_range(40..440)))
            .collect();
        let mut ev = Vec::new();
        let mut t = 0i64;
        while (t as f64) < seconds * 1e6 {
            let shift = speed * px_per_mm * t as f64 / 1e6;
            for &(bx, y) in &dots {
                let x = if forward { bx - shift } else { 640.0 - (bx - shift) };
                if (0.0..640.0).contains(&x) {
                    for dy in 0..8 {
                        ev.push(Event { t_us: t, x: x as u16, y: y + dy * 3, polarity: Polarity::On });
                    }
                }
            }
            let n_noise = (noise_hz * 640.0 * 480.0 * 1e-3) as usize;
            for _ in 0..n_noise {
                ev.push(Event {
                    t_us: t,
                    x: rng.random_range(0..640),
                    y: rng.random_range(0..480),
                    polarity: Polarity::Off,
                });
            }
            t += 1000;
        }
        ev
    }

    fn run(events: &[Event]) -> Vec<SpeedEstimate> {
        let mut e = SpeedEstimator::new(SpeedEstimatorConfig::default(), Resolution::DVXPLORER).unwrap();
        let mut out = Vec::new();
        for ev in events {
            e.push(ev);
            if e.due(ev.t_us) {
                out.extend(e.update(ev.t_us));
            }
        }
        out
    }

    #[test]
    fn the_speed_of_moving_edges_is_found_in_either_direction() {
        for (speed, forward) in [(4.0, true), (8.0, true), (23.0, false), (32.0, true), (60.0, true)] {
            let est = run(&moving(speed, forward, 0.05, 1.5, 7));
            assert!(est.len() > 20, "{speed}: {} estimates", est.len());
            for e in &est[5..] {
                assert!((e.speed_mm_s / speed - 1.0).abs() < 0.05, "{speed} mm/s: {e:?}");
                assert_eq!(e.forward, forward, "{e:?}");
            }
        }
    }

    #[test]
    fn noise_alone_gives_no_estimate() {
        let est = run(&moving(8.0, true, 0.5, 1.0, 3)
            .into_iter()
            .filter(|e| e.polarity == Polarity::Off)
            .collect::<Vec<_>>());
        assert!(est.is_empty(), "{est:?}");
    }
}
