//! Robustness sweeps (SIMULATED): each architecture's character classifier scored as one nuisance
//! of the virtual Evetac grows and the rest stay at a base preset, so that a researcher sees where
//! each architecture breaks. The test scans use the base world's test builds of the sensor (the
//! sensor sweep goes through builds one by one), and every level gets its own scans.

use crate::Progress;
use crate::error::{Error, Result};
use crate::eval::chars::CharModel;
use corpus::windows::{CharSetSpec, Task, build_many_in};
use corpus::world::World;
use pipeline::input::CharInput;
use serde::Serialize;
use sim::{BoardKind, Realism, Setup};
use std::fmt::Write as _;

/// A nuisance a sweep varies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Nuisance {
    /// Background activity per pixel (leak and shot noise in equal parts), Hz.
    NoiseRate,
    /// Standard deviation of the row's lateral offset from the sensor's centre line, mm.
    Misalignment,
    /// Standard deviation of the depth's wander along the row, mm (the tilt's, in mm per 100 mm,
    /// set to the same number).
    DepthDrift,
    /// Scanning speed, mm/s (the models were trained at 8).
    Speed,
    /// Which build of the sensor scans (1-4: the training builds beyond `clean`; 101-102: the
    /// test builds; `clean` trained on build 1 alone).
    SensorBuild,
    /// Compliance of the sensor's mount, um per N, with stick-slip of the gel on the board's face
    /// (`sim::StickSlip::LIGHT_MOUNT` but for the stiffness; 0: no stick-slip, a rigid mount).
    MountCompliance,
    /// Width of the field of view on the gel, mm: the optics' scale (18.6 the design's), every
    /// build at this width.
    FieldOfView,
    /// Share of the sensor's pixels that are hot (each firing at 10-100 Hz), drawn per build.
    HotPixels,
    /// Standard deviation of the board row's yaw under the slide, degrees.
    Yaw,
}

impl Nuisance {
    pub const ALL: [Nuisance; 9] = [
        Nuisance::NoiseRate,
        Nuisance::Misalignment,
        Nuisance::DepthDrift,
        Nuisance::Speed,
        Nuisance::SensorBuild,
        Nuisance::MountCompliance,
        Nuisance::FieldOfView,
        Nuisance::HotPixels,
        Nuisance::Yaw,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Nuisance::NoiseRate => "background activity (Hz per pixel)",
            Nuisance::Misalignment => "lateral misalignment sigma (mm)",
            Nuisance::DepthDrift => "depth drift sigma (mm)",
            Nuisance::Speed => "speed (mm/s)",
            Nuisance::SensorBuild => "sensor build (seed)",
            Nuisance::MountCompliance => "mount compliance with stick-slip (um/N)",
            Nuisance::FieldOfView => "field of view on the gel (mm)",
            Nuisance::HotPixels => "hot pixels (share of the pixels)",
            Nuisance::Yaw => "row yaw sigma (degrees)",
        }
    }

    /// The levels swept, from gentle to past what a real setup shows.
    pub fn levels(self) -> Vec<f64> {
        match self {
            Nuisance::NoiseRate => vec![0.011, 0.1, 0.3, 1.0, 3.0],
            Nuisance::Misalignment => vec![0.0, 0.15, 0.3, 0.6, 1.0],
            Nuisance::DepthDrift => vec![0.0, 0.03, 0.06, 0.12, 0.25],
            Nuisance::Speed => vec![8.0, 16.0, 24.0, 32.0, 48.0],
            Nuisance::SensorBuild => vec![1.0, 2.0, 3.0, 4.0, 101.0, 102.0],
            // Rigid, then 1 MN/m down to 20 kN/m (33: `harsh`'s mount).
            Nuisance::MountCompliance => vec![0.0, 1.0, 2.0, 5.0, 10.0, 20.0, 33.0, 50.0],
            // The design's 18.6 mm +-5% and +-10% (`nominal`'s builds: 2.5% sigma).
            Nuisance::FieldOfView => vec![16.74, 17.67, 18.6, 19.53, 20.46],
            // None, `nominal`'s 0.03%, `harsh`'s 0.1%, and past it.
            Nuisance::HotPixels => vec![0.0, 0.0003, 0.001, 0.003, 0.01],
            // None, `nominal`'s 0.5 degrees, `harsh`'s 1.5, and past it.
            Nuisance::Yaw => vec![0.0, 0.5, 1.0, 1.5, 3.0],
        }
    }

    /// The levels a words sweep reads: the same, but for the speed over the reader's 4-200 mm/s
    /// and the background activity to 3 Hz per pixel through 2 (issue #113's targets).
    pub fn word_levels(self) -> Vec<f64> {
        match self {
            Nuisance::NoiseRate => vec![0.011, 0.1, 0.3, 0.5, 1.0, 2.0, 3.0],
            Nuisance::Speed => vec![4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 200.0],
            other => other.levels(),
        }
    }

    /// Whether the levels run from gentle to harsh, so that the first level a reader falls at
    /// is its cliff (not the sensor builds, nor the field of view on either side of the design's).
    pub fn monotone(self) -> bool {
        !matches!(self, Nuisance::SensorBuild | Nuisance::FieldOfView)
    }

    /// The base setup, scan speed and world with this nuisance at `level`.
    pub(crate) fn apply(self, setup: &mut Setup, speed_mm_s: &mut f64, world: &mut World, level: f64) {
        match self {
            Nuisance::NoiseRate => {
                setup.camera.leak_hz_per_pixel = level / 2.0;
                setup.camera.shot_hz_per_pixel = level / 2.0;
            }
            Nuisance::Misalignment => setup.scan.misalignment_sigma_mm = level,
            Nuisance::DepthDrift => {
                setup.scan.depth_wander_sigma_mm = level;
                setup.scan.depth_tilt_sigma_mm_per_100mm = level;
            }
            Nuisance::Speed => *speed_mm_s = level,
            Nuisance::SensorBuild => world.sensors = vec![level as u64],
            Nuisance::MountCompliance => {
                setup.scan.stick_slip = (level > 0.0).then(|| sim::StickSlip::light_mount_with_compliance(level))
            }
            Nuisance::FieldOfView => {
                setup.camera.fov_width_mm = level;
                setup.variation.fov_rel_sigma = 0.0;
            }
            Nuisance::HotPixels => setup.variation.hot_pixel_fraction = level,
            Nuisance::Yaw => setup.scan.yaw_sigma_deg = level,
        }
    }
}

/// What a sweep scans: a board at a speed and depth, `trials` scans per row and level (the
/// character classifiers' sweep and the readers' words sweep alike).
#[derive(Debug, Clone, Serialize)]
pub struct SweepSpec {
    pub base: Realism,
    pub nuisances: Vec<Nuisance>,
    pub board: BoardKind,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub trials: u64,
    pub seed: u64,
    /// The world scanned: the test builds (`World::test`) or the sealed set's (`World::sealed`);
    /// the sensor-build sweep replaces its builds level by level.
    pub world: World,
    /// Where the swept models were loaded from (named in the report).
    pub models_dir: String,
}

/// One nuisance's curve: accuracy per model per level.
#[derive(Debug, Clone, Serialize)]
pub struct Curve {
    pub nuisance: Nuisance,
    pub label: &'static str,
    pub levels: Vec<f64>,
    /// `[model][level]`.
    pub accuracy: Vec<Vec<f64>>,
    /// Windows scored per level (scans the labeler miscounted give none: they are counted in
    /// `skipped_scans` and score as failures in `accuracy_all_windows`).
    pub windows: Vec<usize>,
    pub skipped_scans: Vec<usize>,
    /// Accuracy over every character printed (windows of skipped scans count as wrong).
    pub accuracy_all_windows: Vec<Vec<f64>>,
}

/// A sweep's curves, of characters ([`Curve`]) or of words
/// (`crate::eval::robustness_words::WordsCurve`), with the names of the models or readers swept.
#[derive(Debug, Clone, Serialize)]
pub struct Report<C = Curve> {
    pub data: &'static str,
    pub spec: SweepSpec,
    pub models: Vec<String>,
    pub curves: Vec<C>,
}

/// Sweeps each nuisance of `spec` for the named models.
pub fn sweep(spec: &SweepSpec, models: &[(String, &CharModel)], progress: &dyn Progress) -> Result<Report> {
    let inputs: Vec<&CharInput> = models.iter().map(|(_, m)| &m.input).collect();
    if inputs.is_empty() {
        return Err(Error::Setting { name: "models", value: "none".into(), expected: "at least one model to sweep" });
    }
    let board = spec.world.board(&spec.base.setup(), &spec.board)?;
    let characters_per_scan: Vec<usize> =
        board.rows.iter().map(|r| r.chars().filter(|c| c.is_ascii_uppercase()).count()).collect();
    let mut curves = Vec::new();
    for &nuisance in &spec.nuisances {
        let levels = nuisance.levels();
        let mut curve = Curve {
            nuisance,
            label: nuisance.label(),
            levels: levels.clone(),
            accuracy: vec![Vec::new(); models.len()],
            windows: Vec::new(),
            skipped_scans: Vec::new(),
            accuracy_all_windows: vec![Vec::new(); models.len()],
        };
        for &level in &levels {
            let mut setup = spec.base.setup();
            let mut set_spec = CharSetSpec {
                boards: vec![spec.board.clone()],
                speed_mm_s: spec.speed_mm_s,
                depth_mm: spec.depth_mm,
                trials: spec.trials,
                seed: spec.seed,
                task: Task::Chars,
                jitter_ms: 0.0,
                world: spec.world.clone(),
                blank_cells: false,
                sweep: None,
            };
            nuisance.apply(&mut setup, &mut set_spec.speed_mm_s, &mut set_spec.world, level);
            let windows = build_many_in(&set_spec, &setup, &inputs, progress)?;
            let printed = characters_per_scan.iter().sum::<usize>() * spec.trials as usize;
            for (k, ((_, m), set)) in models.iter().zip(&windows.sets).enumerate() {
                let s = m.score(set)?;
                curve.accuracy[k].push(s.accuracy);
                let right = (s.accuracy * s.n as f64).round();
                curve.accuracy_all_windows[k].push(if printed > 0 { right / printed as f64 } else { 0.0 });
            }
            curve.windows.push(windows.sets[0].len());
            curve.skipped_scans.push(windows.skipped_scans);
            progress.note(&format!(
                "SIMULATED {:?} = {level}: {}",
                nuisance,
                models
                    .iter()
                    .zip(&curve.accuracy)
                    .map(|((name, _), a)| format!("{name} {:.1}%", 100.0 * a.last().unwrap_or(&0.0)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        curves.push(curve);
    }
    Ok(Report {
        data: "SIMULATED (virtual Evetac)",
        spec: spec.clone(),
        models: models.iter().map(|(n, _)| n.clone()).collect(),
        curves,
    })
}

/// The curves as Markdown tables: accuracy over the windows the labeler found, and over every
/// character printed.
pub fn markdown(r: &Report) -> String {
    let mut m = String::new();
    let s = &r.spec;
    let sealed = s.world.print_seed.is_some();
    let _ = writeln!(
        m,
        "# Robustness sweeps (SIMULATED)\n\nCharacter accuracy of each architecture's character classifier (from `{}`) as one nuisance grows, the rest at the `{}` preset; board {}, {} mm/s, {} mm, {} scans per row and level (seed {}), sensor builds {:?} unless swept. Each cell: accuracy over the windows the labeler found / over every character printed (a scan whose window count was off scores all its characters wrong; the headline, and what the figures plot). {}: `braille sim robustness --realism {} --models {}{}` (see docs/simulator.md).\n",
        s.models_dir,
        s.base,
        s.board.name(),
        s.speed_mm_s,
        s.depth_mm,
        s.trials,
        s.seed,
        s.world.sensors,
        if sealed { "Made by (run again, it reads the sealed set again: docs/protocol.md)" } else { "Regenerate" },
        s.base,
        s.models_dir,
        if sealed { " --final" } else { "" }
    );
    for c in &r.curves {
        let _ = writeln!(m, "## {}\n", c.label);
        let _ = write!(m, "| level | windows (scans skipped) |");
        for name in &r.models {
            let _ = write!(m, " {name}: accuracy / over all printed |");
        }
        let _ = writeln!(m);
        let _ = writeln!(m, "|{}", " --- |".repeat(2 + r.models.len()));
        for (i, level) in c.levels.iter().enumerate() {
            let _ = write!(m, "| {level} | {} ({}) |", c.windows[i], c.skipped_scans[i]);
            for k in 0..r.models.len() {
                // With no window found the conditional accuracy has no meaning.
                let found =
                    if c.windows[i] == 0 { "-".to_string() } else { format!("{:.1}%", 100.0 * c.accuracy[k][i]) };
                let _ = write!(m, " {found} / {:.1}% |", 100.0 * c.accuracy_all_windows[k][i]);
            }
            let _ = writeln!(m);
        }
        let _ = writeln!(m);
    }
    m
}
