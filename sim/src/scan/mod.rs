//! The scan protocol and event generation: lower the sensor onto a row to a depth, slide along
//! it, hold, lift; every pixel turns the brightness it sees into events.
//!
//! Each dot's image moves with the board under the sensor (its stamp carries the gel's trailing
//! smear and drag for the slide's direction and speed, and the depth under it when it passes the
//! sensor's centre), so each pixel row sees one brightness profile along the board, and each of
//! its pixels traverses that profile shifted by its position. The profile is built once per pixel
//! row from the dots' stamps and filtered by the photoreceptor (in the coordinate of travel, at
//! the nominal speed); each pixel then finds the crossings of its own thresholds along it, whose
//! positions convert to times through the motion (ripple and hand-held swings). Crossing times are
//! exact for the piecewise-linear profile, quantised to the readout grid, with the refractory
//! period applied per pixel. The print texture under the board's face adds its own events per
//! pixel; noise (leak, shot, hot pixels), latency jitter and the readout's frames come on top.

use crate::board::Board;
use crate::error::{Error, Result, check};
use crate::mount::{self, Contact, StickSlip, StickSlipTruth, Trace};
use crate::sensor::Sensor;
use crate::stamp::{Stamp, StampMotion};
use encoders::{Event, Polarity, Resolution};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, Poisson};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

mod pixels;

use pixels::*;

/// Which way the sensor slides along the row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
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
    /// Hand-held speed changes: the relative amplitude of slow swings of the speed around its
    /// mean (1-5 Hz; human reading: a CV of 30-50%, assumed from Hughes et al. 2011). The speed
    /// stays positive: reversals are not simulated. 0 for an arm.
    #[serde(default)]
    pub speed_variation: f64,
    /// Depth along the slide: a tilt of the board against the path, drawn per trial with this
    /// standard deviation in mm per 100 mm, plus a smooth wander of this standard deviation and
    /// wavelength (assumed: REALISM.md 4).
    #[serde(default)]
    pub depth_tilt_sigma_mm_per_100mm: f64,
    #[serde(default)]
    pub depth_wander_sigma_mm: f64,
    #[serde(default = "default_wander_wavelength")]
    pub depth_wander_wavelength_mm: f64,
    /// Standard deviation of the row's yaw against the sensor's x axis, per trial (assumed).
    #[serde(default)]
    pub yaw_sigma_deg: f64,
    /// Stick-slip of the gel on the board's face through the mount's compliance
    /// ([`crate::mount`]); `None`: the gel slides steadily and the camera follows the command.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stick_slip: Option<StickSlip>,
}

fn default_wander_wavelength() -> f64 {
    40.0
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
            speed_variation: 0.0,
            depth_tilt_sigma_mm_per_100mm: 0.0,
            depth_wander_sigma_mm: 0.0,
            depth_wander_wavelength_mm: default_wander_wavelength(),
            yaw_sigma_deg: 0.0,
            stick_slip: None,
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
    /// After the lift, the time the scan goes on while the gel recovers (0 without relaxation).
    #[serde(default)]
    pub recovery_s: f64,
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
    /// The drawn yaw of the row and tilt of the depth (0 without them).
    #[serde(default)]
    pub yaw_deg: f64,
    #[serde(default)]
    pub depth_tilt_mm_per_100mm: f64,
    /// The depth under the sensor's centre at the start, middle and end of the slide.
    #[serde(default)]
    pub depth_profile_mm: Vec<f64>,
    /// The slide's swings of speed around its mean (the arm's ripple, then a hand's swings), each
    /// (relative amplitude, angular frequency in rad/s, phase in rad) in time from the slide's
    /// start ([`ScanTruth::speed_at_mm_s`]). Empty in truth files written before 2026-11-25.
    #[serde(default)]
    pub speed_swings: Vec<(f64, f64, f64)>,
    /// What the gel's stick-slip did, when the scan has it ([`ScanConfig::stick_slip`]); the
    /// swings above are the arm's command, the camera follows it through the mount.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stick_slip: Option<StickSlipTruth>,
    pub timeline: Timeline,
    pub resolution: Resolution,
    pub pitch_mm: f64,
    pub fov_width_mm: f64,
    pub characters: Vec<CharacterTruth>,
}

impl ScanTruth {
    /// The board's speed under the sensor at stream time `t_s`, mm/s: the mean speed and its
    /// swings during the slide, 0 before and after it: the arm's. (The gel's surface follows it
    /// with the lag of its dynamics; with stick-slip the camera sticks and jumps about it, see
    /// [`ScanTruth::stick_slip`].)
    pub fn speed_at_mm_s(&self, t_s: f64) -> f64 {
        let tl = &self.timeline;
        if !(tl.slide_start_s..=tl.slide_end_s).contains(&t_s) {
            return 0.0;
        }
        let (t, v) = (t_s - tl.slide_start_s, self.scan.speed_mm_s);
        self.speed_swings.iter().fold(v, |acc, &(a, w, phase)| acc + v * a * (w * t + phase).sin())
    }
}

/// A simulated scan: events in time order and the ground truth.
#[derive(Debug, Clone)]
pub struct Scan {
    pub events: Vec<Event>,
    pub truth: ScanTruth,
}

/// The slide's displacement over time: a mean speed with sinusoidal swings (the arm's ripple, a
/// hand's slow changes), each `(relative amplitude, angular frequency, phase)`.
#[derive(Debug, Clone)]
struct Motion {
    v: f64,
    terms: Vec<(f64, f64, f64)>,
    /// The camera's displacement when the mount lets it differ from the command (stick-slip).
    trace: Option<Trace>,
}

impl Motion {
    /// The arm's displacement and speed at `t` (one `sin_cos` per swing; a swing of zero
    /// amplitude or frequency adds nothing).
    fn displacement_and_speed(&self, t: f64) -> (f64, f64) {
        self.terms.iter().fold((self.v * t, self.v), |(s, v), &(a, w, phase)| {
            if a == 0.0 || w == 0.0 {
                (s, v)
            } else {
                let (sin, cos) = (w * t + phase).sin_cos();
                (s + a * self.v / w * (phase.cos() - cos), v + self.v * a * sin)
            }
        })
    }

    /// The time at which the camera's displacement reaches `s` (Newton's method on the command,
    /// which is monotone; the stick-slip trace where there is one).
    fn time_of(&self, s: f64) -> f64 {
        if let Some(trace) = &self.trace {
            return trace.time_of(s);
        }
        let mut t = s / self.v;
        for _ in 0..8 {
            let (d, v) = self.displacement_and_speed(t);
            t -= (d - s) / v;
        }
        t
    }
}

/// Hand-held speed swings: (share of the amplitude, frequency in Hz), assumed within the 1-5 Hz
/// band of REALISM.md 4.
const HAND_SWINGS: [(f64, f64); 3] = [(0.5, 1.1), (0.3, 2.3), (0.2, 4.7)];

/// The depth under the sensor's centre along the slide: tilt plus a smooth wander.
#[derive(Debug, Clone)]
struct DepthProfile {
    depth_mm: f64,
    slide_mm: f64,
    tilt_per_mm: f64,
    /// (amplitude, wavenumber, phase) of the wander's sinusoids.
    wander: Vec<(f64, f64, f64)>,
}

impl DepthProfile {
    fn at(&self, s: f64) -> f64 {
        let s = s.clamp(0.0, self.slide_mm);
        let w: f64 = self.wander.iter().map(|&(a, k, phase)| a * (k * s + phase).sin()).sum();
        (self.depth_mm + self.tilt_per_mm * (s - self.slide_mm / 2.0) + w).max(0.0)
    }

    fn is_flat(&self) -> bool {
        self.tilt_per_mm == 0.0 && self.wander.is_empty()
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

/// The deepest press the simulator takes, as a share of the gel's thickness.
pub const MAX_PRESS_OF_GEL: f64 = 0.5;

fn validate(scan: &ScanConfig, board: &Board) -> Result<f64> {
    let slide = scan.slide_mm.unwrap_or(board.geometry.row_length_mm);
    check("speed_mm_s", scan.speed_mm_s, 1e-3..1e4, "a positive speed")?;
    check("depth_mm", scan.depth_mm, 0.0..50.0, "zero or more")?;
    check("approach_speed_mm_s", scan.approach_speed_mm_s, 1e-3..1e4, "a positive speed")?;
    check("hold_s", scan.hold_s, 0.0..1e4, "zero or more")?;
    check("speed_ripple", scan.speed_ripple, 0.0..0.5, "in [0, 0.5)")?;
    check("ripple_hz", scan.ripple_hz, 0.0..1e4, "zero or more")?;
    check("misalignment_sigma_mm", scan.misalignment_sigma_mm, 0.0..10.0, "zero or more")?;
    check("slide_mm", slide, 1e-3..1e5, "a positive length")?;
    check("speed_variation", scan.speed_variation, 0.0..0.9, "in [0, 0.9)")?;
    check("depth_tilt_sigma_mm_per_100mm", scan.depth_tilt_sigma_mm_per_100mm, 0.0..5.0, "zero or more")?;
    check("depth_wander_sigma_mm", scan.depth_wander_sigma_mm, 0.0..5.0, "zero or more")?;
    check("depth_wander_wavelength_mm", scan.depth_wander_wavelength_mm, 1.0..1e5, "at least 1 mm")?;
    check("yaw_sigma_deg", scan.yaw_sigma_deg, 0.0..10.0, "in [0, 10) degrees")?;
    if let Some(p) = &scan.stick_slip {
        p.validate()?;
    }
    if scan.speed_ripple + scan.speed_variation >= 0.95 {
        return Err(Error::Inconsistent {
            names: "speed_ripple, speed_variation",
            why: format!(
                "{} + {} must stay below 0.95: the sensor would stop or reverse",
                scan.speed_ripple, scan.speed_variation
            ),
        });
    }
    if scan.row >= board.rows.len() {
        return Err(Error::NoRow { row: scan.row, rows: board.rows.len() });
    }
    Ok(slide)
}

/// What a trial draws besides the clean scan's misalignment and ripple phase, from a stream of its
/// own (so that scans without these nuisances keep their events).
struct Nuisances {
    yaw_rad: f64,
    tilt_per_mm: f64,
    wander: Vec<(f64, f64, f64)>,
    hand: Vec<(f64, f64, f64)>,
    rng: ChaCha8Rng,
}

impl Nuisances {
    fn draw(scan: &ScanConfig) -> Result<Nuisances> {
        let mut rng = ChaCha8Rng::seed_from_u64(scan.seed ^ 0x4e55_4953_414e_4345);
        let unit = Normal::new(0.0, 1.0).map_err(Error::distribution("unit normal"))?;
        let yaw_rad = (scan.yaw_sigma_deg * unit.sample(&mut rng)).to_radians();
        let tilt_per_mm = scan.depth_tilt_sigma_mm_per_100mm * unit.sample(&mut rng) / 100.0;
        let mut wander = Vec::new();
        if scan.depth_wander_sigma_mm > 0.0 {
            // Three sinusoids, wavelengths 1, 0.55 and 0.3 of the given one; amplitudes so that
            // the variance is sigma^2.
            let shares: [(f64, f64); 3] = [(0.7, 1.0), (0.5, 0.55), (0.3, 0.3)];
            let norm = (shares.iter().map(|(a, _)| a * a / 2.0).sum::<f64>()).sqrt();
            for (a, l) in shares {
                let k = std::f64::consts::TAU / (l * scan.depth_wander_wavelength_mm);
                wander.push((scan.depth_wander_sigma_mm * a / norm, k, rng.random_range(0.0..std::f64::consts::TAU)));
            }
        }
        let mut hand = Vec::new();
        if scan.speed_variation > 0.0 {
            for (share, hz) in HAND_SWINGS {
                let phase = rng.random_range(0.0..std::f64::consts::TAU);
                hand.push((scan.speed_variation * share, std::f64::consts::TAU * hz, phase));
            }
        }
        Ok(Nuisances { yaw_rad, tilt_per_mm, wander, hand, rng })
    }
}

/// A dot as one scan sees it: where it is against the sensor's row line (yaw included) and how
/// deep it is pressed (depth profile and its own height).
struct PlacedDot {
    x_mm: f64,
    y_mm: f64,
    key: StampKey,
}

/// Stamps are shared by dots of (nearly) the same penetration, height and radius: 0.01 mm steps.
type StampKey = (i64, i64, i64);

/// Simulates one scan of `board` by `sensor`.
pub fn simulate(board: &Board, sensor: &Sensor, scan: &ScanConfig) -> Result<Scan> {
    let slide = validate(scan, board)?;
    // The gel's model (small-strain modulus, Hertz-like conformity) holds for presses well inside
    // its thickness; a press of half the gel or more bottoms it out against the window.
    let thickness_mm = sensor.gel.dynamics.thickness_mm;
    if scan.depth_mm >= MAX_PRESS_OF_GEL * thickness_mm {
        return Err(Error::Inconsistent {
            names: "depth_mm, gel thickness",
            why: format!(
                "a press of {} mm into a gel {thickness_mm:.2} mm thick: the gel holds presses under {:.2} mm (half its thickness; the paper's are 0.2-1.5 mm)",
                scan.depth_mm,
                MAX_PRESS_OF_GEL * thickness_mm
            ),
        });
    }
    let cam = &sensor.camera;
    let (w, h) = (cam.resolution.width as usize, cam.resolution.height as usize);
    let pitch = cam.pitch_mm();
    let step = pitch / 2.0;
    let dir = scan.direction.sign();
    let mut rng = ChaCha8Rng::seed_from_u64(scan.seed);
    let misalignment = Normal::new(0.0, scan.misalignment_sigma_mm)
        .map_err(Error::distribution("misalignment_sigma_mm"))?
        .sample(&mut rng);
    let phase = rng.random_range(0.0..std::f64::consts::TAU);
    let mut nuisances = Nuisances::draw(scan)?;
    let mut terms = vec![(scan.speed_ripple, std::f64::consts::TAU * scan.ripple_hz, phase)];
    terms.extend(nuisances.hand.iter().copied());
    let mut motion = Motion { v: scan.speed_mm_s, terms, trace: None };
    let depth = DepthProfile {
        depth_mm: scan.depth_mm,
        slide_mm: slide,
        tilt_per_mm: nuisances.tilt_per_mm,
        wander: nuisances.wander.clone(),
    };
    let mut stick_slip = None;
    if let Some(params) = &scan.stick_slip {
        let contact = Contact::of(sensor);
        let height = board.geometry.dot_height_mm;
        let (trace, out) = mount::trace(
            params,
            &contact,
            slide,
            scan.speed_mm_s,
            |t| motion.displacement_and_speed(t),
            |s| depth.at(s) - height,
        )?;
        motion.trace = Some(trace);
        stick_slip = Some(out);
    }
    let start_depth = depth.at(0.0);
    let lower_s = start_depth / scan.approach_speed_mm_s;
    let slide_s = motion.time_of(slide);
    let table = TimeTable::new(&motion, slide, pitch / 2.0);
    // After lifting, the gel's relaxing share recovers for a few of its time constants.
    let recovery = sensor.gel.dynamics.recovery();
    let recovery_s = (5.0 * recovery.1).min(1.0);
    let timeline = Timeline {
        lowered_s: lower_s,
        slide_start_s: lower_s + scan.hold_s,
        slide_end_s: lower_s + scan.hold_s + slide_s,
        lift_start_s: lower_s + 2.0 * scan.hold_s + slide_s,
        end_s: 2.0 * lower_s + 2.0 * scan.hold_s + slide_s + recovery_s,
        recovery_s,
    };
    // Sensor centre at the start of the slide, in board x; travel coordinate p = dir * x.
    let x_start = if dir > 0.0 { scan.start_mm } else { scan.start_mm + slide };
    let row_y = board.row_y_mm(scan.row) + misalignment;
    // The row's yaw turns it about the middle of the slide.
    let x_mid = x_start + dir * slide / 2.0;
    let (sin_yaw, cos_yaw) = nuisances.yaw_rad.sin_cos();

    // Stamps, shared by dots of (nearly) the same penetration, height and radius.
    let g = &board.geometry;
    let optics_scale = w as f64 / 640.0;
    let stamp_motion = StampMotion { direction: dir, speed_mm_s: scan.speed_mm_s };
    let mut stamps: HashMap<StampKey, Stamp> = HashMap::new();
    let mut placed = Vec::with_capacity(board.dots.len());
    let q = |v: f64| (v / 0.01).round() as i64;
    for d in &board.dots {
        let (dx, dy) = (d.x_mm - x_mid, d.y_mm - board.row_y_mm(scan.row));
        let (x_mm, y_mm) =
            (x_mid + dx * cos_yaw - dy * sin_yaw, board.row_y_mm(scan.row) + dx * sin_yaw + dy * cos_yaw);
        // The depth when the dot is under the sensor's centre.
        let penetration = depth.at(dir * (x_mm - x_start)) + (d.height_mm - g.dot_height_mm);
        let key = (q(penetration), q(d.height_mm), q(d.radius_mm));
        let (pen, hd, rd) = (key.0 as f64 * 0.01, key.1 as f64 * 0.01, key.2 as f64 * 0.01);
        // A dot of another board row whose stamp reaches no pixel row of the image (its own
        // rows are further than `half` from it: `build_spans` skips it there) needs no stamp.
        let half = Stamp::half_rows(&sensor.gel, rd.max(hd), hd, pen.max(0.0), pitch, optics_scale);
        if (y_mm - row_y).abs() / pitch >= half as f64 + h as f64 / 2.0 + 1.0 {
            continue;
        }
        stamps.entry(key).or_insert_with(|| {
            Stamp::new(&sensor.gel, rd.max(hd), hd, pen.max(0.0), pitch, optics_scale, stamp_motion)
        });
        placed.push(PlacedDot { x_mm, y_mm, key });
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
    let texture = Texture::new(board, sensor, &depth, scan.speed_mm_s, &level_tau);
    let mut events: Vec<Event> = Vec::new();
    let mut dots_by_y: Vec<usize> = (0..placed.len()).collect();
    dots_by_y.sort_by(|&a, &b| placed[a].y_mm.total_cmp(&placed[b].y_mm));

    for py in 0..h {
        let y = row_y + (py as f64 + 0.5 - h as f64 / 2.0) * pitch;
        // Dots whose stamp reaches this pixel row, in travel order.
        let reach = (max_half + 1.0) * pitch;
        let lo = dots_by_y.partition_point(|&i| placed[i].y_mm < y - reach);
        let hi = dots_by_y.partition_point(|&i| placed[i].y_mm <= y + reach);
        let mut near: Vec<usize> = dots_by_y[lo..hi].to_vec();
        near.sort_by(|&a, &b| (dir * placed[a].x_mm).total_cmp(&(dir * placed[b].x_mm)));
        let spans = build_spans(&placed, &near, &stamps, y, dir, pitch, step, pad, &tau_x);
        if spans.is_empty() && texture.is_none() {
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
            if !spans.is_empty() {
                pixel_events(
                    &pixel,
                    recovery,
                    &spans,
                    level,
                    c,
                    slide,
                    step,
                    &table,
                    &timeline,
                    grid,
                    refractory,
                    &mut events,
                );
            }
            if let Some(texture) = &texture {
                let board_y = y;
                texture.pixel_events(
                    &pixel,
                    level,
                    c,
                    dir,
                    board_y,
                    slide,
                    &table,
                    &timeline,
                    grid,
                    refractory,
                    &mut events,
                );
            }
        }
    }
    if recovery_s > 0.0 {
        // Lifting ends before the gel's slow share has recovered: nothing is read after the end.
        let end_us = (timeline.end_s * 1e6) as i64;
        events.retain(|e| e.t_us <= end_us);
    }

    add_noise(sensor, &timeline, &mut rng, &mut events)?;
    if cam.latency_jitter_us > 0.0 {
        jitter(&mut events, cam.latency_jitter_us, grid, &mut nuisances.rng)?;
    }
    let mut events = sort_by_time(events, grid);
    enforce_refractory(&mut events, w, h, refractory);
    if let Some(limit) = cam.event_rate_limit_hz {
        read_out_frames(&mut events, grid, limit);
    }

    let mut truth = truth(board, sensor, scan, misalignment, phase, timeline, &motion, x_start, slide);
    truth.yaw_deg = nuisances.yaw_rad.to_degrees();
    truth.stick_slip = stick_slip;
    truth.depth_tilt_mm_per_100mm = nuisances.tilt_per_mm * 100.0;
    if !depth.is_flat() {
        truth.depth_profile_mm = vec![depth.at(0.0), depth.at(slide / 2.0), depth.at(slide)];
    }
    Ok(Scan { events, truth })
}

/// Latency jitter: each event's time within its readout frame is unknown (uniform), a half-normal
/// latency of `sigma_us` is added, and the event goes to the frame after.
fn jitter(events: &mut [Event], sigma_us: f64, grid: i64, rng: &mut ChaCha8Rng) -> Result<()> {
    let latency = Normal::new(0.0, sigma_us).map_err(Error::distribution("latency_jitter_us"))?;
    for e in events.iter_mut() {
        let raw = e.t_us as f64 - rng.random_range(0.0..grid as f64) + latency.sample(rng).abs();
        e.t_us = on_grid((raw.max(0.0)) as i64, grid);
    }
    Ok(())
}

/// The smallest grid time at or after `t_us`.
fn on_grid(t_us: i64, grid: i64) -> i64 {
    t_us.div_euclid(grid) * grid + if t_us.rem_euclid(grid) == 0 { 0 } else { grid }
}

/// Variable-rate readout: a frame reads every event that happened before it starts and lasts
/// `max(grid, events / limit)`; the next frame starts when it ends. Events keep their order and
/// are stamped with their frame's start; under overload they arrive late, none is dropped.
fn read_out_frames(events: &mut [Event], grid: i64, limit_hz: f64) {
    let per_event_us = 1e6 / limit_hz;
    let mut i = 0;
    let mut frame = match events.first() {
        Some(e) => e.t_us,
        None => return,
    };
    while i < events.len() {
        // The frame reads what has happened by its start.
        let start = i;
        while i < events.len() && events[i].t_us <= frame {
            events[i].t_us = frame;
            i += 1;
        }
        let n = i - start;
        let length = ((n as f64 * per_event_us).ceil() as i64).max(grid);
        frame += length;
        if i < events.len() && events[i].t_us > frame {
            // Idle: frames run on at the grid until the next event.
            frame += on_grid(events[i].t_us - frame, grid);
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn build_spans(
    placed: &[PlacedDot],
    near: &[usize],
    stamps: &HashMap<StampKey, Stamp>,
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
        let dot = &placed[d];
        let stamp = &stamps[&dot.key];
        let dy = (y - dot.y_mm) / pitch;
        if dy.abs() >= stamp.half as f64 {
            continue;
        }
        let p = dir * dot.x_mm;
        // The stamp's extent along board x, turned into travel coordinates.
        let (lo, hi) = (stamp.x_lo as f64 * pitch, stamp.x_hi as f64 * pitch);
        let (back, ahead) = if dir > 0.0 { (lo, hi) } else { (hi, lo) };
        intervals.push((((p - back) / step).floor() as i64 - 1, ((p + ahead) / step).ceil() as i64 + 1, d));
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
            let dot = &placed[d];
            let stamp = &stamps[&dot.key];
            let dy = (y - dot.y_mm) / pitch;
            let p = dir * dot.x_mm;
            for (j, v) in raw.iter_mut().enumerate() {
                let pj = (a + j as i64) as f64 * step;
                *v += stamp.at(dir * (pj - p) / pitch, dy);
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
        let poisson =
            Poisson::new(lambda).map_err(|e| Error::Distribution { name: "noise rate", source: Box::new(e) })?;
        Ok(poisson.sample(rng) as u64)
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
    let slot = |t_us: i64| ((t_us - min) / grid) as usize;
    let mut start = vec![0usize; slots + 1];
    for e in &events {
        start[slot(e.t_us) + 1] += 1;
    }
    for i in 0..slots {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    if max - min >= 1 << 30 {
        let mut out = vec![Event { t_us: 0, x: 0, y: 0, polarity: Polarity::Off }; events.len()];
        for e in events {
            let k = slot(e.t_us);
            out[next[k]] = e;
            next[k] += 1;
        }
        for i in 0..slots {
            out[start[i]..start[i + 1]].sort_unstable_by_key(|e| (e.t_us, e.y, e.x, e.polarity));
        }
        return out;
    }
    // The key (t_us, y, x, polarity) packed into one integer where the times fit: the same order
    // (equal keys are equal events), sorted as plain integers and unpacked. A slot holds the
    // signal's events in generation order, (y, x), then the noise's: two runs that the stable
    // sort merges rather than sorting anew.
    let mut keys = vec![0u64; events.len()];
    for e in &events {
        let k = slot(e.t_us);
        keys[next[k]] = ((e.t_us - min) as u64) << 33 | u64::from(e.y) << 17 | u64::from(e.x) << 1 | e.polarity as u64;
        next[k] += 1;
    }
    drop(events);
    for i in 0..slots {
        keys[start[i]..start[i + 1]].sort();
    }
    keys.into_iter()
        .map(|k| Event {
            t_us: (k >> 33) as i64 + min,
            y: (k >> 17) as u16,
            x: (k >> 1) as u16,
            polarity: if k & 1 == 1 { Polarity::On } else { Polarity::Off },
        })
        .collect()
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
        yaw_deg: 0.0,
        depth_tilt_mm_per_100mm: 0.0,
        depth_profile_mm: Vec::new(),
        speed_swings: motion.terms.clone(),
        stick_slip: None,
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
        let m = Motion { v: 8.0, terms: vec![(0.03, 12.0, 1.0), (0.3, 7.0, 0.2)], trace: None };
        for s in [0.0, 1.0, 50.0, 195.0] {
            assert!((m.displacement_and_speed(m.time_of(s)).0 - s).abs() < 1e-9);
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

    #[test]
    fn the_time_sort_orders_as_a_plain_sort_on_each_path() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // Packed keys; a span too long to pack; slots too many for the counting sort.
        for (span_us, grid) in [(50_000i64, 1_000i64), (1 << 31, 1 << 20), (1 << 31, 1_000)] {
            // Grid times, signal-like runs in (y, x) order and noise after them, duplicates too.
            let mut events: Vec<Event> = (0..5_000)
                .map(|k| Event {
                    t_us: grid + rng.random_range(0..span_us / grid) * grid,
                    x: (k % 640) as u16,
                    y: (k / 640) as u16,
                    polarity: if rng.random_bool(0.5) { Polarity::On } else { Polarity::Off },
                })
                .collect();
            events.extend(events[..500].to_vec());
            let mut reference = events.clone();
            reference.sort_unstable_by_key(|e| (e.t_us, e.y, e.x, e.polarity));
            assert_eq!(sort_by_time(events, grid), reference);
        }
    }
}
