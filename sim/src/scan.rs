//! The scan protocol and event generation: lower the sensor onto a row to a depth, slide along
//! it, hold, lift; every pixel turns the brightness it sees into events.
//!
//! The board moves rigidly under the sensor, so each pixel row sees one brightness profile along
//! the board, and each of its pixels traverses that profile shifted by its position. The profile
//! is built once per pixel row from the dots' stamps and filtered by the photoreceptor (in the
//! coordinate of travel, at the nominal speed); each pixel then finds the crossings of its own
//! thresholds along it, whose positions convert to times through the (rippled) motion. Crossing
//! times are exact for the piecewise-linear profile, quantised to the readout grid, with the
//! refractory period applied per pixel. Noise (leak, shot, hot pixels) is added on top.

use crate::board::Board;
use crate::error::{Error, Result};
use crate::sensor::Sensor;
use crate::stamp::Stamp;
use encoders::{Event, Polarity, Resolution};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, Poisson};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Which way the sensor slides along the row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Towards increasing board x (reading direction).
    Forward,
    Reverse,
}

impl Direction {
    fn sign(self) -> f64 {
        match self {
            Direction::Forward => 1.0,
            Direction::Reverse => -1.0,
        }
    }
}

/// One scan of one row. Assumed values (no public source) are marked so.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScanConfig {
    pub speed_mm_s: f64,
    /// Indentation from first contact with the dot tops.
    pub depth_mm: f64,
    pub row: usize,
    pub direction: Direction,
    /// Where the sensor's centre starts along the row (forward) or ends (reverse).
    pub start_mm: f64,
    /// Slide length; `None` for the board's row length (195 mm).
    pub slide_mm: Option<f64>,
    /// Vertical speed when lowering and lifting (assumed).
    pub approach_speed_mm_s: f64,
    /// Pause at depth before and after the slide (assumed).
    pub hold_s: f64,
    /// Relative amplitude and frequency of the speed ripple of the arm (assumed).
    pub speed_ripple: f64,
    pub ripple_hz: f64,
    /// Standard deviation of the lateral offset between sensor and row, per trial (assumed).
    pub misalignment_sigma_mm: f64,
    /// Seed of this trial: misalignment, ripple phase, noise.
    pub seed: u64,
}

impl Default for ScanConfig {
    fn default() -> Self {
        Self {
            speed_mm_s: 8.0,
            depth_mm: 1.5,
            row: 0,
            direction: Direction::Forward,
            start_mm: 0.0,
            slide_mm: None,
            approach_speed_mm_s: 5.0,
            hold_s: 0.1,
            speed_ripple: 0.02,
            ripple_hz: 2.0,
            misalignment_sigma_mm: 0.15,
            seed: 0,
        }
    }
}

/// When each phase of a scan starts and ends, in seconds from first contact.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    pub lowered_s: f64,
    pub slide_start_s: f64,
    pub slide_end_s: f64,
    pub lift_start_s: f64,
    pub end_s: f64,
}

/// When a dot column of a character passes the sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ColumnTruth {
    /// 0 = left column (dots 1-3), 1 = right column (dots 4-6).
    pub column: u8,
    pub x_mm: f64,
    /// The column is under the sensor's centre.
    pub t_center_s: Option<f64>,
    /// The column enters and leaves the field of view.
    pub t_enter_s: Option<f64>,
    pub t_exit_s: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CharacterTruth {
    pub letter: char,
    pub row: usize,
    pub word: Option<usize>,
    /// Position in the row.
    pub index: usize,
    /// The cell's left column on the board.
    pub x_mm: f64,
    pub y_mm: f64,
    /// Raised dots as (column, row).
    pub dots: Vec<(u8, u8)>,
    /// The cell's centre is under the sensor's centre.
    pub t_cell_center_s: Option<f64>,
    pub columns: Vec<ColumnTruth>,
}

/// Everything known about a scan: its parameters and where each character is when.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScanTruth {
    pub board: String,
    pub board_seed: u64,
    pub sensor_seed: u64,
    pub row_text: String,
    pub scan: ScanConfig,
    pub misalignment_mm: f64,
    pub ripple_phase_rad: f64,
    pub timeline: Timeline,
    pub resolution: Resolution,
    pub pitch_mm: f64,
    pub fov_width_mm: f64,
    pub characters: Vec<CharacterTruth>,
}

/// A simulated scan: events in time order and the ground truth.
#[derive(Debug, Clone)]
pub struct Scan {
    pub events: Vec<Event>,
    pub truth: ScanTruth,
}

/// The slide's displacement over time with a sinusoidal speed ripple.
#[derive(Debug, Clone, Copy)]
struct Motion {
    v: f64,
    a: f64,
    w: f64,
    phase: f64,
}

impl Motion {
    fn displacement(&self, t: f64) -> f64 {
        if self.a == 0.0 || self.w == 0.0 {
            return self.v * t;
        }
        self.v * t + self.a * self.v / self.w * (self.phase.cos() - (self.w * t + self.phase).cos())
    }

    fn speed(&self, t: f64) -> f64 {
        self.v * (1.0 + self.a * (self.w * t + self.phase).sin())
    }

    /// The time at which the displacement reaches `s` (Newton's method; the motion is monotone).
    fn time_of(&self, s: f64) -> f64 {
        let mut t = s / self.v;
        for _ in 0..4 {
            t -= (self.displacement(t) - s) / self.speed(t);
        }
        t
    }
}

/// The inverse of the motion, tabulated: time as a function of displacement, linear between
/// entries `ds` apart (the ripple is slow against `ds / v`, so the error is far below 1 us).
struct TimeTable {
    ds: f64,
    t: Vec<f64>,
}

impl TimeTable {
    fn new(motion: &Motion, length: f64, ds: f64) -> TimeTable {
        let n = (length / ds).ceil() as usize + 2;
        TimeTable { ds, t: (0..n).map(|i| motion.time_of(i as f64 * ds)).collect() }
    }

    #[inline]
    fn time_of(&self, s: f64) -> f64 {
        let f = (s / self.ds).max(0.0);
        let i = (f as usize).min(self.t.len() - 2);
        let r = f - i as f64;
        self.t[i] + (self.t[i + 1] - self.t[i]) * r
    }
}

/// A stretch of one pixel row's profile where dots make contrast, in travel coordinates.
struct Span {
    /// Travel coordinate of sample 0; samples are `step` apart.
    p0: f64,
    raw: Vec<f32>,
    /// Filtered profile per photoreceptor level.
    filtered: Vec<Vec<f32>>,
    /// Monotone runs per level: (first sample, last sample).
    runs: Vec<Vec<(u32, u32)>>,
}

/// Number of photoreceptor speed levels the pixels are grouped into.
const LEVELS: usize = 4;

fn validate(scan: &ScanConfig, board: &Board) -> Result<f64> {
    let slide = scan.slide_mm.unwrap_or(board.geometry.row_length_mm);
    let ok = scan.speed_mm_s > 0.0
        && scan.depth_mm >= 0.0
        && scan.approach_speed_mm_s > 0.0
        && scan.hold_s >= 0.0
        && (0.0..0.5).contains(&scan.speed_ripple)
        && scan.ripple_hz >= 0.0
        && scan.misalignment_sigma_mm >= 0.0
        && slide > 0.0;
    if !ok {
        return Err(Error::Config(format!("scan parameters out of range: {scan:?}")));
    }
    if scan.row >= board.rows.len() {
        return Err(Error::Config(format!("row {} does not exist: the board has {} rows", scan.row, board.rows.len())));
    }
    Ok(slide)
}

/// Simulates one scan of `board` by `sensor`.
pub fn simulate(board: &Board, sensor: &Sensor, scan: &ScanConfig) -> Result<Scan> {
    let slide = validate(scan, board)?;
    let cam = &sensor.camera;
    let (w, h) = (cam.resolution.width as usize, cam.resolution.height as usize);
    let pitch = cam.pitch_mm();
    let step = pitch / 2.0;
    let dir = scan.direction.sign();
    let mut rng = ChaCha8Rng::seed_from_u64(scan.seed);
    let misalignment =
        Normal::new(0.0, scan.misalignment_sigma_mm).map_err(|e| Error::Config(e.to_string()))?.sample(&mut rng);
    let phase = rng.random_range(0.0..std::f64::consts::TAU);
    let motion = Motion { v: scan.speed_mm_s, a: scan.speed_ripple, w: std::f64::consts::TAU * scan.ripple_hz, phase };
    let lower_s = scan.depth_mm / scan.approach_speed_mm_s;
    let slide_s = motion.time_of(slide);
    let table = TimeTable::new(&motion, slide, pitch / 2.0);
    let timeline = Timeline {
        lowered_s: lower_s,
        slide_start_s: lower_s + scan.hold_s,
        slide_end_s: lower_s + scan.hold_s + slide_s,
        lift_start_s: lower_s + 2.0 * scan.hold_s + slide_s,
        end_s: 2.0 * lower_s + 2.0 * scan.hold_s + slide_s,
    };
    // Sensor centre at the start of the slide, in board x; travel coordinate p = dir * x.
    let x_start = if dir > 0.0 { scan.start_mm } else { scan.start_mm + slide };
    let row_y = board.row_y_mm(scan.row) + misalignment;

    // Stamps, shared by dots of (nearly) the same height.
    let g = &board.geometry;
    let optics_scale = w as f64 / 640.0;
    let mut stamps: HashMap<(i64, i64), Stamp> = HashMap::new();
    let mut dot_stamp = Vec::with_capacity(board.dots.len());
    for d in &board.dots {
        let penetration = scan.depth_mm + (d.height_mm - g.dot_height_mm);
        let key = ((penetration / 0.01).round() as i64, (d.height_mm / 0.01).round() as i64);
        stamps.entry(key).or_insert_with(|| {
            let (pen, hd) = (key.0 as f64 * 0.01, key.1 as f64 * 0.01);
            Stamp::new(&sensor.gel, g.dot_radius_mm.max(hd), hd, pen.max(0.0), pitch, optics_scale)
        });
        dot_stamp.push(key);
    }
    let max_half = stamps.values().map(|s| s.half).max().unwrap_or(0) as f64;

    // Photoreceptor levels.
    let (tau_min, tau_max) = sensor.tau_s.iter().fold((f32::MAX, 0f32), |(a, b), &t| (a.min(t), b.max(t)));
    let level_of = |tau: f32| -> usize {
        if tau_max <= tau_min {
            0
        } else {
            (((tau - tau_min) / (tau_max - tau_min) * LEVELS as f32) as usize).min(LEVELS - 1)
        }
    };
    let level_tau: Vec<f64> =
        (0..LEVELS).map(|l| (tau_min + (tau_max - tau_min) * (l as f32 + 0.5) / LEVELS as f32) as f64).collect();
    let tau_x: Vec<f64> = level_tau.iter().map(|t| t * scan.speed_mm_s).collect();
    let pad = ((6.0 * tau_x.iter().cloned().fold(0.0, f64::max)) / step).ceil() as usize + 2;

    let grid = cam.readout_grid_us;
    let refractory = cam.refractory_us;
    let mut events: Vec<Event> = Vec::new();
    let mut dots_by_y: Vec<usize> = (0..board.dots.len()).collect();
    dots_by_y.sort_by(|&a, &b| board.dots[a].y_mm.total_cmp(&board.dots[b].y_mm));

    for py in 0..h {
        let y = row_y + (py as f64 + 0.5 - h as f64 / 2.0) * pitch;
        // Dots whose stamp reaches this pixel row, in travel order.
        let reach = (max_half + 1.0) * pitch;
        let lo = dots_by_y.partition_point(|&i| board.dots[i].y_mm < y - reach);
        let hi = dots_by_y.partition_point(|&i| board.dots[i].y_mm <= y + reach);
        if lo == hi {
            continue;
        }
        let mut near: Vec<usize> = dots_by_y[lo..hi].to_vec();
        near.sort_by(|&a, &b| (dir * board.dots[a].x_mm).total_cmp(&(dir * board.dots[b].x_mm)));
        let spans = build_spans(board, &near, &dot_stamp, &stamps, y, dir, pitch, step, pad, &tau_x);
        if spans.is_empty() {
            continue;
        }
        for px in 0..w {
            let i = py * w + px;
            let level = level_of(sensor.tau_s[i]);
            let pixel = Pixel {
                x: px as u16,
                y: py as u16,
                theta_on: sensor.threshold_on[i],
                theta_off: sensor.threshold_off[i],
                tau_s: level_tau[level],
            };
            // Travel coordinate of this pixel at the start of the slide.
            let c = dir * (x_start + (px as f64 + 0.5 - w as f64 / 2.0) * pitch);
            pixel_events(&pixel, &spans, level, c, slide, step, &table, &timeline, grid, refractory, &mut events);
        }
    }

    add_noise(sensor, &timeline, &mut rng, &mut events)?;
    let mut events = sort_by_time(events, grid);
    enforce_refractory(&mut events, w, h, refractory);

    let truth = truth(board, sensor, scan, misalignment, phase, timeline, &motion, x_start, slide);
    Ok(Scan { events, truth })
}

#[allow(clippy::too_many_arguments)]
fn build_spans(
    board: &Board,
    near: &[usize],
    dot_stamp: &[(i64, i64)],
    stamps: &HashMap<(i64, i64), Stamp>,
    y: f64,
    dir: f64,
    pitch: f64,
    step: f64,
    pad: usize,
    tau_x: &[f64],
) -> Vec<Span> {
    // Sample-index intervals of each dot in travel coordinates, merged into spans.
    let mut intervals: Vec<(i64, i64, usize)> = Vec::new();
    for &d in near {
        let dot = &board.dots[d];
        let stamp = &stamps[&dot_stamp[d]];
        let dy = (y - dot.y_mm) / pitch;
        if dy.abs() >= stamp.half as f64 {
            continue;
        }
        let p = dir * dot.x_mm;
        let r = stamp.half as f64 * pitch;
        intervals.push((((p - r) / step).floor() as i64 - 1, ((p + r) / step).ceil() as i64 + 1, d));
    }
    intervals.sort_by_key(|iv| iv.0);
    let mut groups: Vec<(i64, i64, Vec<usize>)> = Vec::new();
    for (a, b, d) in intervals {
        match groups.last_mut() {
            Some(g) if a <= g.1 + pad as i64 => {
                g.1 = g.1.max(b);
                g.2.push(d);
            }
            _ => groups.push((a, b, vec![d])),
        }
    }
    let mut spans = Vec::with_capacity(groups.len());
    for (a, b, dots) in groups {
        let n = (b - a) as usize + 1 + pad;
        let mut raw = vec![0f32; n];
        for d in dots {
            let dot = &board.dots[d];
            let stamp = &stamps[&dot_stamp[d]];
            let dy = (y - dot.y_mm) / pitch;
            let p = dir * dot.x_mm;
            for (j, v) in raw.iter_mut().enumerate() {
                let pj = (a + j as i64) as f64 * step;
                let dx = dir * (pj - p) / pitch;
                if dx.abs() < stamp.half as f64 {
                    *v += stamp.at(dx, dy);
                }
            }
        }
        if raw.iter().all(|&v| v == 0.0) {
            continue;
        }
        let filtered: Vec<Vec<f32>> = tau_x.iter().map(|&t| low_pass(&raw, step, t)).collect();
        let runs = filtered.iter().map(|f| monotone_runs(f)).collect();
        spans.push(Span { p0: a as f64 * step, raw, filtered, runs });
    }
    spans
}

/// First-order low-pass along the travel coordinate, exact for a piecewise-linear input.
fn low_pass(x: &[f32], step: f64, tau: f64) -> Vec<f32> {
    if tau <= 0.0 {
        return x.to_vec();
    }
    let e = (-step / tau).exp();
    let mut y = Vec::with_capacity(x.len());
    let mut prev_y = 0.0f64;
    let mut prev_x = 0.0f64;
    for &xi in x {
        let xi = xi as f64;
        let m = (xi - prev_x) / step;
        prev_y = xi - m * tau + (prev_y - prev_x + m * tau) * e;
        prev_x = xi;
        y.push(prev_y as f32);
    }
    y
}

fn monotone_runs(v: &[f32]) -> Vec<(u32, u32)> {
    let mut runs = Vec::new();
    let mut start = 0usize;
    let mut trend = 0i8;
    for j in 1..v.len() {
        let d = v[j] - v[j - 1];
        let s = if d > 0.0 {
            1
        } else if d < 0.0 {
            -1
        } else {
            0
        };
        if s != 0 && trend != 0 && s != trend {
            runs.push((start as u32, (j - 1) as u32));
            start = j - 1;
        }
        if s != 0 {
            trend = s;
        }
    }
    if v.len() > 1 {
        runs.push((start as u32, (v.len() - 1) as u32));
    }
    runs
}

struct Pixel {
    x: u16,
    y: u16,
    theta_on: f32,
    theta_off: f32,
    tau_s: f64,
}

/// A pixel's memory: its reference level and when it last fired.
struct PixelState {
    reference: f32,
    last_t_us: i64,
}

impl PixelState {
    /// Emits an event at `t_s` on the readout grid, respecting the refractory period.
    fn fire(&mut self, p: &Pixel, t_s: f64, polarity: Polarity, grid: i64, refractory: i64, out: &mut Vec<Event>) {
        let t_us = (t_s * 1e6).ceil() as i64;
        let mut t = t_us.div_euclid(grid) * grid + if t_us.rem_euclid(grid) == 0 { 0 } else { grid };
        if self.last_t_us != i64::MIN && t < self.last_t_us + refractory {
            let earliest = self.last_t_us + refractory;
            t = earliest.div_euclid(grid) * grid + if earliest.rem_euclid(grid) == 0 { 0 } else { grid };
        }
        self.last_t_us = t;
        out.push(Event { t_us: t, x: p.x, y: p.y, polarity });
    }

    /// Crossings of the signal going linearly from `a` to `b` over times `t0..t1`.
    #[allow(clippy::too_many_arguments)]
    fn ramp(
        &mut self,
        p: &Pixel,
        a: f32,
        b: f32,
        time: impl Fn(f64) -> f64,
        grid: i64,
        refractory: i64,
        out: &mut Vec<Event>,
    ) {
        if b > a {
            while b >= self.reference + p.theta_on {
                self.reference += p.theta_on;
                let f = ((self.reference - a) / (b - a)).clamp(0.0, 1.0) as f64;
                self.fire(p, time(f), Polarity::On, grid, refractory, out);
            }
        } else if b < a {
            while b <= self.reference - p.theta_off {
                self.reference -= p.theta_off;
                let f = ((a - self.reference) / (a - b)).clamp(0.0, 1.0) as f64;
                self.fire(p, time(f), Polarity::Off, grid, refractory, out);
            }
        }
    }
}

/// Value of a span's samples at travel coordinate `q` (0 outside).
fn value_at(span: &Span, samples: &[f32], q: f64, step: f64) -> f32 {
    let f = (q - span.p0) / step;
    if f < 0.0 || f >= (samples.len() - 1) as f64 {
        return 0.0;
    }
    let j = f as usize;
    let t = (f - j as f64) as f32;
    samples[j] * (1.0 - t) + samples[j + 1] * t
}

#[allow(clippy::too_many_arguments)]
fn pixel_events(
    p: &Pixel,
    spans: &[Span],
    level: usize,
    c: f64,
    slide: f64,
    step: f64,
    motion: &TimeTable,
    tl: &Timeline,
    grid: i64,
    refractory: i64,
    out: &mut Vec<Event>,
) {
    let (q0, q1) = (c, c + slide);
    let first = spans.partition_point(|s| s.p0 + (s.raw.len() as f64) * step < q0);
    let mut st = PixelState { reference: 0.0, last_t_us: i64::MIN };
    // Lowering: contrast appears where a dot is already under the pixel.
    let start_value = spans.get(first).map_or(0.0, |s| value_at(s, &s.raw, q0, step));
    if start_value != 0.0 {
        st.ramp(p, 0.0, start_value, |f| f * tl.lowered_s, grid, refractory, out);
    }
    let time_at = |q: f64| tl.slide_start_s + motion.time_of((q - c).clamp(0.0, slide));
    for span in &spans[first..] {
        if span.p0 > q1 {
            break;
        }
        let v = &span.filtered[level];
        for &(j0, j1) in &span.runs[level] {
            let (j0, j1) = (j0 as usize, j1 as usize);
            let (pa, pb) = (span.p0 + j0 as f64 * step, span.p0 + j1 as f64 * step);
            if pb < q0 || pa > q1 {
                continue;
            }
            let (va, vb) = (v[j0], v[j1]);
            // Within a monotone run only one polarity can fire; skip runs that cannot reach a level.
            let fully_inside = pa >= q0 && pb <= q1;
            if fully_inside
                && ((vb >= va && vb < st.reference + p.theta_on) || (vb < va && vb > st.reference - p.theta_off))
            {
                continue;
            }
            for j in j0..j1 {
                let (mut qa, mut qb) = (span.p0 + j as f64 * step, span.p0 + (j + 1) as f64 * step);
                let (mut a, mut b) = (v[j], v[j + 1]);
                if qb < q0 || qa > q1 {
                    continue;
                }
                if qa < q0 {
                    a = value_at(span, v, q0, step);
                    qa = q0;
                }
                if qb > q1 {
                    b = value_at(span, v, q1, step);
                    qb = q1;
                }
                st.ramp(p, a, b, |f| time_at(qa + f * (qb - qa)), grid, refractory, out);
            }
        }
    }
    // Hold: the photoreceptor settles on the brightness under the pixel; then lifting removes it.
    let end = spans[first..].iter().find(|s| s.p0 <= q1 && q1 < s.p0 + s.raw.len() as f64 * step);
    if let Some(span) = end {
        let (y0, x) = (value_at(span, &span.filtered[level], q1, step), value_at(span, &span.raw, q1, step));
        if (y0 - x).abs() > 1e-6 {
            // y(t) = x + (y0 - x) exp(-t / tau): the crossing of level L is at tau * ln((y0 - x) / (L - x)).
            let tau = p.tau_s;
            st.ramp(
                p,
                y0,
                x,
                |f| {
                    let level = y0 as f64 + f * (x - y0) as f64;
                    let r = ((y0 - x) as f64 / (level - x as f64)).max(1.0);
                    tl.slide_end_s + (tau * r.ln()).min(tl.lift_start_s - tl.slide_end_s)
                },
                grid,
                refractory,
                out,
            );
        }
        if x != 0.0 {
            st.ramp(p, x, 0.0, |f| tl.lift_start_s + f * (tl.end_s - tl.lift_start_s), grid, refractory, out);
        }
    }
}

/// Leak, shot and hot-pixel noise over the whole scan.
fn add_noise(sensor: &Sensor, tl: &Timeline, rng: &mut ChaCha8Rng, events: &mut Vec<Event>) -> Result<()> {
    let cam = &sensor.camera;
    let (w, h) = (cam.resolution.width, cam.resolution.height);
    let pixels = cam.resolution.pixels() as f64;
    let grid = cam.readout_grid_us;
    let on_grid = |t_s: f64| ((t_s * 1e6 / grid as f64).ceil() as i64) * grid;
    let poisson = |lambda: f64, rng: &mut ChaCha8Rng| -> Result<u64> {
        if lambda <= 0.0 {
            return Ok(0);
        }
        Ok(Poisson::new(lambda).map_err(|e| Error::Config(e.to_string()))?.sample(rng) as u64)
    };
    let duration = tl.end_s;
    let leak = poisson(pixels * cam.leak_hz_per_pixel * duration, rng)?;
    let shot = poisson(pixels * cam.shot_hz_per_pixel * duration, rng)?;
    for k in 0..leak + shot {
        let t = rng.random_range(0.0..duration.max(1e-9));
        let polarity = if k < leak || rng.random_bool(0.5) { Polarity::On } else { Polarity::Off };
        events.push(Event { t_us: on_grid(t), x: rng.random_range(0..w), y: rng.random_range(0..h), polarity });
    }
    for &(x, y) in &sensor.hot_pixels {
        let n = poisson(cam.hot_pixel_hz * duration, rng)?;
        for _ in 0..n {
            let t = rng.random_range(0.0..duration.max(1e-9));
            events.push(Event { t_us: on_grid(t), x, y, polarity: Polarity::On });
        }
    }
    Ok(())
}

/// Sorts events by (time, y, x, polarity). Times lie on the readout grid, so a counting sort over
/// grid slots does most of the work; each slot is then sorted on its own.
fn sort_by_time(events: Vec<Event>, grid: i64) -> Vec<Event> {
    let Some(max) = events.iter().map(|e| e.t_us).max() else { return events };
    let min = events.iter().map(|e| e.t_us).min().unwrap_or(0);
    let slots = ((max - min) / grid) as usize + 1;
    if slots > 4 * events.len() + 1024 {
        let mut events = events;
        events.sort_unstable_by_key(|e| (e.t_us, e.y, e.x, e.polarity));
        return events;
    }
    let slot = |e: &Event| ((e.t_us - min) / grid) as usize;
    let mut start = vec![0usize; slots + 1];
    for e in &events {
        start[slot(e) + 1] += 1;
    }
    for i in 0..slots {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut out = vec![Event { t_us: 0, x: 0, y: 0, polarity: Polarity::Off }; events.len()];
    for e in events {
        let k = slot(&e);
        out[next[k]] = e;
        next[k] += 1;
    }
    for i in 0..slots {
        out[start[i]..start[i + 1]].sort_unstable_by_key(|e| (e.t_us, e.y, e.x, e.polarity));
    }
    out
}

/// Drops any event closer than the refractory period to the previous event of its pixel (noise
/// landing next to signal); events must be in time order.
fn enforce_refractory(events: &mut Vec<Event>, w: usize, h: usize, refractory: i64) {
    let mut last = vec![i64::MIN; w * h];
    events.retain(|e| {
        let i = e.y as usize * w + e.x as usize;
        if last[i] != i64::MIN && e.t_us < last[i] + refractory {
            return false;
        }
        last[i] = e.t_us;
        true
    });
}

#[allow(clippy::too_many_arguments)]
fn truth(
    board: &Board,
    sensor: &Sensor,
    scan: &ScanConfig,
    misalignment: f64,
    phase: f64,
    timeline: Timeline,
    motion: &Motion,
    x_start: f64,
    slide: f64,
) -> ScanTruth {
    let dir = scan.direction.sign();
    let fov = sensor.camera.fov_width_mm;
    // Time at which the sensor's centre is at board x (None outside the slide).
    let at = |x: f64| {
        let s = dir * (x - x_start);
        (0.0..=slide).contains(&s).then(|| timeline.slide_start_s + motion.time_of(s))
    };
    let g = &board.geometry;
    let characters = board
        .characters
        .iter()
        .filter(|c| c.row == scan.row)
        .enumerate()
        .map(|(index, c)| {
            let mut cols: Vec<u8> = c.dots.iter().map(|d| d.0).collect();
            cols.sort();
            cols.dedup();
            CharacterTruth {
                letter: c.letter,
                row: c.row,
                word: c.word,
                index,
                x_mm: c.x_mm,
                y_mm: c.y_mm,
                dots: c.dots.clone(),
                t_cell_center_s: at(c.x_mm + g.dot_spacing_mm / 2.0),
                columns: cols
                    .into_iter()
                    .map(|col| {
                        let x = c.x_mm + col as f64 * g.dot_spacing_mm;
                        ColumnTruth {
                            column: col,
                            x_mm: x,
                            t_center_s: at(x),
                            t_enter_s: at(x - dir * fov / 2.0),
                            t_exit_s: at(x + dir * fov / 2.0),
                        }
                    })
                    .collect(),
            }
        })
        .collect();
    ScanTruth {
        board: board.kind.name(),
        board_seed: board.seed,
        sensor_seed: sensor.seed,
        row_text: board.rows[scan.row].clone(),
        scan: scan.clone(),
        misalignment_mm: misalignment,
        ripple_phase_rad: phase,
        timeline,
        resolution: sensor.camera.resolution,
        pitch_mm: sensor.camera.pitch_mm(),
        fov_width_mm: fov,
        characters,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motion_inverts() {
        let m = Motion { v: 8.0, a: 0.03, w: 12.0, phase: 1.0 };
        for s in [0.0, 1.0, 50.0, 195.0] {
            assert!((m.displacement(m.time_of(s)) - s).abs() < 1e-9);
        }
    }

    #[test]
    fn low_pass_follows_slow_ramps_and_runs_split_at_extrema() {
        let x: Vec<f32> = (0..100).map(|i| (i as f32 * 0.1).sin()).collect();
        let y = low_pass(&x, 1.0, 1e-3);
        assert!(x.iter().zip(&y).all(|(a, b)| (a - b).abs() < 1e-2));
        let runs = monotone_runs(&[0.0, 1.0, 2.0, 1.0, 0.0, 0.0, 1.0]);
        assert_eq!(runs, vec![(0, 2), (2, 5), (5, 6)]);
    }
}
