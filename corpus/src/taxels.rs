//! A tactile dataset of another layout, made by the simulator: each Braille character's passage
//! over a small grid of event taxels, written in the folder layout of `data/icub_braille`
//! (`samples.csv`, `events.csv`, `split.csv`). SIMULATED data.
//!
//! It exists to check that what `braille train --data DIR` derives from a dataset, and its
//! search, are not specific to the iCub sets: the taxel count, the sample durations, the event
//! rates and the class count all differ from theirs. The taxels are a patch of the virtual
//! Evetac's pixels, each a coarse event sensor: a taxel sends an event of a polarity each time
//! `pixel_events_per_event` pixel events of that polarity have arrived in it since its last one.
//! Samples are cut by the simulator's truth (a dataset is labelled data): the time the cell's
//! centre passes the patch's centre, plus and minus the travel that takes any of the cell's dots
//! through the patch, at the scan's mean speed. Every scan draws its speed from a range, so the
//! samples' durations differ.

use crate::windows::class_of;
use crate::world::World;
use crate::{Error, Progress, Result};
use encoders::{Polarity, Resolution};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sim::BoardKind;
use std::io::Write;
use std::path::Path;

/// What to simulate and how to pool it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaxelSetSpec {
    /// Boards of the training split (every row, `train_trials` scans each).
    pub train_boards: Vec<BoardKind>,
    pub train_trials: u64,
    /// Boards of the test split.
    pub test_boards: Vec<BoardKind>,
    pub test_trials: u64,
    /// Each scan's speed is drawn uniformly from this range, mm/s.
    pub speed_range_mm_s: (f64, f64),
    pub depth_mm: f64,
    /// Taxels across (along the slide) and down.
    pub taxels_x: usize,
    pub taxels_y: usize,
    /// The patch the taxels tile, centred on the sensor, mm (across, down).
    pub patch_mm: (f64, f64),
    /// A taxel's event threshold: pixel events of one polarity per taxel event.
    pub pixel_events_per_event: u32,
    /// Training scans come from `World::train(realism)`'s sensor builds, test scans from
    /// `World::test(realism)`'s: the test split is another sensor build, as a new robot's skin.
    pub realism: sim::Realism,
    pub seed: u64,
}

impl Default for TaxelSetSpec {
    /// 5 x 4 taxels of 1.2 x 2 mm (a fingertip-sized patch of 6 x 8 mm); the sequential alphabet
    /// board (SAB) 40 times for training and the random one (RAB) 10 times for test, about 40
    /// and 10 samples per letter; speeds 10-30 mm/s; 1.5 mm deep; `nominal`.
    fn default() -> Self {
        TaxelSetSpec {
            train_boards: vec![BoardKind::Sab],
            train_trials: 40,
            test_boards: vec![BoardKind::Rab],
            test_trials: 10,
            speed_range_mm_s: (10.0, 30.0),
            depth_mm: 1.5,
            taxels_x: 5,
            taxels_y: 4,
            patch_mm: (6.0, 8.0),
            pixel_events_per_event: 256,
            realism: sim::Realism::Nominal,
            seed: 1,
        }
    }
}

/// One sample: a character's passage over the taxels.
#[derive(Debug, Clone, PartialEq)]
pub struct TaxelSample {
    pub letter: char,
    pub test: bool,
    /// (taxel, ON, seconds from the sample's start), in time order.
    pub events: Vec<(u16, bool, f64)>,
    pub duration_s: f64,
    pub speed_mm_s: f64,
}

/// What was written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaxelSummary {
    pub spec: TaxelSetSpec,
    pub train_samples: usize,
    pub test_samples: usize,
    pub taxels: usize,
    pub classes: usize,
    pub mean_events_per_sample: f64,
    pub duration_s_min: f64,
    pub duration_s_max: f64,
    /// Samples with no event at all (kept: a dataset keeps what the sensor gave).
    pub empty_samples: usize,
}

/// What `braille sim dataset` prints after the folder's name.
impl std::fmt::Display for TaxelSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "SIMULATED ({} realism), {} taxels, {} classes, {} training and {} test samples, {:.0} events per sample on average ({} with none), {:.2}-{:.2} s long",
            self.spec.realism,
            self.taxels,
            self.classes,
            self.train_samples,
            self.test_samples,
            self.mean_events_per_sample,
            self.empty_samples,
            self.duration_s_min,
            self.duration_s_max
        )
    }
}

/// The events of a scan's characters on the taxel grid.
fn scan_samples(spec: &TaxelSetSpec, scan: &sim::Scan, resolution: Resolution, test: bool) -> Vec<TaxelSample> {
    let truth = &scan.truth;
    let mm_per_px = truth.fov_width_mm / f64::from(resolution.width);
    let (cx, cy) = (f64::from(resolution.width) / 2.0, f64::from(resolution.height) / 2.0);
    let (pw, ph) = (spec.patch_mm.0 / mm_per_px, spec.patch_mm.1 / mm_per_px);
    let (x0, y0) = (cx - pw / 2.0, cy - ph / 2.0);
    let (tw, th) = (pw / spec.taxels_x as f64, ph / spec.taxels_y as f64);
    // A cell is 2.5 mm wide: any of its dots is in the patch while the cell's centre is within
    // (patch + cell) / 2 of the patch's centre.
    let half_travel_mm = (spec.patch_mm.0 + 2.5) / 2.0;
    let v = truth.scan.speed_mm_s;
    let mut out = Vec::new();
    for c in &truth.characters {
        let (Some(t_c), true) = (c.t_cell_center_s, class_of(c.letter).is_some()) else { continue };
        let (t0, t1) = (t_c - half_travel_mm / v, t_c + half_travel_mm / v);
        let (t0_us, t1_us) = ((t0 * 1e6).round() as i64, (t1 * 1e6).round() as i64);
        let from = scan.events.partition_point(|e| e.t_us < t0_us);
        let mut counts = vec![0u32; spec.taxels_x * spec.taxels_y * 2];
        let mut events = Vec::new();
        for e in scan.events[from..].iter().take_while(|e| e.t_us < t1_us) {
            let (fx, fy) = ((f64::from(e.x) + 0.5 - x0) / tw, (f64::from(e.y) + 0.5 - y0) / th);
            if fx < 0.0 || fy < 0.0 || fx >= spec.taxels_x as f64 || fy >= spec.taxels_y as f64 {
                continue;
            }
            let taxel = fy as usize * spec.taxels_x + fx as usize;
            let on = e.polarity == Polarity::On;
            let k = 2 * taxel + usize::from(on);
            counts[k] += 1;
            if counts[k] == spec.pixel_events_per_event {
                counts[k] = 0;
                events.push((taxel as u16, on, (e.t_us - t0_us) as f64 * 1e-6));
            }
        }
        let duration_s = (t1_us - t0_us) as f64 * 1e-6;
        out.push(TaxelSample { letter: c.letter, test, events, duration_s, speed_mm_s: v });
    }
    out
}

/// Simulates the scans of `spec` and returns their samples, training split first, each split in
/// a fixed order (the same seed gives the same samples).
pub fn taxel_samples(spec: &TaxelSetSpec, progress: &dyn Progress) -> Result<Vec<TaxelSample>> {
    if spec.taxels_x == 0 || spec.taxels_y == 0 || spec.pixel_events_per_event == 0 {
        return Err(Error::Setting {
            name: "taxel grid and pixel events per event",
            value: format!("{} x {}, {}", spec.taxels_x, spec.taxels_y, spec.pixel_events_per_event),
            expected: "each at least 1",
        });
    }
    let (lo, hi) = spec.speed_range_mm_s;
    if !(lo > 0.0 && hi >= lo) {
        return Err(Error::Setting {
            name: "speed range (mm/s)",
            value: format!("{lo}-{hi}"),
            expected: "0 < low <= high",
        });
    }
    let resolution = Resolution::DVXPLORER;
    // Each split's world, sensor builds and boards once; a job names them by index.
    let mut splits = Vec::new();
    let mut jobs = Vec::new();
    for (test, boards, trials) in
        [(false, &spec.train_boards, spec.train_trials), (true, &spec.test_boards, spec.test_trials)]
    {
        let world = if test { World::test(spec.realism) } else { World::train(spec.realism) };
        let setup = world.setup();
        let sensors = world.sensors_at(&setup, resolution)?;
        let boards = boards.iter().map(|kind| world.board(&setup, kind)).collect::<Result<Vec<_>>>()?;
        for (b, board) in boards.iter().enumerate() {
            for row in 0..board.rows.len() {
                jobs.extend((0..trials).map(|trial| (splits.len(), b, row, trial)));
            }
        }
        splits.push((test, world, setup, sensors, boards));
    }
    progress.start("simulating taxel scans", jobs.len() as u64);
    let per_scan: Vec<Vec<TaxelSample>> = jobs
        .par_iter()
        .map(|&(split, b, row, trial)| -> Result<_> {
            let (test, world, setup, sensors, boards) = &splits[split];
            let board = &boards[b];
            let key = format!("taxels/{}/{}/{row}/{trial}/{test}", spec.seed, board.kind.name());
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(sim::board::stable_hash(&key));
            let speed = if hi > lo { rng.random_range(lo..hi) } else { lo };
            let seed = world.scan_seed(spec.seed, &board.kind, row, trial, speed, spec.depth_mm);
            let scan = setup.scan(speed, spec.depth_mm, row, seed);
            let sensor = &sensors[(trial % sensors.len() as u64) as usize];
            let s = sim::simulate(board, sensor, &scan)?;
            progress.inc();
            Ok(scan_samples(spec, &s, resolution, *test))
        })
        .collect::<Result<_>>()?;
    progress.finish();
    Ok(per_scan.into_iter().flatten().collect())
}

/// Writes `samples` as a dataset folder in the iCub event layout; existing files are kept
/// unless `force`. Labels are letter indices (`A` = 0).
pub fn write_taxel_dataset(dir: &Path, samples: &[TaxelSample], force: bool) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
    let write = |name: &str, body: &dyn Fn(&mut dyn Write) -> std::io::Result<()>| -> Result<()> {
        let path = dir.join(name);
        let mut f = encoders::formats::AtomicFile::create(&path, force)?;
        body(&mut f).map_err(|source| Error::Io { path: path.clone(), source })?;
        Ok(f.commit()?)
    };
    write("samples.csv", &|f| {
        writeln!(f, "sample,letter,label,n_events,first_event_row")?;
        let mut row = 0;
        for (i, s) in samples.iter().enumerate() {
            let label = class_of(s.letter).unwrap_or_default();
            writeln!(f, "{i},{},{label},{},{row}", s.letter, s.events.len())?;
            row += s.events.len();
        }
        Ok(())
    })?;
    write("events.csv", &|f| {
        writeln!(f, "sample,taxel,pol,t_s")?;
        for (i, s) in samples.iter().enumerate() {
            for &(taxel, on, t) in &s.events {
                writeln!(f, "{i},{taxel},{},{t}", u8::from(on))?;
            }
        }
        Ok(())
    })?;
    write("split.csv", &|f| {
        writeln!(f, "sample,split")?;
        for (i, s) in samples.iter().enumerate() {
            writeln!(f, "{i},{}", if s.test { "test" } else { "train" })?;
        }
        Ok(())
    })
}

/// Simulates `spec`'s samples and writes them to `dir` with `dataset.json` (the spec and the
/// summary).
pub fn make_taxel_dataset(
    spec: &TaxelSetSpec,
    dir: &Path,
    force: bool,
    progress: &dyn Progress,
) -> Result<TaxelSummary> {
    let samples = taxel_samples(spec, progress)?;
    write_taxel_dataset(dir, &samples, force)?;
    let n = samples.len().max(1) as f64;
    let durations = samples.iter().map(|s| s.duration_s);
    let summary = TaxelSummary {
        spec: spec.clone(),
        train_samples: samples.iter().filter(|s| !s.test).count(),
        test_samples: samples.iter().filter(|s| s.test).count(),
        taxels: spec.taxels_x * spec.taxels_y,
        classes: {
            let mut c: Vec<char> = samples.iter().map(|s| s.letter).collect();
            c.sort_unstable();
            c.dedup();
            c.len()
        },
        mean_events_per_sample: samples.iter().map(|s| s.events.len() as f64).sum::<f64>() / n,
        duration_s_min: durations.clone().fold(f64::INFINITY, f64::min),
        duration_s_max: durations.fold(0.0, f64::max),
        empty_samples: samples.iter().filter(|s| s.events.is_empty()).count(),
    };
    crate::write_json(&dir.join("dataset.json"), &summary, force)?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(pixel_events_per_event: u32) -> TaxelSetSpec {
        TaxelSetSpec {
            train_trials: 1,
            test_trials: 1,
            speed_range_mm_s: (24.0, 32.0),
            taxels_x: 3,
            taxels_y: 2,
            pixel_events_per_event,
            ..TaxelSetSpec::default()
        }
    }

    /// Events per (sample, taxel, polarity).
    fn counts(samples: &[TaxelSample]) -> Vec<[[usize; 2]; 6]> {
        samples
            .iter()
            .map(|s| {
                let mut c = [[0; 2]; 6];
                for &(taxel, on, _) in &s.events {
                    c[taxel as usize][usize::from(on)] += 1;
                }
                c
            })
            .collect()
    }

    #[test]
    fn every_printed_letter_is_a_sample_and_a_taxel_fires_once_per_threshold() {
        let one = taxel_samples(&small(1), &()).unwrap();
        // SAB and RAB print the alphabet once each: 26 training and 26 test samples.
        assert_eq!(one.iter().filter(|s| !s.test).count(), 26);
        assert_eq!(one.iter().filter(|s| s.test).count(), 26);
        for s in &one {
            assert!(s.events.windows(2).all(|w| w[0].2 <= w[1].2), "time order");
            assert!(s.events.iter().all(|e| (0.0..s.duration_s).contains(&e.2) && e.0 < 6));
            assert!((24.0..32.0).contains(&s.speed_mm_s));
            let travel_mm = s.duration_s * s.speed_mm_s;
            assert!((travel_mm - 8.5).abs() < 1e-3, "the cell's travel through the patch: {travel_mm}");
        }
        assert!(one.iter().all(|s| !s.events.is_empty()), "every character touches the taxels");
        // A threshold of 4 pixel events gives a quarter of the events, taxel by taxel.
        let four = taxel_samples(&small(4), &()).unwrap();
        for (a, b) in counts(&one).iter().zip(counts(&four)) {
            for (ta, tb) in a.iter().zip(b) {
                assert_eq!([ta[0] / 4, ta[1] / 4], tb);
            }
        }
        assert_eq!(taxel_samples(&small(4), &()).unwrap(), four, "same seed, same samples");
    }

    #[test]
    fn the_folder_loads_as_a_dataset() {
        let spec = TaxelSetSpec { test_boards: vec![], ..small(64) };
        let dir = tempfile::tempdir().unwrap();
        let summary = make_taxel_dataset(&spec, dir.path(), false, &()).unwrap();
        assert_eq!((summary.train_samples, summary.test_samples, summary.classes), (26, 0, 26));
        let ds = encoders::dataset::Dataset::load(dir.path(), 25_000).unwrap();
        assert_eq!(ds.samples.len(), 26);
        assert_eq!(ds.classes[0], "A");
        assert!(make_taxel_dataset(&spec, dir.path(), false, &()).is_err(), "existing files are kept");
    }
}
