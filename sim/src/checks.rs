//! The physics checks of the simulator (SIMULATOR.md), measured on fresh scans at a realism
//! preset. `braille sim-check` prints them; [`CheckReport::failures`] holds each to its bounds,
//! and the tests call it.
//!
//! Signal figures (depth, speed, polarity, geometry) are measured with the noise switched off so
//! that they count what the dots make, on steady scans (no speed ripple, misalignment, yaw or
//! depth drift): they check the gel and the camera, not one trial's kinematics. The noise floor is
//! measured with noise on and no contact. The gel's own checks (lag and smear against speed, the
//! loop of a press and release) and the spread between sensor builds follow the eight.

use crate::board::{Board, BoardGeometry, BoardKind};
use crate::error::Result;
use crate::mount::{Contact, StickSlip};
use crate::realism::{Realism, Setup};
use crate::scan::{Direction, Scan, ScanConfig, simulate};
use crate::sensor::{GelConfig, GelDynamics, Sensor};
use encoders::braille::{Cell, cell_of};
use encoders::{Event, Polarity};
use serde::Serialize;
use std::collections::BTreeMap;

/// The seed paper's measurement: events per dot at these depths over those at 0.2 mm.
pub const PAPER_DEPTH_GAIN: [(f64, f64); 3] = [(0.6, 0.45), (1.0, 0.71), (1.5, 0.91)];
pub const DEPTHS_MM: [f64; 7] = [0.2, 0.4, 0.6, 0.8, 1.0, 1.2, 1.5];
pub const SPEEDS_MM_S: [f64; 4] = [8.0, 16.0, 24.0, 32.0];

/// Sensor builds drawn for the spread check, and the documented range of the coefficient of
/// variation of the events one dot makes in a pass (noise off: the noise floor has its own check).
/// Builds share the bias (mean threshold) and differ in threshold spread (10-20%: events per pixel
/// move by about sigma^2, 1-4%), LED gain (the photoreceptor's bandwidth) and gel (thickness and
/// modulus: the drag): a few percent in all.
pub const SENSOR_BUILDS: u64 = 8;
pub const SENSOR_SPREAD_RANGE: (f64, f64) = (0.002, 0.10);
/// Energy lost over a press and release of a dot, assumed for silicone gels (REALISM.md 1).
pub const HYSTERESIS_RANGE: (f64, f64) = (0.05, 0.15);

/// What the checks measure.
#[derive(Debug, Clone, Serialize)]
pub struct CheckReport {
    pub realism: Realism,
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
    /// One dot's events against where the dot is, per speed: the shift of their mean behind the
    /// dot and the growth of their spread, against the same gel without dynamics (pixels, at the
    /// 640-pixel scale); and the profiles (position behind the dot in mm, events) with and without.
    pub dot_lag_px: BTreeMap<String, f64>,
    pub dot_smear_px: BTreeMap<String, f64>,
    pub dot_profiles: BTreeMap<String, DotProfile>,
    /// A dot pressed 1 mm and released at the approach speed: the force loop's energy loss and the
    /// surface's largest lag behind the released indenter.
    pub press_release: PressRelease,
    /// Events per pass of one dot (noise off) over [`SENSOR_BUILDS`] builds of the sensor.
    pub events_per_pass_by_sensor: Vec<f64>,
    pub sensor_spread_cv: f64,
    /// Stick-slip of this preset's gel on the board's face through `harsh`'s light mount
    /// ([`StickSlip::LIGHT_MOUNT`]), mechanics only, per depth and speed.
    pub stick_slip: Vec<StickSlipRow>,
}

/// The camera's motion against the arm's over 100 mm of a slide with stick-slip.
#[derive(Debug, Clone, Serialize)]
pub struct StickSlipRow {
    pub depth_mm: f64,
    pub speed_mm_s: f64,
    /// Normal force of the board's face (0 where it does not touch the gel).
    pub face_force_n: f64,
    pub slips_per_100mm: f64,
    pub largest_jump_mm: f64,
    /// The camera's lag behind the arm at mid-slide, and the kinetic friction over the mount's
    /// stiffness (what steady sliding gives).
    pub lag_mm: f64,
    pub steady_lag_mm: f64,
}

/// Depths and speeds of the stick-slip check.
pub const STICK_SLIP_DEPTHS_MM: [f64; 3] = [0.3, 1.0, 1.5];
pub const STICK_SLIP_SPEEDS_MM_S: [f64; 4] = [8.0, 16.0, 32.0, 64.0];

/// The stick-slip check's rows for `sensor`'s gel on boards of `geometry`.
pub fn stick_slip(geometry: &BoardGeometry, sensor: &Sensor) -> Result<Vec<StickSlipRow>> {
    let contact = Contact::of(sensor);
    let p = StickSlip::LIGHT_MOUNT;
    let mut rows = Vec::new();
    for depth_mm in STICK_SLIP_DEPTHS_MM {
        let face = depth_mm - geometry.dot_height_mm;
        for v in STICK_SLIP_SPEEDS_MM_S {
            let (_, out) = crate::mount::trace(&p, &contact, 100.0, v, |t| (v * t, v), |_| face)?;
            let face_force_n = if contact.friction > 0.0 { contact.face_force_n(face) } else { 0.0 };
            rows.push(StickSlipRow {
                depth_mm,
                speed_mm_s: v,
                face_force_n,
                slips_per_100mm: out.slips as f64,
                largest_jump_mm: out.largest_jump_mm,
                lag_mm: out.lag_mid_mm,
                steady_lag_mm: contact.friction * face_force_n / p.mount_stiffness_n_per_m * 1e3,
            });
        }
    }
    Ok(rows)
}

/// Events of one pass of a dot binned by the pixel's position behind the dot, in mm (positive:
/// where the dot has been), with the gel's dynamics and without.
#[derive(Debug, Clone, Default, Serialize)]
pub struct DotProfile {
    pub position_mm: Vec<f64>,
    pub events: Vec<usize>,
    pub events_without_dynamics: Vec<usize>,
}

/// A press and release of one dot into the gel, at constant speed.
#[derive(Debug, Clone, Default, Serialize)]
pub struct PressRelease {
    pub depth_mm: f64,
    pub speed_mm_s: f64,
    /// (imposed depth mm, force N) while pressing and while releasing.
    pub loading: Vec<(f64, f64)>,
    pub unloading: Vec<(f64, f64)>,
    /// (imposed depth mm, surface depth mm) while releasing: the surface lags the indenter.
    pub surface_unloading: Vec<(f64, f64)>,
    /// Work lost over the work done pressing.
    pub energy_loss: f64,
    pub max_surface_lag_mm: f64,
}

/// Presses a dot of radius `radius_mm` into the gel to `depth_mm` and releases it at `speed_mm_s`
/// (Lee-Radok: Hertz with the Prony relaxation modulus; once the force would pull, the gel lets
/// go). The surface follows the indenter while pressing and lags it on release as in the stamps.
pub fn press_release(dynamics: &GelDynamics, radius_mm: f64, depth_mm: f64, speed_mm_s: f64) -> PressRelease {
    let steps = 400;
    let ramp_s = depth_mm / speed_mm_s;
    let dt = ramp_s / steps as f64;
    let g = dynamics.relaxing_fraction();
    // The quasi-static modulus (FEATS's fit) is the relaxed one: scale so that E(inf) matches.
    let k_relaxed = dynamics.hertz_force_n(radius_mm, 1.0);
    let k0 = k_relaxed / (1.0 - g);
    let mut arms = vec![0.0f64; dynamics.relaxation.len()];
    let mut lagged = vec![0.0f64; dynamics.relaxation.len()];
    let (mut psi_prev, mut d_prev) = (0.0f64, 0.0f64);
    let mut out = PressRelease { depth_mm, speed_mm_s, ..PressRelease::default() };
    let (mut work_in, mut work_out) = (0.0, 0.0);
    let mut f_prev = 0.0;
    for i in 1..=2 * steps {
        let d = if i <= steps {
            depth_mm * i as f64 / steps as f64
        } else {
            depth_mm * (2 * steps - i) as f64 / steps as f64
        };
        let psi = d.powf(1.5);
        let mut force = k0 * (1.0 - g) * psi;
        for (k, t) in dynamics.relaxation.iter().enumerate() {
            let e = (-dt / t.tau_s).exp();
            arms[k] = arms[k] * e + (psi - psi_prev) * (1.0 - e) * t.tau_s / dt;
            force += k0 * t.fraction * arms[k];
            lagged[k] = lagged[k] * e + (1.0 - e) * d;
        }
        let force = force.max(0.0);
        let surface =
            d.max((1.0 - g) * d + dynamics.relaxation.iter().zip(&lagged).map(|(t, l)| t.fraction * l).sum::<f64>());
        let work = 0.5 * (force + f_prev) * (d - d_prev);
        // Every tenth step is kept for the curves; the work and lag use them all.
        let keep = i % 10 == 0;
        if i <= steps {
            work_in += work;
            if keep {
                out.loading.push((d, force));
            }
        } else {
            work_out -= work;
            if keep {
                out.unloading.push((d, force));
                out.surface_unloading.push((d, surface));
            }
            out.max_surface_lag_mm = out.max_surface_lag_mm.max(surface - d);
        }
        psi_prev = psi;
        d_prev = d;
        f_prev = force;
    }
    out.energy_loss = if work_in > 0.0 { 1.0 - work_out / work_in } else { 0.0 };
    out
}

/// One pass of a dot at `speed_mm_s`, its events binned by position behind the dot.
fn dot_profile(board: &Board, sensor: &Sensor, speed_mm_s: f64, bin_mm: f64) -> Result<(Vec<f64>, Vec<usize>)> {
    let scan = simulate(board, sensor, &steady(1.0, speed_mm_s, 1))?;
    let tr = &scan.truth;
    let tl = tr.timeline;
    let pitch = tr.pitch_mm;
    let w = tr.resolution.width as f64;
    let dot_x = board.dots[0].x_mm;
    let (start, end) = ((tl.slide_start_s * 1e6) as i64, (tl.slide_end_s * 1e6) as i64);
    // From 2 mm ahead of the dot to 3 mm behind it.
    let (ahead, behind_max) = (2.0, 3.0);
    let bins = ((ahead + behind_max) / bin_mm).round() as usize;
    let mut counts = vec![0usize; bins];
    for e in scan.events.iter().filter(|e| e.t_us > start && e.t_us < end) {
        // Forward scan, steady: the sensor's centre is at start_mm + v t; the pixel sees board x.
        let centre = tr.scan.start_mm + speed_mm_s * (e.t_us as f64 / 1e6 - tl.slide_start_s);
        let x = centre + (e.x as f64 + 0.5 - w / 2.0) * pitch;
        let behind = x - dot_x;
        let b = ((behind + ahead) / bin_mm).floor();
        if b >= 0.0 && (b as usize) < bins {
            counts[b as usize] += 1;
        }
    }
    let positions = (0..bins).map(|i| -ahead + (i as f64 + 0.5) * bin_mm).collect();
    Ok((positions, counts))
}

/// Mean and standard deviation of a binned profile.
fn moments(position: &[f64], counts: &[usize]) -> (f64, f64) {
    let n: f64 = counts.iter().map(|&c| c as f64).sum();
    if n == 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = position.iter().zip(counts).map(|(p, &c)| p * c as f64).sum::<f64>() / n;
    let var = position.iter().zip(counts).map(|(p, &c)| (p - mean).powi(2) * c as f64).sum::<f64>() / n;
    (mean, var.sqrt())
}

fn quiet_sensor(setup: &Setup, seed: u64) -> Result<Sensor> {
    Ok(noisy_sensor(setup, seed)?.without_noise())
}

fn noisy_sensor(setup: &Setup, seed: u64) -> Result<Sensor> {
    Sensor::instance(&setup.camera, &setup.gel, &setup.variation, seed)
}

fn single_on(geometry: &BoardGeometry, text: &str, seed: u64) -> Result<Board> {
    Board::new(BoardKind::Text(text.into()), geometry.clone(), seed)
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
    let setup = Setup { gel: gel.clone(), ..Realism::Clean.setup() };
    depth_at(&setup, trials)
}

/// [`depth`] on a preset's gel, camera and board.
pub fn depth_at(setup: &Setup, trials: u64) -> Result<(BTreeMap<String, f64>, BTreeMap<String, f64>)> {
    let sensor = quiet_sensor(setup, 1)?;
    let mut per_dot = BTreeMap::new();
    for d in DEPTHS_MM {
        let mut n = 0.0;
        for t in 0..trials {
            n += simulate(&single_on(&setup.geometry, "A", 100 + t)?, &sensor, &steady(d, 8.0, t))?.events.len() as f64;
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

/// The lag between a cell's two dot columns in `scan`, measured against `one`, a scan of a single
/// dot in the first column's place with the same sensor and motion: the events in a band of
/// columns at the sensor's centre, binned per polarity (0.2 ms), are cross-correlated with the
/// single dot's; the correlation peaks where each column lines up with the template, and the lag
/// is the distance from the first peak to the highest one beyond the template's own duration.
/// Comparing like with like keeps the gel's smear and a dot's edge asymmetry out of the lag.
pub fn column_lag_ms(scan: &Scan, one: &Scan, band_px: u16) -> Option<f64> {
    let w = scan.truth.resolution.width;
    let (a, b) = (w / 2 - band_px / 2, w / 2 + band_px / 2);
    let bin_us = 200;
    let in_band = |s: &Scan| -> Vec<Event> { s.events.iter().filter(|e| e.x >= a && e.x < b).copied().collect() };
    let (cell, dot) = (in_band(scan), in_band(one));
    if cell.len() < 4 || dot.len() < 4 {
        return None;
    }
    let t0 = cell.iter().chain(&dot).map(|e| e.t_us).min()?;
    let t1 = cell.iter().chain(&dot).map(|e| e.t_us).max()?;
    let n = ((t1 - t0) / bin_us + 1) as usize;
    let histogram = |events: &[Event], polarity: Polarity| {
        let mut h = vec![0.0f64; n];
        for e in events.iter().filter(|e| e.polarity == polarity) {
            h[((e.t_us - t0) / bin_us) as usize] += 1.0;
        }
        h
    };
    let polarities = [Polarity::On, Polarity::Off];
    let cells: Vec<Vec<f64>> = polarities.iter().map(|&p| histogram(&cell, p)).collect();
    let dots: Vec<Vec<f64>> = polarities.iter().map(|&p| histogram(&dot, p)).collect();
    // Correlation at shift k (the template moved later by k bins).
    let correlation = |k: usize| -> f64 {
        cells.iter().zip(&dots).map(|(c, d)| d[..n - k].iter().zip(&c[k..]).map(|(x, y)| x * y).sum::<f64>()).sum()
    };
    let c: Vec<f64> = (0..n).map(correlation).collect();
    // The template's duration: where 5% to 95% of its events lie.
    let mut times: Vec<i64> = dot.iter().map(|e| e.t_us).collect();
    times.sort_unstable();
    let width = ((times[times.len() * 95 / 100] - times[times.len() * 5 / 100]) / bin_us) as usize;
    let first = (0..n).max_by(|&x, &y| c[x].total_cmp(&c[y]))?;
    let second = (0..n).filter(|&k| k.abs_diff(first) > width / 2).max_by(|&x, &y| c[x].total_cmp(&c[y]))?;
    let (k1, k2) = (first.min(second), first.max(second));
    Some((k2 - k1) as f64 * bin_us as f64 / 1000.0)
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

impl CheckReport {
    /// Each check outside its bounds, as a sentence; empty when all pass.
    pub fn failures(&self) -> Vec<String> {
        let r = self;
        let mut f = Vec::new();
        let mut need = |ok: bool, what: String| {
            if !ok {
                f.push(what);
            }
        };
        for (d, target) in PAPER_DEPTH_GAIN {
            let g = r.depth_gain[&format!("{d:.1}")];
            need((g - target).abs() <= 0.10, format!("1. depth {d} mm: gain {g:.3}, paper {target} +-0.10"));
        }
        let n: Vec<f64> = r.events_per_dot.values().copied().collect();
        need(
            n.windows(2).all(|w| w[1] > w[0]),
            format!("1. events per dot must grow with depth: {:?}", r.events_per_dot),
        );
        need(
            r.speed_spread <= 0.15,
            format!("2. events per pass vary by {:.3} across speeds (at most 0.15)", r.speed_spread),
        );
        for (k, lag) in &r.column_lag_ms {
            let e = r.expected_column_lag_ms[k];
            need((lag / e - 1.0).abs() < 0.05, format!("2. column lag at {k} mm/s: {lag:.1} ms, expected {e:.1} +-5%"));
        }
        let rates: Vec<f64> = SPEEDS_MM_S.iter().map(|v| r.event_rate_hz[&format!("{v:.0}")]).collect();
        need(rates.windows(2).all(|w| w[1] > w[0]), format!("2. event rate must grow with speed: {rates:?}"));
        need((0.9..=1.2).contains(&r.on_off_ratio), format!("3. ON/OFF ratio {:.3} outside 0.9-1.2", r.on_off_ratio));
        for dir in ["forward", "reverse"] {
            need(
                r.leading_polarity[dir] != r.trailing_polarity[dir],
                format!("3. {dir}: leading and trailing edges agree"),
            );
        }
        need(
            r.leading_polarity["forward"] == r.leading_polarity["reverse"],
            "3. reversing must swap each edge's polarity".into(),
        );
        for (d, w) in &r.blob_width_px {
            let range = if d == "0.2" { 22.0..=32.0 } else { 34.0..=55.0 };
            need(range.contains(w), format!("4. blob width at {d} mm: {w} px, expected {range:?}"));
        }
        need(
            r.patterns_recovered == 26,
            format!("4. patterns read back {}/26 (failed {:?})", r.patterns_recovered, r.patterns_failed),
        );
        need(
            (r.noise_rate_hz / r.expected_noise_rate_hz - 1.0).abs() < 0.03,
            format!(
                "5. noise floor {:.0} Hz against {:.0} Hz configured (+-3%)",
                r.noise_rate_hz, r.expected_noise_rate_hz
            ),
        );
        need(
            r.static_settle_ms <= 6.0,
            format!("6. events {:.1} ms after the motion stops (at most 6)", r.static_settle_ms),
        );
        need(r.min_pixel_gap_us >= 500, format!("7. two events of one pixel {} us apart", r.min_pixel_gap_us));
        need(r.on_readout_grid, "7. timestamps off the readout grid".into());
        need(r.deterministic, "8. the same seed gave another stream".into());
        // The gel's checks hold nominal to the assumed ranges; harsh lies at their edge by design.
        let dynamic = r.realism != Realism::Clean;
        let nominal = r.realism == Realism::Nominal;
        for (k, lag) in &r.dot_lag_px {
            let smear = r.dot_smear_px[k];
            if dynamic {
                need(
                    lag.abs() <= 15.0,
                    format!("9. dot lag at {k} mm/s: {lag:.2} px (REALISM.md's order: at most 15)"),
                );
                need(smear > 0.0, format!("9. the gel's smear at {k} mm/s must widen a dot's events: {smear:.2} px"));
            } else {
                need(
                    *lag == 0.0 && smear == 0.0,
                    format!("9. a gel without dynamics must not lag: {lag} / {smear} px"),
                );
            }
        }
        let loss = r.press_release.energy_loss;
        if nominal {
            let (lo, hi) = HYSTERESIS_RANGE;
            need((lo..=hi).contains(&loss), format!("10. press-release energy loss {loss:.3} outside {lo}-{hi}"));
            let (lo, hi) = SENSOR_SPREAD_RANGE;
            let cv = r.sensor_spread_cv;
            need(
                (lo..=hi).contains(&cv),
                format!("11. events per pass vary by CV {cv:.4} across builds, outside {lo}-{hi}"),
            );
        } else if !dynamic {
            need(loss.abs() < 1e-9, format!("10. a gel without relaxation must not lose energy: {loss}"));
        }
        for d in STICK_SLIP_DEPTHS_MM {
            let rows: Vec<&StickSlipRow> = r.stick_slip.iter().filter(|s| s.depth_mm == d).collect();
            let (Some(slow), Some(fast)) = (rows.first(), rows.last()) else { continue };
            if slow.face_force_n == 0.0 {
                need(
                    rows.iter().all(|s| s.slips_per_100mm == 0.0 && s.lag_mm.abs() < 1e-3),
                    format!("12. no face contact at {d} mm: no stick-slip and no lag"),
                );
            } else {
                need(
                    fast.slips_per_100mm <= slow.slips_per_100mm,
                    format!(
                        "12. stick-slip at {d} mm must fade with speed: {} slips per 100 mm at {} mm/s, {} at {}",
                        fast.slips_per_100mm, fast.speed_mm_s, slow.slips_per_100mm, slow.speed_mm_s
                    ),
                );
                need(
                    fast.slips_per_100mm > 1.0 || (fast.lag_mm / fast.steady_lag_mm - 1.0).abs() < 0.05,
                    format!(
                        "12. steady sliding at {d} mm, {} mm/s must lag by the kinetic friction: {:.3} mm, {:.3} expected",
                        fast.speed_mm_s, fast.lag_mm, fast.steady_lag_mm
                    ),
                );
            }
        }
        f
    }

    /// The checks as a Markdown table beside what each should give.
    pub fn markdown(&self) -> String {
        use std::fmt::Write as _;
        let r = self;
        let mut m = String::new();
        let _ =
            writeln!(m, "Simulator physics checks at `{}` realism (simulated scans; see SIMULATOR.md):\n", r.realism);
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
        for v in SPEEDS_MM_S {
            let key = format!("{v:.0}");
            let _ = writeln!(
                m,
                "| 9. one dot at {key} mm/s: lag / smear of its events against the gel without dynamics | {:+.2} / {:+.2} px | lag within 15 px (REALISM.md: 1-3 px viscous, 2-9 px drag) |",
                r.dot_lag_px[&key], r.dot_smear_px[&key]
            );
        }
        let p = &r.press_release;
        let _ = writeln!(
            m,
            "| 10. press to {} mm and release at {} mm/s: energy lost / surface lag | {:.1}% / {:.3} mm | {:.0}-{:.0}% (assumed for silicone) |",
            p.depth_mm,
            p.speed_mm_s,
            p.energy_loss * 100.0,
            p.max_surface_lag_mm,
            HYSTERESIS_RANGE.0 * 100.0,
            HYSTERESIS_RANGE.1 * 100.0
        );
        let _ = writeln!(
            m,
            "| 11. events per pass across {} sensor builds (CV) | {:.2}% | {:.1}-{:.0}% |",
            r.events_per_pass_by_sensor.len(),
            r.sensor_spread_cv * 100.0,
            SENSOR_SPREAD_RANGE.0 * 100.0,
            SENSOR_SPREAD_RANGE.1 * 100.0
        );
        for s in &r.stick_slip {
            let _ = writeln!(
                m,
                "| 12. stick-slip, light mount, {} mm at {} mm/s: face force / slips per 100 mm / largest jump / lag | {:.1} N / {} / {:.3} mm / {:.3} mm | none without face contact; fades with speed; steady lag {:.3} mm |",
                s.depth_mm,
                s.speed_mm_s,
                s.face_force_n,
                s.slips_per_100mm,
                s.largest_jump_mm,
                s.lag_mm,
                s.steady_lag_mm
            );
        }
        let failures = r.failures();
        if failures.is_empty() {
            let _ = writeln!(m, "\nAll checks are within their bounds.");
        } else {
            let _ = writeln!(m, "\nOutside their bounds:\n");
            for f in failures {
                let _ = writeln!(m, "- {f}");
            }
        }
        m
    }
}

/// Runs every check at a realism preset. `trials` repeats the depth measurement over boards and
/// seeds.
pub fn run(realism: Realism, trials: u64) -> Result<CheckReport> {
    let setup = realism.setup();
    let geometry = &setup.geometry;
    let single = |text: &str, seed: u64| single_on(geometry, text, seed);
    let (depth_gain, events_per_dot) = depth_at(&setup, trials)?;
    let quiet = quiet_sensor(&setup, 1)?;

    // Speed: one dot, events per pass; rate during the slide; lag between the columns of "C".
    let mut events_per_pass = BTreeMap::new();
    let mut event_rate_hz = BTreeMap::new();
    let mut column_lag = BTreeMap::new();
    let mut expected_lag = BTreeMap::new();
    let dot = single("A", 3)?;
    // The lag is measured on a board printed without tolerances, so that it tests the motion and
    // the measurement, not one board's dots.
    let exact =
        BoardGeometry { position_sigma_mm: 0.0, height_sigma_mm: 0.0, base_radius_sigma_mm: 0.0, ..geometry.clone() };
    let c = Board::new(BoardKind::Text("C".into()), exact.clone(), 3)?;
    // "A" is C's first column alone.
    let c_first = Board::new(BoardKind::Text("A".into()), exact, 3)?;
    for v in SPEEDS_MM_S {
        let s = simulate(&dot, &quiet, &steady(1.0, v, 1))?;
        let key = format!("{v:.0}");
        let tl = s.truth.timeline;
        events_per_pass.insert(key.clone(), s.events.len() as f64);
        event_rate_hz.insert(key.clone(), s.events.len() as f64 / (tl.slide_end_s - tl.slide_start_s));
        let s = simulate(&c, &quiet, &steady(1.0, v, 1))?;
        let one = simulate(&c_first, &quiet, &steady(1.0, v, 1))?;
        column_lag.insert(key.clone(), column_lag_ms(&s, &one, 10).unwrap_or(f64::NAN));
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
        BoardGeometry { cell_spacing_mm: 10.0, ..geometry.clone() },
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
    let noisy = noisy_sensor(&setup, 1)?;
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

    // Readout on a noisy scan of a letter board, with the preset's kinematics.
    let readout_scan = setup.scan(32.0, 1.5, 0, 9);
    let s = simulate(&single("GH", 6)?, &noisy, &readout_scan)?;
    let (min_pixel_gap_us, on_readout_grid) = readout(&s, noisy.camera.readout_grid_us);
    let again = simulate(&single("GH", 6)?, &noisy, &readout_scan)?;

    // The gel: one dot's events against where the dot is, with and without the gel's dynamics.
    let still = Sensor::new(
        quiet.camera.clone(),
        GelConfig {
            dynamics: GelDynamics { relaxation: Vec::new(), friction: 0.0, ..quiet.gel.dynamics.clone() },
            ..quiet.gel.clone()
        },
        quiet.seed,
    )?;
    let lone =
        Board::new(BoardKind::Text("A".into()), BoardGeometry { position_sigma_mm: 0.0, ..geometry.clone() }, 3)?;
    let scale = 640.0 / quiet.camera.resolution.width as f64 / quiet.camera.pitch_mm();
    let (mut dot_lag_px, mut dot_smear_px, mut dot_profiles) = (BTreeMap::new(), BTreeMap::new(), BTreeMap::new());
    for v in SPEEDS_MM_S {
        let (position_mm, events) = dot_profile(&lone, &quiet, v, 0.1)?;
        let (_, events_without_dynamics) = dot_profile(&lone, &still, v, 0.1)?;
        let (m1, s1) = moments(&position_mm, &events);
        let (m0, s0) = moments(&position_mm, &events_without_dynamics);
        let key = format!("{v:.0}");
        dot_lag_px.insert(key.clone(), (m1 - m0) * scale);
        dot_smear_px.insert(key.clone(), (s1 - s0) * scale);
        dot_profiles.insert(key, DotProfile { position_mm, events, events_without_dynamics });
    }
    let radius = lone.dots[0].radius_mm;
    let press_release = press_release(&quiet.gel.dynamics, radius, 1.0, setup.scan.approach_speed_mm_s);

    // Builds of the sensor: events per pass of one dot (the noise has its own check).
    let mut events_per_pass_by_sensor = Vec::new();
    for seed in 1..=SENSOR_BUILDS {
        let sensor = quiet_sensor(&setup, 1000 + seed)?;
        events_per_pass_by_sensor.push(simulate(&lone, &sensor, &steady(1.0, 16.0, 1))?.events.len() as f64);
    }
    let n = events_per_pass_by_sensor.len() as f64;
    let mean = events_per_pass_by_sensor.iter().sum::<f64>() / n;
    let sd = (events_per_pass_by_sensor.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();

    Ok(CheckReport {
        realism,
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
        dot_lag_px,
        dot_smear_px,
        dot_profiles,
        press_release,
        events_per_pass_by_sensor,
        sensor_spread_cv: sd / mean,
        stick_slip: stick_slip(geometry, &quiet)?,
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
