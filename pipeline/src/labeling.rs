//! The paper's labeling pipeline: character windows found from the events alone.
//!
//! 1. Heat maps in 10 ms bins, pooled by 4 (eq. 4); the activity profile `S(t)` (eq. 5) sums the
//!    events of a 10-pixel-wide start window.
//! 2. `S(t)` is smoothed by a moving average of 7 bins; its local maxima are the onsets of the
//!    dot columns.
//! 3. Peaks within a merging window belong to one character; the window grows from 300 ms to
//!    450 ms until the number of characters equals the known count.
//! 4. Each character's window is `[t_max, t_max + 350 ms]`, shifted by 280 ms for single-column
//!    characters; pixels outside columns 20..100 are masked.
//!
//! Beyond the paper, a running median takes the spikes out of the start window's events before
//! step 2 ([`LabelerConfig::despike_bins`]): a slide with stick-slip moves the image in jumps,
//! each jump a burst of events from everything in view, and at the paper's smoothing every burst
//! was a peak of its own (docs/labeling.md).
//!
//! The paper's constants hold at 8 mm/s. At other speeds every duration scales by
//! `8 mm/s / speed`, so that it spans the same distance on the board (the geometry is what they
//! encode: 350 ms at 8 mm/s is 2.8 mm of travel). Our reading of what the paper leaves open: the
//! start window sits at pooled columns 100..110, just before the active region in the direction
//! the image moves (a forward scan moves it towards column 0), and spans pooled rows 10..110 (the
//! image's height but its outer 40 pixels: see [`LabelerConfig::start_window_rows`]); a local
//! maximum counts as a peak
//! when it reaches `min_peak_fraction` of the profile's largest value; the network input is the
//! 20 frames of 10 ms (scaled) centred in the window.

use crate::error::{Error, Result};
use encoders::heatmap::{Heatmap, HeatmapConfig, HeatmapEncoder};
use encoders::{Event, Resolution};
use serde::{Deserialize, Serialize};
use std::ops::Range;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LabelerConfig {
    /// The speed the durations below are given for (the paper's 8 mm/s).
    pub reference_speed_mm_s: f64,
    pub bin_ms: f64,
    pub pool: u16,
    /// Pooled columns summed into the activity profile.
    pub start_window_cols: Range<u16>,
    /// Pooled rows summed into the activity profile: 10..110 of a 480-pixel-high image, the
    /// middle 11.6 mm of its 14 mm. The row's own cells span 6 mm about the centre, and the 2.8 mm
    /// either side take misalignment and yaw; the next rows' nearest dots (7.5 mm from the centre
    /// at 10 mm line spacing) press the gel at the image's edge, and summed in they add a peak for
    /// each of their dot columns. Files written before this field existed read the default.
    #[serde(default = "LabelerConfig::default_start_window_rows")]
    pub start_window_rows: Range<u16>,
    /// Pooled columns kept in the windows; the rest is masked.
    pub active_cols: Range<u16>,
    pub smoothing_bins: usize,
    /// Bins of the running median applied to the start window's events before the moving
    /// average (0 or 1: none, the paper's profile). A jump of stick-slip packs the events of a
    /// stretch of motion into one or two bins; a median over 9 bins (0.72 mm of travel at the
    /// reference speed) keeps the level between the jumps, which follows the content in view,
    /// and drops the jumps. Chosen on the validation boards (docs/labeling.md); files written
    /// before it existed read the default.
    #[serde(default = "LabelerConfig::default_despike_bins")]
    pub despike_bins: usize,
    pub min_peak_fraction: f32,
    pub merge_min_ms: f64,
    pub merge_max_ms: f64,
    pub merge_step_ms: f64,
    pub window_ms: f64,
    pub single_column_shift_ms: f64,
    /// Frames of the network input, each `bin_ms` long (scaled with speed).
    pub frames: usize,
}

impl Default for LabelerConfig {
    fn default() -> Self {
        Self {
            reference_speed_mm_s: 8.0,
            bin_ms: 10.0,
            pool: 4,
            start_window_cols: 100..110,
            start_window_rows: Self::default_start_window_rows(),
            active_cols: 20..100,
            smoothing_bins: 7,
            despike_bins: Self::default_despike_bins(),
            min_peak_fraction: 0.2,
            merge_min_ms: 300.0,
            merge_max_ms: 450.0,
            merge_step_ms: 10.0,
            window_ms: 350.0,
            single_column_shift_ms: 280.0,
            frames: 20,
        }
    }
}

/// One character found in a stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CharWindow {
    /// The character's last peak: the onset of its second column, or of its only one.
    pub t_max_us: i64,
    /// Dot-column peaks merged into it (1 for single-column characters).
    pub peaks: usize,
    /// The labelled window.
    pub t_start_us: i64,
    pub t_end_us: i64,
}

/// What the labeler found in one stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Labeling {
    pub windows: Vec<CharWindow>,
    /// The merging window that gave the expected count (or came closest).
    pub merge_window_ms: f64,
    /// Whether the count matched the expected number of characters.
    pub count_matched: bool,
    /// The smoothed activity profile, one value per bin from `t0_us`.
    pub profile: Vec<f32>,
    pub t0_us: i64,
    pub bin_us: i64,
}

impl LabelerConfig {
    /// The default of [`Self::start_window_rows`].
    pub fn default_start_window_rows() -> Range<u16> {
        10..110
    }

    /// The default of [`Self::despike_bins`].
    pub fn default_despike_bins() -> usize {
        9
    }

    /// Durations scaled to `speed_mm_s`, in microseconds.
    fn scaled_us(&self, ms: f64, speed_mm_s: f64) -> i64 {
        (ms * 1e3 * self.reference_speed_mm_s / speed_mm_s).round() as i64
    }

    fn validate(&self, speed_mm_s: f64) -> Result<()> {
        let ok = speed_mm_s > 0.0
            && self.bin_ms > 0.0
            && self.smoothing_bins >= 1
            && self.merge_min_ms <= self.merge_max_ms
            && self.merge_step_ms > 0.0
            && self.frames >= 1
            && self.start_window_cols.start < self.start_window_cols.end
            && self.start_window_rows.start < self.start_window_rows.end
            && self.active_cols.start < self.active_cols.end;
        if ok {
            Ok(())
        } else {
            Err(Error::Setting {
                name: "labeler configuration",
                value: format!("{self:?} at {speed_mm_s} mm/s"),
                expected: "positive durations, frames and thresholds, a positive speed",
            })
        }
    }

    /// The bin width at `speed_mm_s`.
    pub fn bin_us(&self, speed_mm_s: f64) -> i64 {
        self.scaled_us(self.bin_ms, speed_mm_s).max(1)
    }
}

/// Moving average over `k` bins, centred (the ends average what exists).
pub fn moving_average(x: &[f32], k: usize) -> Vec<f32> {
    let half = k / 2;
    (0..x.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(half), (i + k - half).min(x.len()));
            x[a..b].iter().sum::<f32>() / (b - a) as f32
        })
        .collect()
}

/// Indices of local maxima of `x` that reach `min_fraction` of its largest value (a plateau
/// counts once, at its first bin).
pub fn peaks(x: &[f32], min_fraction: f32) -> Vec<usize> {
    let max = x.iter().cloned().fold(0.0f32, f32::max);
    let floor = max * min_fraction;
    let mut out = Vec::new();
    let mut i = 1;
    while i + 1 < x.len() {
        if x[i] > x[i - 1] && x[i] >= floor && x[i] > 0.0 {
            let mut j = i;
            while j + 1 < x.len() && x[j + 1] == x[i] {
                j += 1;
            }
            if j + 1 < x.len() && x[j + 1] < x[i] {
                out.push(i);
            }
            i = j + 1;
        } else {
            i += 1;
        }
    }
    out
}

/// Centred running median over `k` bins (the ends take what exists).
pub fn running_median(x: &[f32], k: usize) -> Vec<f32> {
    let half = k / 2;
    let mut w = Vec::with_capacity(k);
    (0..x.len())
        .map(|i| {
            w.clear();
            w.extend_from_slice(&x[i.saturating_sub(half)..(i + k - half).min(x.len())]);
            w.sort_by(f32::total_cmp);
            w[w.len() / 2]
        })
        .collect()
}

/// Groups peak times: a peak within `window_us` of its group's first peak joins it.
fn merge(peak_us: &[i64], window_us: i64) -> Vec<Vec<i64>> {
    let mut groups: Vec<Vec<i64>> = Vec::new();
    for &t in peak_us {
        match groups.last_mut() {
            Some(g) if t - g[0] <= window_us => g.push(t),
            _ => groups.push(vec![t]),
        }
    }
    groups
}

/// Finds the windows of `expected` characters in `events` (in time order) from a sensor of
/// `resolution` sliding at `speed_mm_s`.
pub fn label(
    events: &[Event],
    resolution: Resolution,
    speed_mm_s: f64,
    expected: usize,
    cfg: &LabelerConfig,
) -> Result<Labeling> {
    cfg.validate(speed_mm_s)?;
    let bin_us = cfg.bin_us(speed_mm_s);
    let (t0, t1) = match (events.first(), events.last()) {
        (Some(a), Some(b)) => (a.t_us, b.t_us),
        _ => (0, 0),
    };
    let bins = ((t1 - t0) / bin_us + 1) as usize;
    // Activity profile (eq. 5): the sum over the start window's cells of each bin's heat map,
    // counted directly rather than through a heat map per bin.
    let mut raw = vec![0f32; bins];
    for e in events {
        let col = e.x / cfg.pool;
        if cfg.start_window_cols.contains(&col)
            && cfg.start_window_rows.contains(&(e.y / cfg.pool))
            && e.y < resolution.height
        {
            raw[((e.t_us - t0) / bin_us) as usize] += 1.0;
        }
    }
    if cfg.despike_bins > 1 {
        raw = running_median(&raw, cfg.despike_bins);
    }
    // Bins scale with speed, so the 7-bin kernel spans the same distance at every speed.
    let profile = moving_average(&raw, cfg.smoothing_bins);
    let peak_us: Vec<i64> =
        peaks(&profile, cfg.min_peak_fraction).into_iter().map(|b| t0 + b as i64 * bin_us).collect();

    // Grow the merging window until the count matches; else keep the closest.
    let mut best: Option<(usize, f64, Vec<Vec<i64>>)> = None;
    let mut w = cfg.merge_min_ms;
    while w <= cfg.merge_max_ms + 1e-9 {
        let groups = merge(&peak_us, cfg.scaled_us(w, speed_mm_s));
        let miss = groups.len().abs_diff(expected);
        if best.as_ref().is_none_or(|b| miss < b.0) {
            best = Some((miss, w, groups));
        }
        if miss == 0 {
            break;
        }
        w += cfg.merge_step_ms;
    }
    let (miss, merge_window_ms, groups) = best.unwrap_or((expected, cfg.merge_min_ms, Vec::new()));
    let window_us = cfg.scaled_us(cfg.window_ms, speed_mm_s);
    let shift_us = cfg.scaled_us(cfg.single_column_shift_ms, speed_mm_s);
    let column_lag_us = cfg.scaled_us(312.5, speed_mm_s);
    let windows = groups
        .iter()
        .map(|g| {
            let t_max = g[g.len() - 1];
            // A second column comes one dot spacing (312 ms at 8 mm/s) after the first; peaks
            // closer together are edges of one column.
            let two_columns = t_max - g[0] >= column_lag_us / 2;
            let start = if two_columns { t_max } else { t_max + shift_us };
            CharWindow { t_max_us: t_max, peaks: g.len(), t_start_us: start, t_end_us: start + window_us }
        })
        .collect();
    Ok(Labeling { windows, merge_window_ms, count_matched: miss == 0, profile, t0_us: t0, bin_us })
}

/// The network input of one window: `frames` bins of the (speed-scaled) bin width centred in the
/// window, pooled, with the columns outside the active region masked.
pub fn window_heatmap(
    events: &[Event],
    resolution: Resolution,
    speed_mm_s: f64,
    w: &CharWindow,
    cfg: &LabelerConfig,
) -> Result<Heatmap> {
    let bin_us = cfg.bin_us(speed_mm_s);
    let span = bin_us * cfg.frames as i64;
    let start = w.t_start_us + ((w.t_end_us - w.t_start_us) - span) / 2;
    let hm = HeatmapEncoder::new(
        HeatmapConfig::new(resolution).with_pool(cfg.pool).with_bin_us(bin_us).with_mask_cols(cfg.active_cols.clone()),
    )?;
    let a = events.partition_point(|e| e.t_us < start);
    let b = events.partition_point(|e| e.t_us < start + span);
    Ok(hm.encode(&events[a..b], start, cfg.frames))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_and_smoothing() {
        let x = [0.0, 1.0, 3.0, 1.0, 0.0, 0.0, 2.0, 2.0, 1.0, 0.1, 0.2, 0.0];
        assert_eq!(peaks(&x, 0.2), vec![2, 6]); // 0.2 is below 20% of the maximum
        let m = moving_average(&[0.0, 0.0, 3.0, 0.0, 0.0], 3);
        assert_eq!(m, vec![0.0, 1.0, 1.0, 1.0, 0.0]);
    }

    #[test]
    fn the_running_median_drops_a_burst_and_keeps_a_slow_bump() {
        // A two-bin burst goes; a bump five bins wide (the content in view) stays.
        let x = [1.0, 1.0, 1.0, 9.0, 9.0, 1.0, 1.0, 1.0, 1.0, 4.0, 4.0, 4.0, 4.0, 4.0, 1.0, 1.0];
        let m = running_median(&x, 5);
        // (At the end the window is four bins, and its median the upper middle.)
        assert_eq!(m, vec![1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 4.0, 4.0, 4.0, 4.0, 4.0, 4.0, 1.0]);
        assert_eq!(running_median(&x, 1), x.to_vec());
    }

    #[test]
    fn merging_groups_columns_of_one_character() {
        let g = merge(&[0, 312_000, 2_000_000, 4_000_000, 4_300_000], 350_000);
        assert_eq!(g.len(), 3);
        assert_eq!(g[0], vec![0, 312_000]);
    }
}
