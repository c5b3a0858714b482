//! Why the first word of a row reads worse than the rest (issue #47), on the validation board
//! only: VAL-LETTERS scanned by builds that are not the test builds at the validation seed, read
//! by a `nominal` reader (the speed given, so the speed estimate is out of it, or estimated, as
//! shipped), with the simulator's per-scan nuisances as drawn, and again with one of them
//! switched off: the row's yaw, the depth's tilt along the row, the lateral misalignment. Per
//! variant: the first word right (raw letters, no spelling) against the later words, and for the
//! scans as drawn, the first word's rate per build and by the drawn yaw's size, and every missed
//! first word with its scan's yaw.
//!
//! `cargo run --release -p experiments --example row_start [trials] [speed_mm_s] [depth_mm]
//! [classifier] [builds] [arch] [variants] [timing]` (defaults 4, 16, 1.0, `-`: the
//! architecture's shipped classifier, `training` builds (or `validation`: builds 51 and 52, held
//! out of training and test; or a range `A-B` of build seeds, e.g. `53-60`, builds no model was
//! trained, chosen or tested on; the test builds 101 and 102 are refused), `snn` (or `resnet`),
//! every variant (or a comma list of `as-drawn`, `no-yaw`, `no-tilt`, `no-misalignment`), and
//! `given` (the speed told: an oracle) or `estimated` (the reader as shipped); about 2 minutes a
//! variant on two cores at the defaults). Scan `t` of a row is read by build `t mod builds`; with
//! more than one build the first word's rate is printed per build.

use corpus::boards::{HeldOut, all_letters_board};
use corpus::world::{SensorBuilds, VALIDATION_SEED, World};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{Spell, Speller, Timing};
use rayon::prelude::*;
use sim::Realism;

/// One scan: the drawn yaw (degrees) and misalignment (mm), first word right, later words right
/// of later words printed (aligned from the row's end).
struct Outcome {
    build: usize,
    row: usize,
    /// The first word printed and the words read (for the misses' list).
    truth: String,
    read: String,
    yaw_deg: f64,
    misalignment_mm: f64,
    first: bool,
    later: (usize, usize),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Variant {
    AsDrawn,
    NoYaw,
    NoTilt,
    NoMisalignment,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let trials: u64 = args.get(1).map_or(Ok(4), |a| a.parse())?;
    let speed: f64 = args.get(2).map_or(Ok(16.0), |a| a.parse())?;
    let depth: f64 = args.get(3).map_or(Ok(1.0), |a| a.parse())?;
    let builds_name = args.get(5).map_or("training", String::as_str);
    let world = match builds_name {
        "training" => World::of(Realism::Nominal, SensorBuilds::Training),
        "validation" => World::of(Realism::Nominal, SensorBuilds::Validation),
        range => {
            let bad = || format!("builds {range:?}: training, validation or a range A-B of build seeds");
            let (a, b) = range.split_once('-').ok_or_else(bad)?;
            let (a, b): (u64, u64) = (a.parse().map_err(|_| bad())?, b.parse().map_err(|_| bad())?);
            if a > b || (a..=b).any(|s| corpus::world::TEST_SENSORS.contains(&s)) {
                return Err(
                    format!("builds {range:?}: an increasing range without the test builds (the reports')").into()
                );
            }
            World { sensors: (a..=b).collect(), ..World::of(Realism::Nominal, SensorBuilds::Validation) }
        }
    };
    let given = match args.get(8).map_or("given", String::as_str) {
        "given" => true,
        "estimated" => false,
        other => return Err(format!("timing {other:?}: given or estimated").into()),
    };
    let arch = match args.get(6).map_or("snn", String::as_str) {
        "snn" => snn::model_file::Arch::Snn,
        "resnet" => snn::model_file::Arch::Resnet,
        other => return Err(format!("arch {other:?}: snn or resnet").into()),
    };
    let all = [Variant::AsDrawn, Variant::NoYaw, Variant::NoTilt, Variant::NoMisalignment];
    let variants: Vec<Variant> = match args.get(7) {
        None => all.to_vec(),
        Some(list) => list
            .split(',')
            .map(|v| match v {
                "as-drawn" => Ok(Variant::AsDrawn),
                "no-yaw" => Ok(Variant::NoYaw),
                "no-tilt" => Ok(Variant::NoTilt),
                "no-misalignment" => Ok(Variant::NoMisalignment),
                other => Err(format!("variant {other:?}: as-drawn, no-yaw, no-tilt or no-misalignment")),
            })
            .collect::<Result<_, _>>()?,
    };
    let setup = world.setup();
    let kind = all_letters_board(HeldOut::Validation);
    let board = world.board(&setup, &kind)?;
    let sensors = world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
    let shipped = pipeline::shipped::reader_in("models/nominal".as_ref(), arch);
    let classifier = match args.get(4).map(String::as_str) {
        None | Some("-") => shipped.classifier.clone(),
        Some(path) => path.into(),
    };
    let models = ReaderModels::load(&shipped.segmenter, &classifier, SnnRunner::Sliding)?;
    let speller = Speller::new(Spell::None);
    let jobs: Vec<(usize, u64)> = (0..board.rows.len()).flat_map(|r| (0..trials).map(move |t| (r, t))).collect();
    println!(
        "VAL-LETTERS, builds {:?}, seed {VALIDATION_SEED}, {speed} mm/s, {depth} mm, {} scans, {arch:?} reader ({}), speed {}, no spelling",
        world.sensors,
        jobs.len(),
        classifier.display(),
        if given { "given" } else { "estimated" }
    );
    for variant in variants {
        let outcomes: Vec<Outcome> = jobs
            .par_iter()
            .map(|&(row, trial)| -> Result<Outcome, String> {
                let seed = world.scan_seed(VALIDATION_SEED, &kind, row, trial, speed, depth);
                let sensor = &sensors[(trial % sensors.len() as u64) as usize];
                let mut scan = setup.scan(speed, depth, row, seed);
                match variant {
                    Variant::AsDrawn => {}
                    Variant::NoYaw => scan.yaw_sigma_deg = 0.0,
                    Variant::NoTilt => scan.depth_tilt_sigma_mm_per_100mm = 0.0,
                    Variant::NoMisalignment => scan.misalignment_sigma_mm = 0.0,
                }
                let s = sim::simulate(&board, sensor, &scan).map_err(|e| e.to_string())?;
                let timing =
                    if given { Timing::Given { speed_mm_s: speed } } else { Timing::Estimated { hint_mm_s: None } };
                let read =
                    models.read(&s.events, sensor.camera.resolution, timing, &speller).map_err(|e| e.to_string())?;
                let truth: Vec<&str> = s.truth.row_text.split_whitespace().collect();
                let words: Vec<&str> = read.words.iter().map(|w| w.raw.as_str()).collect();
                let first = words.first() == truth.first();
                let later = (1..truth.len())
                    .filter(|&k| {
                        let from_end = truth.len() - k;
                        words.len() > from_end && words[words.len() - from_end] == truth[k]
                    })
                    .count();
                Ok(Outcome {
                    build: (trial % sensors.len() as u64) as usize,
                    row,
                    truth: truth.first().map_or(String::new(), |w| w.to_string()),
                    read: words.join(" "),
                    yaw_deg: s.truth.yaw_deg,
                    misalignment_mm: s.truth.misalignment_mm,
                    first,
                    later: (later, truth.len() - 1),
                })
            })
            .collect::<Result<_, String>>()?;
        let n = outcomes.len() as f64;
        let first = outcomes.iter().filter(|o| o.first).count() as f64 / n;
        let (right, printed) = outcomes.iter().fold((0, 0), |(a, b), o| (a + o.later.0, b + o.later.1));
        let name = match variant {
            Variant::AsDrawn => "as drawn",
            Variant::NoYaw => "no yaw",
            Variant::NoTilt => "no depth tilt",
            Variant::NoMisalignment => "no misalignment",
        };
        println!(
            "{name}: first word {:.1}%, later words {:.1}% ({right} of {printed})",
            100.0 * first,
            100.0 * right as f64 / printed as f64
        );
        if variant == Variant::AsDrawn {
            if world.sensors.len() > 1 {
                for (b, seed) in world.sensors.iter().enumerate() {
                    let of: Vec<&Outcome> = outcomes.iter().filter(|o| o.build == b).collect();
                    let (right, printed) = of.iter().fold((0, 0), |(a, c), o| (a + o.later.0, c + o.later.1));
                    println!(
                        "  build {seed}: first word {} of {}, later words {right} of {printed}",
                        of.iter().filter(|o| o.first).count(),
                        of.len()
                    );
                }
            }
            for o in outcomes.iter().filter(|o| !o.first) {
                println!(
                    "  missed: row {} build {} yaw {:+.2} deg misalignment {:+.2} mm: {} read as \"{}\"",
                    o.row, world.sensors[o.build], o.yaw_deg, o.misalignment_mm, o.truth, o.read
                );
            }
            for (what, key) in [
                ("|yaw|", Box::new(|o: &Outcome| o.yaw_deg.abs()) as Box<dyn Fn(&Outcome) -> f64>),
                ("|misalignment|", Box::new(|o: &Outcome| o.misalignment_mm.abs())),
            ] {
                let mut sorted: Vec<&Outcome> = outcomes.iter().collect();
                sorted.sort_by(|a, b| key(a).total_cmp(&key(b)));
                for (k, third) in sorted.chunks(sorted.len().div_ceil(3)).enumerate() {
                    let rate = third.iter().filter(|o| o.first).count() as f64 / third.len() as f64;
                    println!(
                        "  {what} third {} ({:.2} to {:.2}): first word {:.1}% of {}",
                        k + 1,
                        key(third[0]),
                        key(third[third.len() - 1]),
                        100.0 * rate,
                        third.len()
                    );
                }
            }
        }
    }
    Ok(())
}
