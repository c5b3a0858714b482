//! The scanning speed, estimated online from the events alone.
//!
//! A slide moves the gel's image along the sensor's x axis. The estimator is contrast
//! maximisation (Gallego, Rebecq and Scaramuzza, "A unifying contrast maximization framework for
//! event cameras", CVPR 2018) restricted to that one motion: the events of a recent window
//! are moved back along x to a common time at a candidate image velocity, and at the true velocity
//! the events of each dot edge land on the same pixels, so the image of moved events is sharpest.
//! Sharpness is the sum of squared counts of that image (ON and OFF apart). The candidates are a
//! log-spaced grid of speeds in both directions, refined by a parabola through the best candidate
//! and its neighbours.
//!
//! Searching every candidate at every update is costly, so the whole range is searched at the
//! start, after a lost estimate and once a second; in between, a few candidates a few per cent
//! apart around the last estimate are searched (tracking), and the window holds a fixed length of
//! motion at that estimate (shorter at higher speeds, so it follows a changing speed sooner).
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
#[serde(default)]
pub struct SpeedEstimatorConfig {
    /// The sensor's calibration: the width of its field of view on the gel (Evetac: 18.6 mm).
    pub fov_width_mm: f64,
    /// A window holds the events of this much motion at the last estimate (so a window holds
    /// about as many pixels of motion, and as many events, at every speed), within
    /// `min_window_ms..=window_ms`. 1 mm and 40 ms were chosen on the validation board
    /// (docs/reading.md): shorter windows lag less behind a changing speed.
    pub window_mm: f64,
    pub min_window_ms: f64,
    /// The longest window, and the window before the first estimate.
    pub window_ms: f64,
    /// Stream time between estimates.
    pub update_ms: f64,
    /// The range of speeds searched. The top, 250 mm/s, was chosen on the validation board
    /// (docs/results/speed_estimate_range.md): with 100 mm/s, scans at 128-200 mm/s were
    /// estimated 23-49% slow and read nothing; with 250 every speed from 4 to 200 mm/s is within
    /// 3% (median) and the slower speeds are as before.
    pub min_mm_s: f64,
    pub max_mm_s: f64,
    /// Candidate speeds per direction of the whole-range search, log-spaced over the range.
    pub candidates: usize,
    /// The local search around the last estimate: candidates `local_step` apart (relative),
    /// `local_half_width` either side, walking on while the sharpest is at an end.
    pub local_step: f64,
    pub local_half_width: usize,
    /// A whole-range search at the first update, after an update gave no estimate, when the local
    /// search loses its peak, and at least this often (0: at every update).
    pub global_every_ms: f64,
    /// After an update that gave no estimate (noise, a pause), the next search waits this long.
    pub retry_ms: f64,
    /// At most this many events (every k-th of the window) are moved per candidate. Events are
    /// thinned as they come in (one in a power of two) to about twice this many per window.
    /// At most 65 535 (the moved image counts in 16 bits).
    pub max_events: usize,
    /// Fewer events in the window than this give no estimate.
    pub min_events: usize,
    /// The sharpest candidate must be this many times as sharp as the median candidate (of the
    /// whole range), or as the median of three blurred references (the local search: the
    /// reverse direction, half and a third of the speed).
    pub min_gain: f64,
    /// Bin sizes of the image of moved events, in pixels.
    pub bin_x_px: u16,
    pub bin_y_px: u16,
}

impl Default for SpeedEstimatorConfig {
    fn default() -> Self {
        Self {
            fov_width_mm: 18.6,
            window_mm: 1.0,
            min_window_ms: 40.0,
            window_ms: 250.0,
            update_ms: 50.0,
            min_mm_s: 2.0,
            max_mm_s: 250.0,
            candidates: 48,
            local_step: 0.03,
            local_half_width: 3,
            global_every_ms: 1000.0,
            retry_ms: 150.0,
            max_events: 2000,
            min_events: 300,
            min_gain: 1.3,
            bin_x_px: 2,
            bin_y_px: 8,
        }
    }
}

impl SpeedEstimatorConfig {
    /// The exhaustive reference (the estimator until 2026-11-25): a fixed 250 ms window, 6 000
    /// events and the whole range at every update. About 25 times the default's work.
    pub fn exhaustive() -> Self {
        Self { min_window_ms: 250.0, global_every_ms: 0.0, retry_ms: 0.0, max_events: 6000, ..Self::default() }
    }

    fn validate(&self) -> Result<()> {
        let ok = self.fov_width_mm > 0.0
            && self.window_mm > 0.0
            && self.min_window_ms > 0.0
            && self.window_ms >= self.min_window_ms
            && self.update_ms > 0.0
            && self.min_mm_s > 0.0
            && self.max_mm_s > self.min_mm_s
            && self.candidates >= 3
            && self.local_step > 0.0
            && self.local_half_width >= 1
            && self.global_every_ms >= 0.0
            && self.retry_ms >= 0.0
            && (1..=u16::MAX as usize).contains(&self.max_events)
            && self.min_gain >= 1.0
            && self.bin_x_px >= 1
            && self.bin_y_px >= 1;
        if ok {
            Ok(())
        } else {
            Err(Error::Setting {
                name: "speed estimator configuration",
                value: format!("{self:?}"),
                expected: "positive windows, thresholds and bounds, and max_events in 1..=65535",
            })
        }
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
    /// Sharpness of the best candidate over the median's (or the references').
    pub gain: f64,
}

/// An event kept in the window: its time, x, y bin and polarity, and how many events it stands for
/// (itself and those passed over before it).
#[derive(Debug, Clone, Copy)]
struct Kept {
    t_us: i64,
    x: u16,
    yb: u16,
    weight: u32,
}

/// The online estimator of one stream: the events of the last window, and the last estimate.
#[derive(Debug, Clone)]
pub struct SpeedEstimator {
    cfg: SpeedEstimatorConfig,
    width: u16,
    height: u16,
    px_per_mm: f64,
    window_us: i64,
    min_window_us: i64,
    update_us: i64,
    global_every_us: i64,
    /// (t, x, y bin and polarity, events it stands for) of the longest window's kept events,
    /// oldest first.
    events: VecDeque<Kept>,
    /// One event in `keep_every` is kept (a power of two, set at each update from the rate), and
    /// the count of those passed over since the last kept one.
    keep_every: u32,
    skipped: u32,
    /// Events pushed since the last update.
    arrived: u64,
    /// No search before this stream time (after an update that gave no estimate).
    retry_at_us: i64,
    retry_us: i64,
    /// The largest number of events kept (the busiest window the readout can fill, bounded).
    cap: usize,
    next_update_us: Option<i64>,
    last: Option<SpeedEstimate>,
    /// The stream time of the last whole-range search.
    last_global_us: Option<i64>,
    /// Candidate image speeds of the whole-range search, pixels per microsecond.
    speeds_px_us: Vec<f64>,
    /// The image of moved events: columns wide enough for the fastest candidate's shift either
    /// way (`max_shift_px` each side), rows of y bins times two polarities; counts in 16 bits
    /// (an update samples at most `max_events`, at most 65 535: half the cache lines of 32).
    max_shift_px: f64,
    cols: usize,
    hist: Vec<u16>,
    /// Each sampled event's image bin under one candidate (to count and clear them).
    filled: Vec<u32>,
    /// The events of one update: x, time before the update and the row's offset in the image.
    sample: Vec<(f32, f32, u32)>,
    /// Estimates given so far.
    pub estimates: u64,
    /// Updates run, and those that searched the whole range.
    pub updates: u64,
    pub global_searches: u64,
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
        if cols >= 1 << 24 {
            return Err(Error::Setting {
                name: "speed estimator configuration",
                value: format!("{cfg:?}"),
                expected: "a window and top speed whose image of moved events is under 2^24 columns",
            });
        }
        let rows = (resolution.height / cfg.bin_y_px + 1) as usize * 2;
        Ok(SpeedEstimator {
            width: resolution.width,
            height: resolution.height,
            px_per_mm,
            window_us,
            min_window_us: (cfg.min_window_ms * 1e3) as i64,
            update_us: (cfg.update_ms * 1e3).max(1.0) as i64,
            global_every_us: (cfg.global_every_ms * 1e3) as i64,
            events: VecDeque::new(),
            keep_every: 1,
            skipped: 0,
            arrived: 0,
            retry_at_us: i64::MIN,
            retry_us: (cfg.retry_ms * 1e3) as i64,
            cap: 2_000_000,
            next_update_us: None,
            last: None,
            last_global_us: None,
            speeds_px_us,
            max_shift_px,
            cols,
            hist: vec![0; cols * rows],
            filled: Vec::new(),
            sample: Vec::new(),
            estimates: 0,
            updates: 0,
            global_searches: 0,
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
        self.arrived += 1;
        self.skipped += 1;
        if self.skipped < self.keep_every {
            return;
        }
        let weight = std::mem::take(&mut self.skipped);
        self.keep(e, weight);
    }

    /// Hands in a run of events (in time order) with no update due inside it: the same as
    /// [`push`](Self::push) for each, but when every event of the run is on the sensor only the
    /// kept ones (one in `keep_every`) are visited. The readers' loop hands in each bin's run so,
    /// instead of counting every event in its binning loop (2026-12-02, docs/reading.md).
    pub fn push_run(&mut self, run: &[Event]) {
        let (width, height) = (self.width, self.height);
        // counted rather than `any`: a loop without an early exit vectorises
        let outside = run.iter().fold(0usize, |n, e| n + usize::from((e.x >= width) | (e.y >= height)));
        if outside > 0 {
            run.iter().for_each(|e| self.push(e));
            return;
        }
        self.arrived += run.len() as u64;
        let every = self.keep_every as usize;
        let skipped = self.skipped as usize;
        // the first kept is the event at which `skipped` reaches `keep_every` (the run's first
        // when it already has: `keep_every` can fall at an update), standing for those before it
        let first = every.saturating_sub(skipped + 1);
        if first >= run.len() {
            self.skipped += run.len() as u32;
            return;
        }
        self.keep(&run[first], (skipped + first + 1) as u32);
        let mut last = first;
        for (k, e) in run.iter().enumerate().skip(first + every).step_by(every) {
            self.keep(e, every as u32);
            last = k;
        }
        self.skipped = (run.len() - 1 - last) as u32;
    }

    /// `e` into the window, standing for `weight` events.
    #[inline]
    fn keep(&mut self, e: &Event, weight: u32) {
        let yb = (e.y / self.cfg.bin_y_px) * 2 + e.polarity.index() as u16;
        self.events.push_back(Kept { t_us: e.t_us, x: e.x, yb, weight });
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
        let previous_update = self.next_update_us.map(|n| n - self.update_us);
        self.next_update_us = Some(t_us + self.update_us);
        self.updates += 1;
        while self.events.front().is_some_and(|e| e.t_us < t_us - self.window_us) {
            self.events.pop_front();
        }
        // the last estimate, if the previous update gave it: the local search starts there
        let tracked = self.last.filter(|l| previous_update.is_some_and(|p| l.t_us >= p));
        let searches = self.global_searches;
        let est =
            if tracked.is_some() || t_us >= self.retry_at_us { self.estimate_window(t_us, tracked) } else { None };
        match est {
            Some(est) => {
                self.last = Some(est);
                self.estimates += 1;
            }
            // a whole-range search found nothing: wait before the next
            None if self.global_searches > searches => self.retry_at_us = t_us + self.retry_us,
            None => {}
        }
        // thin the coming events to about twice `max_events` per window at this rate
        let since_us = previous_update.map_or(self.update_us, |p| (t_us - p).max(1));
        let per_window =
            self.arrived as f64 * self.window_for(self.last.filter(|l| l.t_us == t_us)) as f64 / since_us as f64;
        let keep = (per_window / (2 * self.cfg.max_events) as f64).max(1.0);
        self.keep_every = 1 << (keep.log2().floor() as u32).min(16);
        self.arrived = 0;
        est
    }

    /// The window of an update that tracks `tracked` (the longest without).
    fn window_for(&self, tracked: Option<SpeedEstimate>) -> i64 {
        tracked.map_or(self.window_us, |l| {
            ((self.cfg.window_mm / l.speed_mm_s * 1e6) as i64).clamp(self.min_window_us, self.window_us)
        })
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.events.capacity() * std::mem::size_of::<Kept>()
            + self.hist.capacity() * 2
            + self.filled.capacity() * 4
            + self.sample.capacity() * std::mem::size_of::<(f32, f32, u32)>()
    }

    /// Sharpness of the sampled events moved to the update's time at `v` pixels per microsecond
    /// (signed: negative for an image moving towards decreasing x): the sum of squared counts of
    /// the image.
    fn sharpness(&mut self, v: f64) -> f64 {
        let (v, off, inv_bx, last) =
            (v as f32, self.max_shift_px as f32, 1.0 / self.cfg.bin_x_px as f32, (self.cols - 1) as u32);
        let (hist, filled) = (&mut self.hist, &mut self.filled);
        // where each event's pixel content is at the update's time (a loop without dependencies,
        // which vectorises), then the counts, then the sum of their squares: the same integer
        // as adding `2 h + 1` at each event, without a chain through the sum
        filled.clear();
        filled.extend(self.sample.iter().map(|&(x, dt, row)| row + column_bin((x + v * dt + off) * inv_bx, last)));
        for &i in filled.iter() {
            hist[i as usize] += 1;
        }
        let mut s = 0u64;
        for &i in filled.iter() {
            let h = std::mem::take(&mut hist[i as usize]) as u64;
            s += h * h;
        }
        s as f64
    }

    /// The image speed of `speed_mm_s` in a direction, pixels per microsecond (signed).
    fn px_us(&self, speed_mm_s: f64, forward: bool) -> f64 {
        let v = speed_mm_s * self.px_per_mm * 1e-6;
        if forward { -v } else { v }
    }

    fn estimate_window(&mut self, t_ref: i64, tracked: Option<SpeedEstimate>) -> Option<SpeedEstimate> {
        let window_us = self.window_for(tracked);
        let first = self.events.partition_point(|e| e.t_us < t_ref - window_us);
        let kept = self.events.len() - first;
        let n: u64 = self.events.range(first..).map(|e| e.weight as u64).sum();
        if n < self.cfg.min_events as u64 {
            return None;
        }
        // every stride-th event kept, taken once for all candidates
        let stride = kept.div_ceil(self.cfg.max_events);
        let cols = self.cols as u32;
        self.sample.clear();
        self.sample.extend(
            self.events
                .range(first..)
                .step_by(stride)
                .map(|e| (e.x as f32, (t_ref - e.t_us) as f32, e.yb as u32 * cols)),
        );
        let global_due = self.last_global_us.is_none_or(|g| t_ref - g >= self.global_every_us);
        match tracked {
            Some(l) if !global_due => self.local_search(t_ref, l).or_else(|| self.global_search(t_ref)),
            _ => self.global_search(t_ref),
        }
    }

    /// Candidates `local_step` apart around the last estimate, in its direction, walking on while
    /// the sharpest is at an end (at most as far again); `None` when the peak stays at an end or
    /// does not stand out from the blurred references.
    fn local_search(&mut self, t_ref: i64, last: SpeedEstimate) -> Option<SpeedEstimate> {
        let step = self.cfg.local_step.ln_1p();
        let h = self.cfg.local_half_width as i64;
        let (lo, hi) = (self.cfg.min_mm_s.ln(), self.cfg.max_mm_s.ln());
        let centre = last.speed_mm_s.ln();
        let speed_at = |k: i64| (centre + step * k as f64).exp();
        let inside = |k: i64| (lo..=hi).contains(&(centre + step * k as f64));
        let mut s: Vec<(i64, f64)> = Vec::with_capacity(4 * h as usize + 1);
        for k in -h..=h {
            if inside(k) {
                let v = self.px_us(speed_at(k), last.forward);
                s.push((k, self.sharpness(v)));
            }
        }
        // walk on while the sharpest is at an end
        loop {
            let (best, _) = *s.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
            let (first, end) = (s[0].0, s[s.len() - 1].0);
            let next = if best == end && end < 2 * h {
                end + 1
            } else if best == first && first > -2 * h {
                first - 1
            } else {
                break;
            };
            if !inside(next) {
                break;
            }
            let v = self.px_us(speed_at(next), last.forward);
            let x = self.sharpness(v);
            if next > end { s.push((next, x)) } else { s.insert(0, (next, x)) }
        }
        let j = s.iter().enumerate().max_by(|a, b| a.1.1.total_cmp(&b.1.1)).map(|(j, _)| j)?;
        if j == 0 || j + 1 == s.len() {
            return None;
        }
        let peak = s[j].1;
        let speed = speed_at(s[j].0);
        let mut refs = [
            self.sharpness(self.px_us(speed, !last.forward)),
            self.sharpness(self.px_us(speed / 2.0, last.forward)),
            self.sharpness(self.px_us(speed / 3.0, last.forward)),
        ];
        refs.sort_by(f64::total_cmp);
        let gain = peak / refs[1].max(f64::MIN_POSITIVE);
        if gain < self.cfg.min_gain {
            return None;
        }
        let offset = parabola(s[j - 1].1, peak, s[j + 1].1);
        let speed_mm_s = (centre + step * (s[j].0 as f64 + offset)).exp();
        Some(SpeedEstimate { t_us: t_ref, speed_mm_s, forward: last.forward, gain })
    }

    /// Every candidate of the range, in both directions.
    fn global_search(&mut self, t_ref: i64) -> Option<SpeedEstimate> {
        self.global_searches += 1;
        self.last_global_us = Some(t_ref);
        let k = self.speeds_px_us.len();
        // [forward candidates..., reverse candidates...]
        let mut s = Vec::with_capacity(2 * k);
        for dir in [-1.0, 1.0] {
            for j in 0..k {
                let v = dir * self.speeds_px_us[j];
                s.push(self.sharpness(v));
            }
        }
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
        let offset = if j > 0 && j + 1 < k { parabola(s[base + j - 1], s[base + j], s[base + j + 1]) } else { 0.0 };
        let step = (self.cfg.max_mm_s / self.cfg.min_mm_s).ln() / (k - 1) as f64;
        let speed_mm_s = self.cfg.min_mm_s * (step * (j as f64 + offset)).exp();
        Some(SpeedEstimate { t_us: t_ref, speed_mm_s, forward, gain })
    }
}

/// The image column of a moved event at `f` bins from the left: `f` truncated, within
/// `0..=last` (`last < 2^24`, exact as an `f32`). The same as `(f as usize).min(last)` for every
/// `f` (below zero and NaN give 0, past `last` gives `last`), clamped as a float first so that
/// the conversion needs no saturation, which SSE does four at a time (a conversion to `usize`
/// is one value at a time: the sharpness's loop ran scalar).
#[inline(always)]
fn column_bin(f: f32, last: u32) -> u32 {
    debug_assert!(last < 1 << 24, "a column count an f32 holds exactly");
    // `max` returns 0 for NaN
    let clamped = f.max(0.0).min(last as f32);
    // SAFETY: `clamped` is finite and within `0..=last`, which an i32 holds.
    unsafe { clamped.to_int_unchecked::<i32>() as u32 }
}

/// The vertex of the parabola through three evenly spaced values around the largest, as an
/// offset from the middle one in steps (within half a step).
fn parabola(a: f64, b: f64, c: f64) -> f64 {
    let d = a - 2.0 * b + c;
    if d < 0.0 { (0.5 * (a - c) / d).clamp(-0.5, 0.5) } else { 0.0 }
}

/// Every estimate the estimator gives over a whole stream of `events` (in time order), as a
/// reader running it would have them.
pub fn estimates_of(
    events: &[Event],
    cfg: &SpeedEstimatorConfig,
    resolution: Resolution,
) -> Result<Vec<SpeedEstimate>> {
    let mut est = SpeedEstimator::new(cfg.clone(), resolution)?;
    let mut given = Vec::new();
    for e in events {
        est.push(e);
        if est.due(e.t_us)
            && let Some(x) = est.update(e.t_us)
        {
            given.push(x);
        }
    }
    Ok(given)
}

/// The median speed of the estimates given within `half_ms` of `t_us` (`estimates` in time
/// order); `None` when none was.
pub fn speed_near(estimates: &[SpeedEstimate], t_us: i64, half_ms: f64) -> Option<f64> {
    let half_us = (half_ms * 1e3) as i64;
    let from = estimates.partition_point(|x| x.t_us < t_us - half_us);
    let to = estimates.partition_point(|x| x.t_us <= t_us + half_us);
    let mut near: Vec<f64> = estimates[from..to].iter().map(|x| x.speed_mm_s).collect();
    near.sort_by(f64::total_cmp);
    near.get(near.len() / 2).copied()
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
    fn a_run_handed_in_at_once_gives_what_pushing_each_event_gives() {
        // runs all on the sensor and runs with events outside it, runs shorter and longer than
        // the thinning's step, and the thinning at work after the first updates
        let mut events = moving(32.0, true, 1.0, 1.5, 3);
        for (k, e) in events.iter_mut().enumerate().filter(|(k, _)| k % 9_973 < 3) {
            (e.x, e.y) = if k % 2 == 0 { (700, e.y) } else { (e.x, 500) };
        }
        let new = || SpeedEstimator::new(SpeedEstimatorConfig::default(), Resolution::DVXPLORER).unwrap();
        let (mut a, mut b) = (new(), new());
        let (mut est_a, mut est_b) = (Vec::new(), Vec::new());
        let (mut outside, mut runs) = (0, 0);
        for run in events.chunk_by(|x, y| x.t_us / 40_000 == y.t_us / 40_000) {
            // split further into runs of 1 to 40 events (fewer than `keep_every` once thinned)
            for part in run.chunks(1 + runs % 40) {
                runs += 1;
                outside += usize::from(part.iter().any(|e| e.x >= 640 || e.y >= 480));
                part.iter().for_each(|e| a.push(e));
                b.push_run(part);
                assert_eq!((a.arrived, a.skipped, a.events.len()), (b.arrived, b.skipped, b.events.len()));
            }
            let t = run[run.len() - 1].t_us;
            est_a.extend(a.update(t));
            est_b.extend(b.update(t));
        }
        assert!(a.keep_every > 1 && est_a.len() > 10, "keep 1 in {}, {} estimates", a.keep_every, est_a.len());
        assert!(outside > 10 && outside < runs / 2, "{outside} runs of {runs} with events outside");
        let weights = |e: &SpeedEstimator| e.events.iter().map(|k| (k.t_us, k.x, k.yb, k.weight)).collect::<Vec<_>>();
        assert_eq!(weights(&a), weights(&b));
        assert_eq!(format!("{est_a:?}"), format!("{est_b:?}"));
    }

    #[test]
    fn tracking_searches_the_whole_range_about_once_a_second() {
        let events = moving(32.0, true, 0.05, 3.0, 11);
        let mut e = SpeedEstimator::new(SpeedEstimatorConfig::default(), Resolution::DVXPLORER).unwrap();
        let mut est = Vec::new();
        for ev in &events {
            e.push(ev);
            if e.due(ev.t_us) {
                est.extend(e.update(ev.t_us));
            }
        }
        assert!(est.len() >= 55, "{} estimates of {} updates", est.len(), e.updates);
        for x in &est[5..] {
            assert!((x.speed_mm_s / 32.0 - 1.0).abs() < 0.05 && x.forward, "{x:?}");
        }
        // the first update, then one a second
        assert!(e.global_searches <= 4, "{} whole-range searches of {} updates", e.global_searches, e.updates);
        let mut full = SpeedEstimator::new(SpeedEstimatorConfig::exhaustive(), Resolution::DVXPLORER).unwrap();
        for ev in &events {
            full.push(ev);
            if full.due(ev.t_us) {
                full.update(ev.t_us);
            }
        }
        // (the first update, at the first event, has too few events to search)
        assert_eq!(full.global_searches, full.updates - 1);
    }

    #[test]
    fn a_change_of_speed_or_direction_is_followed() {
        // 1.5 s forward at 8 mm/s, then 24 mm/s, then 24 mm/s the other way
        let mut events = Vec::new();
        for (k, (speed, forward)) in [(8.0, true), (24.0, true), (24.0, false)].into_iter().enumerate() {
            let t0 = k as i64 * 1_500_000;
            events.extend(
                moving(speed, forward, 0.05, 1.5, 5 + k as u64).into_iter().map(|e| Event { t_us: e.t_us + t0, ..e }),
            );
        }
        let est = run(&events);
        for x in &est {
            let (t, phase) = (x.t_us % 1_500_000, x.t_us / 1_500_000);
            let (speed, forward) = [(8.0, true), (24.0, true), (24.0, false)][phase as usize];
            // a changed direction is found by the next whole-range search (at most a second on)
            let settle_us = if phase == 2 { 1_300_000 } else { 500_000 };
            if t > settle_us {
                assert!((x.speed_mm_s / speed - 1.0).abs() < 0.05, "phase {phase}: {x:?}");
                assert_eq!(x.forward, forward, "phase {phase}: {x:?}");
            }
        }
    }

    #[test]
    fn more_sampled_events_than_the_image_can_count_are_refused() {
        let cfg = |max_events| SpeedEstimatorConfig { max_events, ..SpeedEstimatorConfig::default() };
        assert!(SpeedEstimator::new(cfg(65_535), Resolution::DVXPLORER).is_ok());
        let e = SpeedEstimator::new(cfg(65_536), Resolution::DVXPLORER).unwrap_err().to_string();
        assert!(e.contains("max_events in 1..=65535"), "{e}");
    }

    #[test]
    fn an_image_too_wide_for_exact_float_columns_is_refused() {
        // 10^7 mm/s over a 250 ms window moves the image by 86 million pixels (refused before
        // anything is allocated)
        let cfg = SpeedEstimatorConfig { max_mm_s: 1e7, ..SpeedEstimatorConfig::default() };
        let e = SpeedEstimator::new(cfg, Resolution::DVXPLORER).unwrap_err().to_string();
        assert!(e.contains("under 2^24 columns"), "{e}");
        let cfg = SpeedEstimatorConfig { max_mm_s: 1e3, ..SpeedEstimatorConfig::default() };
        assert!(SpeedEstimator::new(cfg, Resolution::DVXPLORER).is_ok());
    }

    #[test]
    fn a_column_bin_is_the_truncation_clamped_to_the_image() {
        let last = 700u32;
        let mut xs = vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0, 0.0, -0.5, -1.0, 0.999_999_94, 1.0];
        xs.extend([699.99994, 700.0, 700.5, 701.0, 2.0e9, 2_147_483_648.0, 1e20, -2.0e9, -1e20, f32::MAX, f32::MIN]);
        let mut r = 0x9e37_79b9_u32;
        for _ in 0..100_000 {
            r ^= r << 13;
            r ^= r >> 17;
            r ^= r << 5;
            xs.push(f32::from_bits(r));
            xs.push((r % 1_000_000) as f32 / 997.0 - 100.0);
        }
        for f in xs {
            assert_eq!(column_bin(f, last), (f as usize).min(last as usize) as u32, "{f:e}");
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

    #[test]
    fn the_speed_near_a_time_is_the_median_of_the_estimates_around_it() {
        let x = |t_ms: i64, v: f64| SpeedEstimate { t_us: t_ms * 1000, speed_mm_s: v, forward: true, gain: 2.0 };
        let given = [x(0, 30.0), x(400, 8.0), x(500, 8.5), x(600, 9.0), x(1_500, 16.0)];
        assert_eq!(speed_near(&given, 500_000, 200.0), Some(8.5));
        // an outlier among them moves the median little
        assert_eq!(speed_near(&given, 300_000, 400.0), Some(9.0));
        assert_eq!(speed_near(&given, 1_000_000, 100.0), None);
        // a whole stream: the estimator's own estimates
        let ev = tests::moving(16.0, true, 0.05, 0.7, 1);
        let est = estimates_of(&ev, &SpeedEstimatorConfig::default(), Resolution::DVXPLORER).unwrap();
        let v = speed_near(&est, ev[ev.len() / 2].t_us, 500.0).unwrap();
        assert!((v / 16.0 - 1.0).abs() < 0.05, "{v}");
    }
}
