//! The simulated world of a protocol's scans: a realism preset and the sensor builds that scan,
//! and the seeds that make each scan (SIMULATED data). Training scans use the training builds,
//! test scans builds never trained on, as a model moved to a new Evetac would meet.

use crate::error::Result;
use serde::{Deserialize, Serialize};
use sim::sensor::Sensor;
use sim::{Board, BoardKind, CameraConfig, GelConfig, Realism, Setup};

/// The clean simulated sensor: the DVXplorer's resolution behind the default gel, pixel seed
/// `seed` (the `clean` world's one build).
pub fn sensor(resolution: encoders::Resolution, seed: u64) -> Result<Sensor> {
    let camera = CameraConfig { resolution, ..CameraConfig::default() };
    Ok(Sensor::new(camera, GelConfig::default(), seed)?)
}

/// Sensor builds that training scans are made with, and builds kept for testing: a model is
/// tested on sensors it never saw, as a model moved to a new Evetac would be.
pub const TRAIN_SENSORS: [u64; 4] = [1, 2, 3, 4];
pub const TEST_SENSORS: [u64; 2] = [101, 102];
/// Sensor builds neither trained nor tested on: with a validation board, a choice that must hold
/// on a new sensor (as the test builds ask) is made without the test builds.
pub const VALIDATION_SENSORS: [u64; 2] = [51, 52];
/// Builds kept for reads that choose or diagnose: 51 and 52 the `validation` world, 53-60 read
/// build by build (`row_start`, `speck_builds`). Never trained on, like the test builds.
pub const HELD_OUT_BUILDS: std::ops::RangeInclusive<u64> = 51..=60;
/// The sealed test sets' sensor builds ([`World::sealed`]): never trained on, and read only by a
/// report's `--final` run, which records the read in docs/protocol.md (`experiments::sealed`).
pub const SEALED_SENSORS: [u64; 2] = [201, 202];

/// A list of sensor builds as a command line gives it: numbers and inclusive ranges, `1-4,7,20-24`,
/// in that order. What it may hold is [`World::train_on`]'s to say.
pub fn parse_builds(text: &str) -> Result<Vec<u64>> {
    let bad = || crate::Error::Setting {
        name: "sensor builds",
        value: text.to_string(),
        expected: "numbers and ranges separated by commas, e.g. 1-4,7,20-24",
    };
    let mut builds = Vec::new();
    for part in text.split(',').map(str::trim) {
        let number = |s: &str| s.trim().parse::<u64>().map_err(|_| bad());
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (number(a)?, number(b)?);
                if a > b {
                    return Err(bad());
                }
                builds.extend(a..=b);
            }
            None => builds.push(number(part)?),
        }
    }
    Ok(builds)
}

/// A list of sensor builds as [`parse_builds`] reads it, runs written as ranges: `1-4,7,20-24`.
pub fn format_builds(builds: &[u64]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < builds.len() {
        let mut j = i;
        while j + 1 < builds.len() && builds[j + 1] == builds[j] + 1 {
            j += 1;
        }
        parts.push(if j > i { format!("{}-{}", builds[i], builds[j]) } else { builds[i].to_string() });
        i = j + 1;
    }
    parts.join(",")
}

/// The simulated world a protocol's scans come from: a realism preset (the print of the boards,
/// the gel, the camera, the kinematics) and the builds of the sensor, trial `t` being scanned by
/// `sensors[t % len]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct World {
    pub realism: Realism,
    pub sensors: Vec<u64>,
    /// The sensor mount's compliance in um per N, in place of the preset's mount: 0 for a rigid
    /// mount (no stick-slip), else `sim::StickSlip::LIGHT_MOUNT` at that compliance; `None` for
    /// the preset's (`nominal`: 10 um/N). The same scans (seeds) with another mount, so that what
    /// stick-slip costs is measured pair by pair.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mount_compliance_um_per_n: Option<f64>,
    /// The seed the boards' print (their tolerances) is drawn with, in place of each board's own
    /// (`None`): the sealed test sets print the test boards anew ([`World::sealed`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub print_seed: Option<u64>,
}

impl Default for World {
    fn default() -> Self {
        World::clean()
    }
}

/// Which sensor builds scan an evaluation's boards (beyond `clean`, which has one build).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum SensorBuilds {
    /// The test builds, never trained on: every reported figure.
    #[default]
    Test,
    /// The training builds: with a validation board (VAL, VAL-WORDS), for choices made on
    /// validation data.
    Training,
    /// Builds held out of training and test (51 and 52): with a validation board, for choices
    /// that must hold on a sensor never trained on.
    Validation,
}

impl World {
    /// The world of `builds` at `realism`.
    pub fn of(realism: Realism, builds: SensorBuilds) -> World {
        match builds {
            SensorBuilds::Test => World::test(realism),
            SensorBuilds::Training => World::train(realism),
            SensorBuilds::Validation => World::validation(realism),
        }
    }

    /// The simulator before its nuisances: one sensor build (seed 1) for training and test, and
    /// the scan seeds of then. The shipped models and tables were made in it.
    pub fn clean() -> World {
        World { realism: Realism::Clean, sensors: vec![1], mount_compliance_um_per_n: None, print_seed: None }
    }

    /// Training scans at `realism`: the training builds ([`TRAIN_SENSORS`]; `clean` has one).
    pub fn train(realism: Realism) -> World {
        match realism {
            Realism::Clean => World::clean(),
            _ => World { realism, sensors: TRAIN_SENSORS.to_vec(), mount_compliance_um_per_n: None, print_seed: None },
        }
    }

    /// Training scans at `realism` made by `builds` in place of the training builds (a model
    /// that must hold on new sensors trained on more of them). Refuses an empty list, a build
    /// kept for validation ([`HELD_OUT_BUILDS`]) or test ([`TEST_SENSORS`]), and `clean` (one
    /// build by definition).
    pub fn train_on(realism: Realism, builds: &[u64]) -> Result<World> {
        let setting = |expected| crate::Error::Setting { name: "train_builds", value: format!("{builds:?}"), expected };
        if builds.is_empty() {
            return Err(setting("at least one sensor build"));
        }
        if builds.iter().any(|b| HELD_OUT_BUILDS.contains(b) || TEST_SENSORS.contains(b) || SEALED_SENSORS.contains(b))
        {
            return Err(setting(
                "builds outside 51-60 (validation), 101-102 (test) and 201-202 (sealed): they never train",
            ));
        }
        if realism == Realism::Clean {
            return Err(setting("a realism with sensor builds: `clean` has one"));
        }
        Ok(World { realism, sensors: builds.to_vec(), mount_compliance_um_per_n: None, print_seed: None })
    }

    /// Validation scans on builds never trained or tested on ([`VALIDATION_SENSORS`]; `clean` has
    /// one).
    pub fn validation(realism: Realism) -> World {
        match realism {
            Realism::Clean => World::clean(),
            _ => World {
                realism,
                sensors: VALIDATION_SENSORS.to_vec(),
                mount_compliance_um_per_n: None,
                print_seed: None,
            },
        }
    }

    /// Test scans at `realism`: builds never trained on ([`TEST_SENSORS`]; `clean` has one).
    pub fn test(realism: Realism) -> World {
        match realism {
            Realism::Clean => World::clean(),
            _ => World { realism, sensors: TEST_SENSORS.to_vec(), mount_compliance_um_per_n: None, print_seed: None },
        }
    }

    /// The sealed test set's world at `realism`: the test boards printed anew (their tolerances
    /// from [`SEALED_SEED`]), scanned by builds no run has read ([`SEALED_SENSORS`]; `clean` has
    /// one build, printed anew). Its scans take [`SEALED_SEED`]. Only a report's `--final` run
    /// reads it.
    pub fn sealed(realism: Realism) -> World {
        let sensors = if realism == Realism::Clean { vec![1] } else { SEALED_SENSORS.to_vec() };
        World { realism, sensors, mount_compliance_um_per_n: None, print_seed: Some(SEALED_SEED) }
    }

    /// The preset's setup, with the mount in place of its own when one is given.
    pub fn setup(&self) -> Setup {
        let mut setup = self.realism.setup();
        if let Some(c) = self.mount_compliance_um_per_n {
            setup.scan.stick_slip = (c > 0.0).then(|| sim::StickSlip::light_mount_with_compliance(c));
        }
        setup
    }

    /// This world with the mount's compliance set (see [`World::mount_compliance_um_per_n`]).
    pub fn with_mount(self, compliance_um_per_n: Option<f64>) -> World {
        World { mount_compliance_um_per_n: compliance_um_per_n, ..self }
    }

    /// The sensor build that scans trial `trial`.
    pub fn sensor_seed(&self, trial: u64) -> u64 {
        if self.sensors.is_empty() { 1 } else { self.sensors[(trial % self.sensors.len() as u64) as usize] }
    }

    /// Every build of this world at `resolution`, in the order of `sensors`.
    pub fn sensors_at(&self, setup: &Setup, resolution: encoders::Resolution) -> Result<Vec<Sensor>> {
        let seeds = if self.sensors.is_empty() { vec![1] } else { self.sensors.clone() };
        seeds.iter().map(|&s| Ok(setup.sensor(resolution, s)?)).collect()
    }

    /// A board printed as this world prints (its tolerances from the board's own seed, or from
    /// the world's print seed).
    pub fn board(&self, setup: &Setup, kind: &BoardKind) -> Result<Board> {
        let own = Board::default_seed(kind);
        let seed = self.print_seed.map_or(own, |p| sim::board::stable_hash(&format!("print/{p}/{own}")));
        Ok(Board::new(kind.clone(), setup.geometry.clone(), seed)?)
    }

    /// The seed of one scan. Beyond `clean` (which keeps its old seeds for regression) it depends
    /// on everything that makes a scan: board, row, trial, speed, depth, sensor and preset, so no
    /// two conditions share a scan.
    #[allow(clippy::too_many_arguments)]
    pub fn scan_seed(
        &self,
        seed: u64,
        board: &BoardKind,
        row: usize,
        trial: u64,
        speed_mm_s: f64,
        depth_mm: f64,
    ) -> u64 {
        match self.realism {
            Realism::Clean => scan_seed(seed, board, row, trial),
            r => sim::board::stable_hash(&format!(
                "scan/{r}/{seed}/{}/{row}/{trial}/{speed_mm_s}/{depth_mm}/{}",
                board.name(),
                self.sensor_seed(trial)
            )),
        }
    }
}

/// The seed of one trial of one row (`braille simulate`, `braille label-check`).
pub fn trial_seed(seed: u64, row: usize, trial: u64) -> u64 {
    sim::board::stable_hash(&format!("{seed}/{row}/{trial}"))
}

/// A stable seed per scan.
pub fn scan_seed(seed: u64, board: &BoardKind, row: usize, trial: u64) -> u64 {
    sim::board::stable_hash(&format!("chars/{seed}/{}/{row}/{trial}", board.name()))
}

/// The validation seed: the VAL board's print and the validation scans (docs/protocol.md).
pub const VALIDATION_SEED: u64 = 2_000_003;

/// The scans of the simulated tests (the seed Table I, the depth curve and the words table test on).
/// Read many times while the readers were developed: the development test sets.
pub const TEST_SEED: u64 = 1_000_003;

/// The sealed test sets' scans and print ([`World::sealed`]): no run before the first `--final`
/// read drew from it.
pub const SEALED_SEED: u64 = 3_000_017;

/// The scan seed of a study's own read of the sealed world (`braille eval chars --final`), apart
/// from the reports' ([`SEALED_SEED`]): the same sealed boards and builds, scans no report reads.
pub const SEALED_STUDY_SEED: u64 = 3_000_019;

/// The scan seed of the robustness sweep's read of the sealed world (`braille sim robustness
/// --final`): scans no other read draws.
pub const SEALED_SWEEP_SEED: u64 = 3_000_023;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clean_keeps_its_seeds_and_other_worlds_seed_every_condition_apart() {
        let clean = World::clean();
        assert_eq!(clean.scan_seed(5, &BoardKind::Rab, 1, 2, 8.0, 1.5), scan_seed(5, &BoardKind::Rab, 1, 2));
        assert_eq!(clean.scan_seed(5, &BoardKind::Rab, 1, 2, 32.0, 0.2), scan_seed(5, &BoardKind::Rab, 1, 2));
        let test = World::test(Realism::Nominal);
        let base = test.scan_seed(5, &BoardKind::Rab, 1, 2, 8.0, 1.5);
        for other in [
            test.scan_seed(5, &BoardKind::Rab, 1, 2, 32.0, 1.5),
            test.scan_seed(5, &BoardKind::Rab, 1, 2, 8.0, 1.0),
            test.scan_seed(5, &BoardKind::Rab, 1, 3, 8.0, 1.5),
            test.scan_seed(5, &BoardKind::Sab, 1, 2, 8.0, 1.5),
            World::train(Realism::Nominal).scan_seed(5, &BoardKind::Rab, 1, 2, 8.0, 1.5),
            World::test(Realism::Harsh).scan_seed(5, &BoardKind::Rab, 1, 2, 8.0, 1.5),
        ] {
            assert_ne!(base, other);
        }
        // Training, validation and test builds never meet.
        let (train, test) = (World::train(Realism::Nominal), World::test(Realism::Nominal));
        let val = World::of(Realism::Nominal, SensorBuilds::Validation);
        assert!((0..8).all(|t| !test.sensors.contains(&train.sensor_seed(t))));
        assert!(
            (0..8).all(|t| !test.sensors.contains(&val.sensor_seed(t)) && !train.sensors.contains(&val.sensor_seed(t)))
        );
        assert_ne!(base, val.scan_seed(5, &BoardKind::Rab, 1, 2, 8.0, 1.5));
        assert_eq!(World::train(Realism::Clean), World::test(Realism::Clean));
    }

    #[test]
    fn build_lists_read_numbers_and_ranges() {
        assert_eq!(parse_builds("1-4,7, 20-22").expect("a list"), [1, 2, 3, 4, 7, 20, 21, 22]);
        assert_eq!(parse_builds("9").expect("one"), [9]);
        for list in [&[1, 2, 3, 4, 7, 20, 21, 22][..], &[9], &[5, 3, 4], &[]] {
            let text = format_builds(list);
            if !list.is_empty() {
                assert_eq!(parse_builds(&text).expect("its own format"), list, "{text}");
            }
        }
        assert_eq!(format_builds(&[1, 2, 3, 4, 7, 20, 21, 22]), "1-4,7,20-22");
        for bad in ["", "4-1", "a", "1-", "1,,2", "-3"] {
            assert!(parse_builds(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn more_training_builds_never_take_a_held_out_one() {
        let w = World::train_on(Realism::Nominal, &[1, 2, 5, 24]).expect("unused builds train");
        assert_eq!((0..4).map(|t| w.sensor_seed(t)).collect::<Vec<_>>(), [1, 2, 5, 24]);
        // the same trial on another build is another scan
        let base = World::train(Realism::Nominal);
        assert_ne!(w.scan_seed(5, &BoardKind::Sab, 0, 2, 8.0, 1.5), base.scan_seed(5, &BoardKind::Sab, 0, 2, 8.0, 1.5));
        for bad in [&[1, 51][..], &[60], &[101], &[102, 3], &[]] {
            let e = World::train_on(Realism::Nominal, bad).expect_err("held out or empty");
            assert!(e.to_string().contains("train_builds"), "{e}");
        }
        assert!(World::train_on(Realism::Clean, &[1, 2]).is_err());
        assert!(World::train_on(Realism::Nominal, &[50, 61, 100, 103]).is_ok());
    }
}
