//! Background-activity denoising, as event-camera practice does before any recognition: the
//! spatio-temporal correlation filter of libcaer's DVS noise filter (DV's `dv_dvsnoisefilter`
//! module) and of dv-processing's `noise.BackgroundActivityNoiseFilter`.
//!
//! An event passes when, among its eight neighbouring pixels, between `support_min` and
//! `support_max` had an event less than `window_us` before it (of the same polarity when
//! `check_polarity`); with a refractory period, an event less than `refractory_us` after the
//! previous event of its own pixel is dropped first. Every event, kept or dropped, writes its
//! pixel's timestamp, as libcaer's does. Memory is one timestamp and one polarity per pixel,
//! whatever the stream's length; the cost per event is a constant number of lookups
//! (`cargo bench --bench denoise`).
//!
//! One difference from libcaer and dv-processing, on purpose: their timestamp maps start at zero,
//! so that in the first `window_us` of a stream that starts at time zero every event counts as
//! supported; here a pixel that has not fired supports nothing. On streams whose first event comes
//! at least `window_us` after time zero (DV's recordings carry Unix-epoch microseconds) the two
//! agree event for event (`tests/interop.rs` checks it against dv-processing).
//!
//! ```
//! use encoders::denoise::{BackgroundActivityFilter, NoiseFilterSettings};
//! use encoders::{Event, Polarity, Resolution};
//!
//! let mut filter = BackgroundActivityFilter::new(Resolution::DVXPLORER, NoiseFilterSettings::DV_PROCESSING).unwrap();
//! let mut events = vec![
//!     Event::new(10_000, 100, 40, Polarity::On), // nothing near it before: dropped
//!     Event::new(10_500, 101, 40, Polarity::On), // its neighbour fired 0.5 ms before: kept
//!     Event::new(50_000, 300, 200, Polarity::Off), // alone: dropped
//! ];
//! filter.filter(&mut events);
//! assert_eq!(events.len(), 1);
//! assert_eq!((filter.stats().kept, filter.stats().background), (1, 2));
//! ```

use crate::formats::{EventSource, StreamInfo};
use crate::{Event, Polarity, Resolution};
use std::fmt;
use std::path::Path;
use std::str::FromStr;

/// The filter's settings, named as libcaer and DV name them. Written in full; read in full or
/// by name (`"dv-lab"`, `"dv-processing:2000"`, as [`FromStr`] reads them: a recipe key's value).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "SettingsForm")]
pub struct NoiseFilterSettings {
    /// `backgroundActivityTime`: a neighbour's event supports one that follows it within this.
    pub window_us: i64,
    /// `backgroundActivitySupportMin` and `SupportMax`: how many of the eight neighbours must
    /// support an event, and how many may (1 and 8: at least one).
    pub support_min: u8,
    pub support_max: u8,
    /// `backgroundActivityCheckPolarity`: only neighbours of the event's polarity support it.
    pub check_polarity: bool,
    /// `refractoryPeriodTime` when the refractory period filter is on.
    pub refractory_us: Option<i64>,
}

impl NoiseFilterSettings {
    /// The chain the seed's lab records its DVXplorer tactile sensor through (DV's noise filter:
    /// background activity 2 ms, 1 to 8 supporting neighbours, polarity not checked, refractory
    /// period 100 us, hot-pixel filter off; docs/simulator.md, "A lab's recording chain").
    pub const DV_LAB: NoiseFilterSettings = NoiseFilterSettings {
        window_us: 2_000,
        support_min: 1,
        support_max: 8,
        check_polarity: false,
        refractory_us: Some(100),
    };
    /// dv-processing's `noise.BackgroundActivityNoiseFilter` at its default duration (2 ms): one
    /// supporting neighbour, no refractory period.
    pub const DV_PROCESSING: NoiseFilterSettings = NoiseFilterSettings {
        window_us: 2_000,
        support_min: 1,
        support_max: 8,
        check_polarity: false,
        refractory_us: None,
    };

    /// Settings no filter can have, named.
    pub fn check(&self) -> Result<(), String> {
        if self.window_us <= 0 {
            return Err(format!("the background-activity window must be positive, not {} us", self.window_us));
        }
        if !(1..=8).contains(&self.support_min) || !(self.support_min..=8).contains(&self.support_max) {
            return Err(format!(
                "supporting neighbours {}..={}: expected 1 <= min <= max <= 8",
                self.support_min, self.support_max
            ));
        }
        if self.refractory_us.is_some_and(|r| r <= 0) {
            return Err("the refractory period must be positive (or off)".into());
        }
        Ok(())
    }
}

/// The named settings a command takes: `dv-lab` or `dv-processing`, optionally with another
/// window, `dv-processing:5000`.
/// The forms settings are read in: by name or field by field.
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum SettingsForm {
    Named(String),
    Fields { window_us: i64, support_min: u8, support_max: u8, check_polarity: bool, refractory_us: Option<i64> },
}

impl TryFrom<SettingsForm> for NoiseFilterSettings {
    type Error = String;
    fn try_from(form: SettingsForm) -> Result<Self, String> {
        match form {
            SettingsForm::Named(name) => name.parse(),
            SettingsForm::Fields { window_us, support_min, support_max, check_polarity, refractory_us } => {
                let s = NoiseFilterSettings { window_us, support_min, support_max, check_polarity, refractory_us };
                s.check()?;
                Ok(s)
            }
        }
    }
}

impl FromStr for NoiseFilterSettings {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (name, window) = s.split_once(':').map_or((s, None), |(n, w)| (n, Some(w)));
        let mut settings = match name {
            "dv-lab" => NoiseFilterSettings::DV_LAB,
            "dv-processing" => NoiseFilterSettings::DV_PROCESSING,
            _ => return Err(format!("unknown noise filter {name:?}: expected dv-lab or dv-processing[:WINDOW_US]")),
        };
        if let Some(w) = window {
            settings.window_us = w.parse().map_err(|_| format!("{w:?} is no window in microseconds"))?;
        }
        settings.check()?;
        Ok(settings)
    }
}

/// A reader's choice of filter over its models' own: `off`, or settings by name
/// (`dv-lab`, `dv-processing[:US]`), as `braille read --denoise` takes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DenoiseChoice {
    Off,
    On(NoiseFilterSettings),
}

impl DenoiseChoice {
    /// The filter a reader runs: the choice when one is made, else the models' own.
    pub fn over(choice: Option<DenoiseChoice>, models: Option<NoiseFilterSettings>) -> Option<NoiseFilterSettings> {
        match choice {
            None => models,
            Some(DenoiseChoice::Off) => None,
            Some(DenoiseChoice::On(s)) => Some(s),
        }
    }
}

impl FromStr for DenoiseChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "off" | "none" => Ok(DenoiseChoice::Off),
            _ => s.parse().map(DenoiseChoice::On).map_err(|e| format!("{e}, or off")),
        }
    }
}

impl fmt::Display for NoiseFilterSettings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "background activity {} us, {}-{} neighbours", self.window_us, self.support_min, self.support_max)?;
        if self.check_polarity {
            write!(f, " of the same polarity")?;
        }
        match self.refractory_us {
            Some(r) => write!(f, ", refractory period {r} us"),
            None => write!(f, ", no refractory period"),
        }
    }
}

/// What the filter did so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct FilterStats {
    pub kept: u64,
    /// Dropped as unsupported background activity.
    pub background: u64,
    /// Dropped within their pixel's refractory period.
    pub refractory: u64,
    /// Outside the resolution: passed through unfiltered (a stream read from a file was checked
    /// against its resolution already).
    pub outside: u64,
}

/// A pixel that has not fired: it supports nothing and starts no refractory period.
const NEVER_US: i64 = i64::MIN / 4;

/// The streaming filter: feed it events in time order, one at a time or a chunk at a time.
#[derive(Debug, Clone)]
pub struct BackgroundActivityFilter {
    settings: NoiseFilterSettings,
    width: usize,
    height: usize,
    last_us: Vec<i64>,
    last_on: Vec<bool>,
    stats: FilterStats,
}

impl BackgroundActivityFilter {
    pub fn new(resolution: Resolution, settings: NoiseFilterSettings) -> Result<Self, String> {
        settings.check()?;
        let (width, height) = (usize::from(resolution.width), usize::from(resolution.height));
        if width == 0 || height == 0 {
            return Err(format!("no pixels at resolution {}x{}", width, height));
        }
        Ok(Self {
            settings,
            width,
            height,
            last_us: vec![NEVER_US; width * height],
            last_on: vec![false; width * height],
            stats: FilterStats::default(),
        })
    }

    pub fn settings(&self) -> NoiseFilterSettings {
        self.settings
    }

    pub fn stats(&self) -> FilterStats {
        self.stats
    }

    /// The stream's uncorrelated activity per pixel, estimated from what the filter dropped as
    /// background over `span_us` of stream: the dropped events per pixel per second, over the
    /// chance that an event of such activity finds no neighbour within the window (`exp(-8 r w)`,
    /// solved for `r` by a few fixed-point steps). Background activity and hot pixels alike;
    /// events of the print that find no neighbour add to it, so the estimate is an upper bound
    /// near zero. `None` before any time has passed.
    pub fn background_rate_hz_per_pixel(&self, span_us: i64) -> Option<f64> {
        if span_us <= 0 {
            return None;
        }
        let pixels = (self.width * self.height) as f64;
        let dropped = self.stats.background as f64 / pixels / (span_us as f64 / 1e6);
        let (w_s, neighbours) = (self.settings.window_us as f64 / 1e6, 8.0);
        let mut r = dropped;
        for _ in 0..8 {
            r = dropped * (neighbours * r * w_s).exp();
        }
        Some(r)
    }

    /// Bytes the filter holds: a timestamp and a polarity per pixel.
    pub fn memory_bytes(&self) -> usize {
        self.last_us.capacity() * 8 + self.last_on.capacity()
    }

    /// Whether `e` passes; its pixel's timestamp is written either way.
    pub fn retain(&mut self, e: &Event) -> bool {
        let (x, y) = (usize::from(e.x), usize::from(e.y));
        if x >= self.width || y >= self.height {
            self.stats.outside += 1;
            return true;
        }
        let at = y * self.width + x;
        let on = e.polarity == Polarity::On;
        let keep = if self.settings.refractory_us.is_some_and(|r| e.t_us - self.last_us[at] < r) {
            self.stats.refractory += 1;
            false
        } else {
            let support = self.support(x, y, e.t_us, on);
            let keep =
                support >= u32::from(self.settings.support_min) && support <= u32::from(self.settings.support_max);
            if !keep {
                self.stats.background += 1;
            }
            keep
        };
        self.last_us[at] = e.t_us;
        self.last_on[at] = on;
        self.stats.kept += u64::from(keep);
        keep
    }

    /// Keeps the events of `events` that pass, in order.
    pub fn filter(&mut self, events: &mut Vec<Event>) {
        events.retain(|e| self.retain(e));
    }

    /// The neighbours of (x, y) that support an event of polarity `on` at `t_us`.
    fn support(&self, x: usize, y: usize, t_us: i64, on: bool) -> u32 {
        let (x0, x1) = (x.saturating_sub(1), (x + 1).min(self.width - 1));
        let (y0, y1) = (y.saturating_sub(1), (y + 1).min(self.height - 1));
        let mut n = 0;
        for ny in y0..=y1 {
            let row = ny * self.width;
            for nx in x0..=x1 {
                if nx == x && ny == y {
                    continue;
                }
                let at = row + nx;
                let recent = t_us - self.last_us[at] < self.settings.window_us;
                n += u32::from(recent && (!self.settings.check_polarity || self.last_on[at] == on));
            }
        }
        n
    }
}

/// An event source whose events pass a [`BackgroundActivityFilter`] first (or pass untouched
/// without settings): the stream stays bounded, chunk by chunk.
pub struct Denoised {
    inner: Box<dyn EventSource>,
    filter: Option<BackgroundActivityFilter>,
    kept: Vec<Event>,
}

impl Denoised {
    /// `inner` filtered with `settings` at its declared resolution, else at `fallback`.
    pub fn new(
        inner: Box<dyn EventSource>,
        fallback: Resolution,
        settings: Option<NoiseFilterSettings>,
    ) -> Result<Self, String> {
        let resolution = inner.info().resolution.unwrap_or(fallback);
        let filter = settings.map(|s| BackgroundActivityFilter::new(resolution, s)).transpose()?;
        Ok(Self { inner, filter, kept: Vec::new() })
    }

    /// The filter's settings and what it did so far; `None` without a filter.
    pub fn stats(&self) -> Option<(NoiseFilterSettings, FilterStats)> {
        self.filter.as_ref().map(|f| (f.settings(), f.stats()))
    }
}

impl EventSource for Denoised {
    fn info(&self) -> &StreamInfo {
        self.inner.info()
    }

    fn next_chunk(&mut self) -> crate::Result<Option<&[Event]>> {
        let Some(filter) = self.filter.as_mut() else { return self.inner.next_chunk() };
        loop {
            let Some(chunk) = self.inner.next_chunk()? else { return Ok(None) };
            self.kept.clear();
            self.kept.extend(chunk.iter().filter(|e| filter.retain(e)));
            if !self.kept.is_empty() {
                return Ok(Some(&self.kept));
            }
        }
    }

    fn path(&self) -> &Path {
        self.inner.path()
    }
}

impl fmt::Display for FilterStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let seen = self.kept + self.background + self.refractory;
        write!(
            f,
            "kept {} of {seen} events ({} unsupported, {} refractory",
            self.kept, self.background, self.refractory
        )?;
        if self.outside > 0 {
            write!(f, ", {} outside the resolution passed", self.outside)?;
        }
        write!(f, ")")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(t_us: i64, x: u16, y: u16) -> Event {
        Event::new(t_us, x, y, Polarity::On)
    }

    fn filter(width: u16, height: u16, settings: NoiseFilterSettings) -> BackgroundActivityFilter {
        BackgroundActivityFilter::new(Resolution { width, height }, settings).unwrap()
    }

    /// Which of `events` (time, x, y; ON) pass, in order.
    fn passes(f: &mut BackgroundActivityFilter, events: &[(i64, u16, u16)]) -> Vec<bool> {
        events.iter().map(|&(t, x, y)| f.retain(&ev(t, x, y))).collect()
    }

    #[test]
    fn a_readers_choice_overrides_its_models_filter_or_turns_it_off() {
        let lab = Some(NoiseFilterSettings::DV_LAB);
        assert_eq!(DenoiseChoice::over(None, lab), lab);
        assert_eq!(DenoiseChoice::over(None, None), None);
        assert_eq!(DenoiseChoice::over(Some("off".parse().unwrap()), lab), None);
        let dv = "dv-processing:3000".parse::<DenoiseChoice>().unwrap();
        assert_eq!(DenoiseChoice::over(Some(dv), lab).map(|s| (s.window_us, s.refractory_us)), Some((3000, None)));
        let e = "median".parse::<DenoiseChoice>().unwrap_err();
        assert!(e.contains("dv-lab") && e.contains("off"), "{e}");
    }

    #[test]
    fn uniform_background_activity_is_estimated_from_what_the_filter_drops() {
        // Poisson activity at `rate` on every pixel of 64 x 64 for 20 s (a seeded generator)
        for rate in [0.5, 2.0, 5.0] {
            let (w, h, span_us) = (64u16, 64u16, 20_000_000i64);
            let mut seed = 0x9E37_79B9_7F4A_7C15u64;
            let mut uniform = move || {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                (seed >> 11) as f64 / (1u64 << 53) as f64
            };
            let n = (rate * f64::from(w) * f64::from(h) * span_us as f64 / 1e6) as usize;
            let mut events: Vec<(i64, u16, u16)> = (0..n)
                .map(|_| {
                    let t = (uniform() * span_us as f64) as i64;
                    (t, (uniform() * f64::from(w)) as u16, (uniform() * f64::from(h)) as u16)
                })
                .collect();
            events.sort();
            let mut f = filter(w, h, NoiseFilterSettings::DV_LAB);
            passes(&mut f, &events);
            let est = f.background_rate_hz_per_pixel(span_us).unwrap();
            assert!((est / rate - 1.0).abs() < 0.05, "{rate} Hz estimated as {est}");
        }
        assert_eq!(filter(4, 4, NoiseFilterSettings::DV_LAB).background_rate_hz_per_pixel(0), None);
    }

    #[test]
    fn an_event_needs_a_recent_neighbour_not_itself() {
        let mut f = filter(8, 8, NoiseFilterSettings::DV_PROCESSING);
        // alone; the same pixel again (no neighbour of itself); a diagonal neighbour within 2 ms;
        // two pixels away; a neighbour exactly 2 ms after the last (the window is open below 2 ms)
        let events = [(10_000, 3, 3), (10_100, 3, 3), (11_000, 4, 4), (11_200, 6, 3), (13_000, 5, 5)];
        assert_eq!(passes(&mut f, &events), [false, false, true, false, false]);
        assert_eq!(f.stats(), FilterStats { kept: 1, background: 4, refractory: 0, outside: 0 });
        // at the corners and edges only the pixels inside count; outside the resolution: passed, counted
        let mut f = filter(4, 3, NoiseFilterSettings::DV_PROCESSING);
        let events = [(5_000, 0, 0), (5_001, 1, 1), (9_000, 3, 2), (9_500, 3, 1), (9_600, 4, 0)];
        assert_eq!(passes(&mut f, &events), [false, true, false, true, true]);
        assert_eq!(f.stats().outside, 1);
    }

    #[test]
    fn refractory_period_polarity_and_support_limits() {
        let mut f = filter(8, 8, NoiseFilterSettings::DV_LAB);
        assert!(!f.retain(&ev(10_000, 2, 2)));
        assert!(f.retain(&ev(10_500, 2, 3)));
        // the same pixel 50 us later: within its refractory period, whatever its support
        assert!(!f.retain(&ev(10_550, 2, 3)));
        assert_eq!(f.stats().refractory, 1);
        let polar = NoiseFilterSettings { check_polarity: true, ..NoiseFilterSettings::DV_PROCESSING };
        let mut f = filter(8, 8, polar);
        f.retain(&ev(1_000_000, 2, 2));
        assert!(!f.retain(&Event::new(1_000_100, 2, 3, Polarity::Off)));
        assert!(f.retain(&ev(1_000_200, 1, 2)));
        // at most one supporter: an event with two is dropped
        let one = NoiseFilterSettings { support_max: 1, ..NoiseFilterSettings::DV_PROCESSING };
        let mut f = filter(8, 8, one);
        f.retain(&ev(1_000, 0, 0));
        f.retain(&ev(1_001, 2, 0));
        assert!(!f.retain(&ev(1_002, 1, 0)));
    }

    #[test]
    fn settings_parse_and_refuse_what_no_filter_has() {
        assert_eq!("dv-lab".parse::<NoiseFilterSettings>().unwrap(), NoiseFilterSettings::DV_LAB);
        assert_eq!("dv-processing:5000".parse::<NoiseFilterSettings>().unwrap().window_us, 5_000);
        for bad in ["dv", "dv-lab:0", "dv-lab:x"] {
            assert!(bad.parse::<NoiseFilterSettings>().is_err(), "{bad}");
        }
        let zero = NoiseFilterSettings { support_min: 0, ..NoiseFilterSettings::DV_LAB };
        assert!(BackgroundActivityFilter::new(Resolution::DVXPLORER, zero).unwrap_err().contains("1 <= min"));
        assert!(
            BackgroundActivityFilter::new(Resolution { width: 0, height: 4 }, NoiseFilterSettings::DV_LAB).is_err()
        );
    }
}
