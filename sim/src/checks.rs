//! The physics checks of the simulator (SIMULATOR.md), measured on fresh scans. `braille
//! sim-check` prints them; the tests hold them to their bounds.
//!
//! Signal figures (depth, speed, polarity, geometry) are measured with the noise switched off so
//! that they count what the dots make; the noise floor is measured with noise on and no contact.

use crate::board::{Board, BoardGeometry, BoardKind};
use crate::braille::{Cell, cell_of};
use crate::error::Result;
use crate::scan::{Direction, Scan, ScanConfig, simulate};
use crate::sensor::{CameraConfig, GelConfig, Sensor};
use encoders::{Event, Polarity};
use serde::Serialize;
use std::collections::BTreeMap;

/// The seed paper's measurement: events per dot at these depths over those at 0.2 mm.
pub const PAPER_DEPTH_GAIN: [(f64, f64); 3] = [(0.6, 0.45), (1.0, 0.71), (1.5, 0.91)];
pub const DEPTHS_MM: [f64; 7] = [0.2, 0.4, 0.6, 0.8, 1.0, 1.2, 1.5];
pub const SPEEDS_MM_S: [f64; 4] = [8.0, 16.0, 24.0, 32.0];

/// What the checks measure.
#[derive(Debug, Clone, Serialize)]
pub struct CheckReport {
    /// Events per dot at each depth (mm, as text) over those at 0.2 mm, minus one.
    pub depth_gain: BTreeMap<String, f64>,
    pub events_per_dot: BTreeMap<String, f64>,
    /// Largest relative deviation of events per pass from their mean across 8-32 mm/s.
    pub speed_spread: f64,
    pub events_per_pass: BTreeMap<String, f64>,
    /// Event rate during the slide, per speed.
    pub event_rate_hz: BTreeMap<String, f64>,
    /// ON / OFF events over one pass (1.0 mm, 8 mm/s).
    pub on_off_ratio: f64,
    /// Lag between a cell's two dot columns at the sensor's centre, per speed, and 2.5 mm / speed.
    pub column_lag_ms: BTreeMap<String, f64>,
    pub expected_column_lag_ms: BTreeMap<String, f64>,
    /// Polarity of the first and last events of the pixels a dot passes, per direction.
    pub leading_polarity: BTreeMap<String, String>,
    pub trailing_polarity: BTreeMap<String, String>,
    /// Pixel rows (640x480 scale) in which one dot makes events, per depth.
    pub blob_width_px: BTreeMap<String, f64>,
    /// Letters whose six-dot pattern was read back from the events, of 26.
    pub patterns_recovered: usize,
    pub patterns_failed: Vec<char>,
    /// With no contact: measured and configured noise rate.
    pub noise_rate_hz: f64,
    pub expected_noise_rate_hz: f64,
    /// Time from the end of the motion until the last event before lifting.
    pub static_settle_ms: f64,
    /// Smallest gap between two events of one pixel, and whether every timestamp is on the grid.
    pub min_pixel_gap_us: i64,
    pub on_readout_grid: bool,
    /// The same seed gave the same stream, bit for bit.
    pub deterministic: bool,
}

fn quiet_sensor(seed: u64) -> Result<Sensor> {
    Sensor::new(CameraConfig::default().without_noise(), GelConfig::default(), seed)
}

fn single(text: &str, seed: u64) -> Result<Board> {
    Board::new(BoardKind::Text(text.into()), BoardGeometry::default(), seed)
}

fn steady(depth_mm: f64, speed_mm_s: f64, seed: u64) -> ScanConfig {
    ScanConfig { depth_mm, speed_mm_s, speed_ripple: 0.0, misalignment_sigma_mm: 0.0, seed, ..ScanConfig::default() }
}

fn count(events: &[Event], polarity: Polarity) -> usize {
    events.iter().filter(|e| e.polarity == polarity).count()
}

/// Depth gains relative to 0.2 mm: events of one dot, averaged over `trials` printed boards (each
/// with its own tolerances) and scans.
pub fn depth(gel: &GelConfig, trials: u64) -> Result<(BTreeMap<String, f64>, BTreeMap<String, f64>)> {
    let sensor = Sensor::new(CameraConfig::default().without_noise(), gel.clone(), 1)?;
    let mut per_dot = BTreeMap::new();
    for d in DEPTHS_MM {
        let mut n = 0.0;
        for t in 0..trials {
            n += simulate(&single("A", 100 + t)?, &sensor, &steady(d, 8.0, t))?.events.len() as f64;
        }
        per_dot.insert(format!("{d:.1}"), n / trials as f64);
    }
    let base = per_dot["0.2"];
    let gain = per_dot.iter().filter(|(k, _)| *k != "0.2").map(|(k, v)| (k.clone(), v / base - 1.0)).collect();
    Ok((gain, per_dot))
}

/// Pixel rows holding at least `min_events` events of one dot.
pub fn blob_width_px(scan: &Scan, min_events: usize, width: usize) -> f64 {
    let mut per_row: BTreeMap<u16, usize> = BTreeMap::new();
    for e in &scan.events {
        *per_row.entry(e.y).or_default() += 1;
    }
    let rows = per_row.values().filter(|&&n| n >= min_events).count();
    rows as f64 * 640.0 / width as f64
}

/// Times of events in a band of columns at the sensor's centre, clustered into the passes of two
/// dot columns (two-means in time); returns the lag between the two clusters' mean times.
pub fn column_lag_ms(scan: &Scan, band_px: u16) -> Option<f64> {
    let w = scan.truth.resolution.width;
    let (a, b) = (w / 2 - band_px / 2, w / 2 + band_px / 2);
    let t: Vec<f64> = scan.events.iter().filter(|e| e.x >= a && e.x < b).map(|e| e.t_us as f64).collect();
    if t.len() < 4 {
        return None;
    }
    let mut split = t.iter().sum::<f64>() / t.len() as f64;
    let mut means = (0.0, 0.0);
    for _ in 0..20 {
        let (lo, hi): (Vec<f64>, Vec<f64>) = t.iter().partition(|&&x| x < split);
        if lo.is_empty() || hi.is_empty() {
            return None;
        }
        means = (lo.iter().sum::<f64>() / lo.len() as f64, hi.iter().sum::<f64>() / hi.len() as f64);
        split = (means.0 + means.1) / 2.0;
    }
    Some((means.1 - means.0) / 1000.0)
}

/// The polarity most pixels show first (leading edge) and last (trailing edge).
pub fn edge_polarities(events: &[Event]) -> (Polarity, Polarity) {
    let mut first: BTreeMap<(u16, u16), Polarity> = BTreeMap::new();
    let mut last: BTreeMap<(u16, u16), Polarity> = BTreeMap::new();
    for e in events {
        first.entry((e.x, e.y)).or_insert(e.polarity);
        last.insert((e.x, e.y), e.polarity);
    }
    let majority = |m: &BTreeMap<(u16, u16), Polarity>| {
        let on = m.values().filter(|p| **p == Polarity::On).count();
        if 2 * on >= m.len() { Polarity::On } else { Polarity::Off }
    };
    (majority(&first), majority(&last))
}

/// Reads each raised dot back from the events: for each of the six dot places, the events near
/// its pixel row while its column is at the sensor's centre.
pub fn recover_cells(scan: &Scan) -> Vec<(char, Cell)> {
    let tr = &scan.truth;
    let (w, h) = (tr.resolution.width as f64, tr.resolution.height as f64);
    let pitch = tr.pitch_mm;
    let spacing = 2.5;
    let column_lag_s = spacing / tr.scan.speed_mm_s;
    let half_window = (0.3 * column_lag_s * 1e6) as i64;
    let band = (0.5 * spacing / pitch) as i64;
    let mut out = Vec::new();
    for ch in &tr.characters {
        let Some(t_cell) = ch.t_cell_center_s else { continue };
        let mut counts = [0usize; 6];
        for col in 0..2u8 {
            // The column is at the centre half a dot spacing before / after the cell's centre.
            let t_col = t_cell + (col as f64 - 0.5) * column_lag_s;
            let t = (t_col * 1e6) as i64;
            for row in 0..3u8 {
                // Dot row relative to the sensor's centre line (which sits on the row's centre
                // line, shifted by the misalignment).
                let y_mm = (row as f64 - 1.0) * spacing - tr.misalignment_mm;
                let py = (h / 2.0 + y_mm / pitch - 0.5).round() as i64;
                let cx = (w / 2.0) as i64;
                counts[(col * 3 + row) as usize] = scan
                    .events
                    .iter()
                    .filter(|e| (e.t_us - t).abs() <= half_window)
                    .filter(|e| (e.y as i64 - py).abs() <= band && (e.x as i64 - cx).abs() <= band)
                    .count();
            }
        }
        let max = *counts.iter().max().unwrap_or(&0);
        let mut bits = 0u8;
        for (k, &c) in counts.iter().enumerate() {
            if max > 0 && c * 4 > max {
                bits |= 1 << k;
            }
        }
        out.push((ch.letter, Cell(bits)));
    }
    out
}

/// Runs every check. `trials` repeats the depth measurement over boards and seeds.
impl CheckReport {
    /// The checks as a Markdown table beside what each should give.
    pub fn markdown(&self) -> String {
        use std::fmt::Write as _;
        let r = self;
        let mut m = String::new();
        let _ = writeln!(m, "Simulator physics checks (simulated scans; see SIMULATOR.md):\n");
        let _ = writeln!(m, "| check | measured | expected |\n| --- | --- | --- |");
        for (d, target) in PAPER_DEPTH_GAIN {
            let g = r.depth_gain[&format!("{d:.1}")];
            let _ = writeln!(
                m,
                "| 1. events per dot at {d} mm over 0.2 mm | +{:.0}% | +{:.0}% +-10 points (paper) |",
                g * 100.0,
                target * 100.0
            );
        }
        let _ = writeln!(
            m,
            "| 2. events per pass across 8-32 mm/s | largest deviation {:.1}% | within 15% |",
            r.speed_spread * 100.0
        );
        for v in SPEEDS_MM_S {
            let key = format!("{v:.0}");
            let _ = writeln!(
                m,
                "| 2. column lag at {key} mm/s | {:.1} ms | {:.1} ms (2.5 mm / speed) |",
                r.column_lag_ms[&key], r.expected_column_lag_ms[&key]
            );
        }
        let _ = writeln!(m, "| 3. ON/OFF ratio per pass | {:.2} | 0.9-1.2 |", r.on_off_ratio);
        let _ = writeln!(
            m,
            "| 3. leading / trailing edge, forward | {} / {} | opposite |\n| 3. leading / trailing edge, reverse | {} / {} | opposite; each physical edge swaps |",
            r.leading_polarity["forward"],
            r.trailing_polarity["forward"],
            r.leading_polarity["reverse"],
            r.trailing_polarity["reverse"]
        );
        for (d, w) in &r.blob_width_px {
            let expected = if d == "0.2" { "about 27 px" } else { "34-55 px" };
            let _ = writeln!(m, "| 4. dot blob width at {d} mm | {w:.0} px | {expected} |");
        }
        let _ = writeln!(m, "| 4. six-dot patterns read back from events | {}/26 | 26/26 |", r.patterns_recovered);
        let _ = writeln!(
            m,
            "| 5. noise floor without contact | {:.0} Hz | {:.0} Hz configured |",
            r.noise_rate_hz, r.expected_noise_rate_hz
        );
        let _ =
            writeln!(m, "| 6. last event after the motion stops | {:.1} ms | within about 5 ms |", r.static_settle_ms);
        let _ = writeln!(
            m,
            "| 7. smallest gap between events of one pixel | {} us | >= 500 us refractory |",
            r.min_pixel_gap_us
        );
        let _ = writeln!(m, "| 7. timestamps on the 200 us readout grid | {} | true |", r.on_readout_grid);
        let _ = writeln!(m, "| 8. same seed, same stream bit for bit | {} | true |", r.deterministic);
        m
    }
}

pub fn run(trials: u64) -> Result<CheckReport> {
    let (depth_gain, events_per_dot) = depth(&GelConfig::default(), trials)?;
    let quiet = quiet_sensor(1)?;

    // Speed: one dot, events per pass; rate during the slide; lag between the columns of "C".
    let mut events_per_pass = BTreeMap::new();
    let mut event_rate_hz = BTreeMap::new();
    let mut column_lag = BTreeMap::new();
    let mut expected_lag = BTreeMap::new();
    let dot = single("A", 3)?;
    let exact = BoardGeometry { position_sigma_mm: 0.0, ..BoardGeometry::default() };
    let c = Board::new(BoardKind::Text("C".into()), exact, 3)?;
    for v in SPEEDS_MM_S {
        let s = simulate(&dot, &quiet, &steady(1.0, v, 1))?;
        let key = format!("{v:.0}");
        let tl = s.truth.timeline;
        events_per_pass.insert(key.clone(), s.events.len() as f64);
        event_rate_hz.insert(key.clone(), s.events.len() as f64 / (tl.slide_end_s - tl.slide_start_s));
        let s = simulate(&c, &quiet, &steady(1.0, v, 1))?;
        column_lag.insert(key.clone(), column_lag_ms(&s, 10).unwrap_or(f64::NAN));
        expected_lag.insert(key, 2.5 / v * 1000.0);
    }
    let mean = events_per_pass.values().sum::<f64>() / events_per_pass.len() as f64;
    let speed_spread = events_per_pass.values().map(|n| (n / mean - 1.0).abs()).fold(0.0, f64::max);

    // Polarity.
    let pass = simulate(&dot, &quiet, &steady(1.0, 8.0, 1))?;
    let on_off_ratio = count(&pass.events, Polarity::On) as f64 / count(&pass.events, Polarity::Off).max(1) as f64;
    let mut leading = BTreeMap::new();
    let mut trailing = BTreeMap::new();
    for (name, direction) in [("forward", Direction::Forward), ("reverse", Direction::Reverse)] {
        let s = simulate(&dot, &quiet, &ScanConfig { direction, ..steady(1.0, 8.0, 1) })?;
        let (l, t) = edge_polarities(&s.events);
        leading.insert(name.to_string(), format!("{l:?}"));
        trailing.insert(name.to_string(), format!("{t:?}"));
    }

    // Geometry.
    let mut blob = BTreeMap::new();
    for d in [0.2, 0.6, 1.0, 1.5] {
        let s = simulate(&dot, &quiet, &steady(d, 8.0, 1))?;
        blob.insert(format!("{d:.1}"), blob_width_px(&s, 10, quiet.camera.resolution.width as usize));
    }
    let letters = Board::new(
        BoardKind::Text("ABCDEFGHIJKLM/NOPQRSTUVWXYZ".into()),
        BoardGeometry { cell_spacing_mm: 10.0, ..BoardGeometry::default() },
        5,
    )?;
    let mut recovered = 0;
    let mut failed = Vec::new();
    for row in 0..2 {
        let s = simulate(&letters, &quiet, &ScanConfig { row, ..steady(1.0, 16.0, 2) })?;
        for (letter, cell) in recover_cells(&s) {
            if cell_of(letter) == Some(cell) {
                recovered += 1;
            } else {
                failed.push(letter);
            }
        }
    }

    // Noise floor: no dots on the board, noise on.
    let noisy = Sensor::new(CameraConfig::default(), GelConfig::default(), 1)?;
    let blank = single(" ", 1)?;
    let s = simulate(&blank, &noisy, &steady(1.0, 8.0, 4))?;
    let noise_rate_hz = s.events.len() as f64 / s.truth.timeline.end_s;

    // Static hold: stop with the dot under the sensor's centre.
    let stop = ScanConfig { slide_mm: Some(dot.characters[0].x_mm), hold_s: 0.2, ..steady(1.0, 8.0, 1) };
    let s = simulate(&dot, &quiet, &stop)?;
    let tl = s.truth.timeline;
    let (end_us, lift_us) = ((tl.slide_end_s * 1e6) as i64, (tl.lift_start_s * 1e6) as i64);
    let last_in_hold = s.events.iter().filter(|e| e.t_us >= end_us && e.t_us < lift_us).map(|e| e.t_us).max();
    let static_settle_ms = last_in_hold.map_or(0.0, |t| (t - end_us) as f64 / 1000.0);

    // Readout on a noisy scan of a letter board.
    let s = simulate(&single("GH", 6)?, &noisy, &ScanConfig { speed_mm_s: 32.0, seed: 9, ..ScanConfig::default() })?;
    let (min_pixel_gap_us, on_readout_grid) = readout(&s, noisy.camera.readout_grid_us);
    let again =
        simulate(&single("GH", 6)?, &noisy, &ScanConfig { speed_mm_s: 32.0, seed: 9, ..ScanConfig::default() })?;

    Ok(CheckReport {
        depth_gain,
        events_per_dot,
        speed_spread,
        events_per_pass,
        event_rate_hz,
        on_off_ratio,
        column_lag_ms: column_lag,
        expected_column_lag_ms: expected_lag,
        leading_polarity: leading,
        trailing_polarity: trailing,
        blob_width_px: blob,
        patterns_recovered: recovered,
        patterns_failed: failed,
        noise_rate_hz,
        expected_noise_rate_hz: noisy.camera.noise_rate_hz(),
        static_settle_ms,
        min_pixel_gap_us,
        on_readout_grid,
        deterministic: again.events == s.events && again.truth == s.truth,
    })
}

/// Smallest interval between two events of one pixel, and whether all times are on the grid.
pub fn readout(scan: &Scan, grid_us: i64) -> (i64, bool) {
    let mut last: std::collections::HashMap<(u16, u16), i64> = std::collections::HashMap::new();
    let mut gap = i64::MAX;
    for e in &scan.events {
        if let Some(prev) = last.insert((e.x, e.y), e.t_us) {
            gap = gap.min(e.t_us - prev);
        }
    }
    (gap, scan.events.iter().all(|e| e.t_us % grid_us == 0))
}
