//! A reader's operating point, chosen on validation data (`braille calibrate-reader`): the
//! segmentation network's threshold and the temporal filter's shortest segment
//! ([`OperatingPoint`]), swept over a grid on SIMULATED scans of the validation words with the
//! training sensor builds and the validation seed, never a test board (docs/protocol.md).
//!
//! Every point of the grid reads the same scans with the real streaming reader, speed estimated
//! from the events. The networks' outputs do not depend on the point (the reader's frames come
//! from the events and its speed estimate alone), so each scan's outputs are computed once and
//! looked up by window for the other points ([`Memo`]). The rest of a reading (its frames, the
//! speed estimate, the filter, the spelling) runs at every point: sampled on 2026-11-28, the
//! speed estimate and the reader's loop took over 80% of a grid's time, so a grid of N points
//! costs far more than one reading (VAL-UEB's 378 scans, 25 points, two readers: 13 minutes on
//! two cores).
//!
//! The rule, fixed before any run: the highest mean word accuracy (1 - WER, so an inserted word
//! counts against a point) without spelling over the speeds (every printed word counts; the
//! reading itself, which a speller can hide), ties to the higher mean with the lexicon, then to
//! the point nearer the paper's. Before 2026-11-26 the rule measured percent correct (blind to
//! inserted words); a model file's recorded `rule` says which.

pub mod abstain;
pub mod job;

use crate::Progress;
use crate::Result;
use crate::eval::scoring::WordMetrics;
use corpus::boards::{HeldOut, validation_words_board};
use corpus::world::{VALIDATION_SEED, World};
use pipeline::classify::{ReaderModels, WindowModel, WindowState};
use pipeline::code::BrailleCode;
use pipeline::reader::{
    CalibrationGrid, OperatingPoint, PointCalibration, ReaderConfig, Spell, Speller, Timing, Window, WindowClassifier,
    f32_as_printed, read_all,
};
use rayon::prelude::*;
use serde::Serialize;
use sim::{BoardKind, Realism};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::Path;

/// Which scans and which grid.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationSpec {
    pub board: BoardKind,
    pub world: World,
    pub seed: u64,
    /// Scans per board row and speed.
    pub trials: u64,
    pub speeds_mm_s: Vec<f64>,
    pub depth_mm: f64,
    pub thresholds: Vec<f32>,
    pub min_frames: Vec<usize>,
    /// The Braille code the board is printed in; beyond the paper's letters the reader reads
    /// cells, and its words are the cells back-translated through the code.
    pub code: BrailleCode,
    /// The board's rows as printed (a code's print board; empty for the letters, whose scans'
    /// text is the print): the words each row is scored against.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub print_rows: Vec<String>,
}

impl CalibrationSpec {
    /// The validation words (`VAL-WORDS`) at `realism` with the training sensor builds and the
    /// validation seed, 12 scans per row at 8, 16, 32 and 64 mm/s, 1.5 mm; thresholds 0.3-0.95
    /// and shortest segments of 2-12 frames (the paper's 0.5 and 4 among them).
    pub fn validation(realism: Realism) -> CalibrationSpec {
        CalibrationSpec {
            board: validation_words_board(),
            world: World::train(realism),
            seed: VALIDATION_SEED,
            trials: 12,
            speeds_mm_s: vec![8.0, 16.0, 32.0, 64.0],
            depth_mm: 1.5,
            thresholds: vec![0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95],
            min_frames: vec![2, 3, 4, 5, 6, 8, 10, 12],
            code: BrailleCode::Grade1Letters,
            print_rows: Vec::new(),
        }
    }

    /// A code's validation sentences (`VAL-UEB`, printed in `code`) at `realism` with the
    /// training sensor builds and the validation seed, 3 scans per row at 8, 16 and 32 mm/s, 1.0
    /// mm (the conditions of the UEB tables), and the letters' grid. The letters' spec for
    /// [`BrailleCode::Grade1Letters`].
    pub fn validation_in(realism: Realism, code: BrailleCode) -> Result<CalibrationSpec> {
        if code == BrailleCode::Grade1Letters {
            return Ok(CalibrationSpec::validation(realism));
        }
        let board = corpus::boards::sentence_board(HeldOut::Validation, code)?;
        Ok(CalibrationSpec {
            board: board.kind,
            trials: 3,
            speeds_mm_s: vec![8.0, 16.0, 32.0],
            depth_mm: 1.0,
            code,
            print_rows: board.print_rows,
            ..CalibrationSpec::validation(realism)
        })
    }
}

/// One point of the grid, scored.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationRow {
    pub present_threshold: f32,
    pub min_frames: usize,
    /// Word accuracy (1 - WER) over every printed word per speed, without spelling and with the
    /// lexicon.
    pub none: Vec<f64>,
    pub lexicon: Vec<f64>,
    pub mean_none: f64,
    pub mean_lexicon: f64,
}

impl CalibrationRow {
    /// A point's scores per speed, with their means over the speeds.
    fn of(present_threshold: f32, min_frames: usize, none: Vec<f64>, lexicon: Vec<f64>) -> CalibrationRow {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        CalibrationRow {
            present_threshold,
            min_frames,
            mean_none: mean(&none),
            mean_lexicon: mean(&lexicon),
            none,
            lexicon,
        }
    }
}

/// The grid's scores and the point chosen.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    pub data: &'static str,
    pub segmenter: String,
    pub classifier: String,
    /// The validation scans, in words.
    pub scans: String,
    /// The simulated validation scans' spec (none for a recordings folder).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spec: Option<CalibrationSpec>,
    /// The speeds the scores are grouped by (a folder's commanded speeds).
    pub speeds_mm_s: Vec<f64>,
    /// Printed words per speed (over all scans).
    pub words: Vec<usize>,
    pub rows: Vec<CalibrationRow>,
    pub chosen: OperatingPoint,
    pub rule: &'static str,
}

pub const RULE: &str = "the highest mean word accuracy (1 - WER, all printed words, inserted words counted) without spelling over the speeds, ties to the higher mean with the lexicon, then to the point nearer the paper's (0.5, 4)";

/// A network whose output for each window is computed once and looked up after: the reader's
/// windows (known by their end, bin length and bin count) are the same at every operating point.
/// One per scan (not shared between threads).
pub struct Memo<'m> {
    inner: &'m WindowModel,
    cache: RefCell<HashMap<(i64, i64, usize), Vec<f32>>>,
}

impl<'m> Memo<'m> {
    pub fn new(inner: &'m WindowModel) -> Memo<'m> {
        Memo { inner, cache: RefCell::new(HashMap::new()) }
    }
}

impl WindowClassifier for Memo<'_> {
    type State = WindowState;

    fn new_state(&self) -> WindowState {
        self.inner.new_state()
    }

    fn classify(&self, state: &mut WindowState, window: &Window) -> pipeline::Result<Vec<f32>> {
        let key = (window.t_end_us, window.bin_us, window.n_bins());
        if let Some(p) = self.cache.borrow().get(&key) {
            return Ok(p.clone());
        }
        let p = self.inner.classify(state, window)?;
        self.cache.borrow_mut().insert(key, p.clone());
        Ok(p)
    }
}

/// Sweeps the grid of `spec` for the pair `models` (named `segmenter` and `classifier` in the
/// record) and chooses by [`RULE`].
pub fn calibrate(
    models: &ReaderModels,
    segmenter: &str,
    classifier: &str,
    spec: &CalibrationSpec,
    progress: &dyn Progress,
) -> Result<Calibration> {
    let (_, mut each) = calibrate_shared(&[(models, classifier)], segmenter, spec, progress)?;
    Ok(each.remove(0))
}

/// Sweeps the grid of `spec` for a segmentation network that several classifiers read with
/// (`pairs`: each reader and its classifier's name; the UEB readers of both architectures share
/// one): every scan is simulated once and read by every pair, and one point serves them all, so
/// [`RULE`] is applied to each point's scores averaged over the pairs. Returns that joint
/// calibration (its classifiers' names joined by ` + `) and each pair's own.
pub fn calibrate_shared(
    pairs: &[(&ReaderModels, &str)],
    segmenter: &str,
    spec: &CalibrationSpec,
    progress: &dyn Progress,
) -> Result<(Calibration, Vec<Calibration>)> {
    if pairs.is_empty()
        || spec.thresholds.is_empty()
        || spec.min_frames.is_empty()
        || spec.speeds_mm_s.is_empty()
        || spec.trials == 0
    {
        return Err(crate::Error::Setting {
            name: "calibration grid",
            value: format!(
                "{} readers, {} thresholds, {} frame counts, {} speeds, {} scans",
                pairs.len(),
                spec.thresholds.len(),
                spec.min_frames.len(),
                spec.speeds_mm_s.len(),
                spec.trials
            ),
            expected: "at least one of each",
        });
    }
    let grid = grid_of(&spec.thresholds, &spec.min_frames)?;
    let setup = spec.world.setup();
    let board = spec.world.board(&setup, &spec.board)?;
    if !spec.print_rows.is_empty() && spec.print_rows.len() != board.rows.len() {
        return Err(crate::Error::Setting {
            name: "print_rows",
            value: format!("{} rows of print", spec.print_rows.len()),
            expected: "one per row of the board's cells",
        });
    }
    let sensors = spec.world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
    let jobs: Vec<(usize, usize, u64)> = (0..spec.speeds_mm_s.len())
        .flat_map(|s| (0..board.rows.len()).flat_map(move |r| (0..spec.trials).map(move |t| (s, r, t))))
        .collect();
    let load = |k: usize| -> Result<Scan> {
        let (s, row, trial) = jobs[k];
        let speed = spec.speeds_mm_s[s];
        let seed = spec.world.scan_seed(spec.seed, &spec.board, row, trial, speed, spec.depth_mm);
        let sensor = &sensors[(trial % sensors.len() as u64) as usize];
        let scan = sim::simulate(&board, sensor, &setup.scan(speed, spec.depth_mm, row, seed))?;
        // a code's print is scored against the print, not against its cells
        let printed = spec.print_rows.get(row).unwrap_or(&scan.truth.row_text);
        let truth = printed.split_whitespace().map(str::to_string).collect();
        Ok(Scan { speed: s, events: scan.events, resolution: sensor.camera.resolution, truth })
    };
    let readers: Vec<&ReaderModels> = pairs.iter().map(|p| p.0).collect();
    let reads = read_grid(
        &readers,
        &grid,
        jobs.len(),
        &load,
        spec.code,
        "reading validation scans at every operating point",
        progress,
    )?;
    let scans = format!(
        "SIMULATED validation {}, {} world, sensor builds {:?}, seed {}, {} scans per row at {:?} mm/s, {} mm, speed estimated",
        match spec.code {
            BrailleCode::Grade1Letters => format!("words ({})", spec.board.name()),
            code => format!("sentences ({}), printed in {code}", corpus::boards::board_name(&spec.board)),
        },
        spec.world.realism,
        spec.world.sensors,
        spec.seed,
        spec.trials,
        spec.speeds_mm_s,
        spec.depth_mm
    );
    let each: Vec<Calibration> = pairs
        .iter()
        .zip(reads)
        .map(|(&(_, classifier), reads)| {
            let mut c = choose_point(
                segmenter,
                classifier,
                &grid,
                &spec.speeds_mm_s,
                &reads,
                scans.clone(),
                (&spec.thresholds, &spec.min_frames),
            );
            c.spec = Some(spec.clone());
            c
        })
        .collect();
    let names: Vec<&str> = pairs.iter().map(|p| p.1).collect();
    let mut joint = joint_point(segmenter, &names.join(" + "), &each, scans, (&spec.thresholds, &spec.min_frames));
    joint.spec = Some(spec.clone());
    Ok((joint, each))
}

/// Sweeps the grid of `thresholds` and `min_frames` on the `val` scans of a lab's recordings
/// folder (docs/recordings.md) for the pair `models`, grouped by commanded speed (a speed's depths
/// together), and chooses by [`RULE`] (`braille calibrate-reader --recordings`). The reader gets
/// the events only; the manifest's text scores it.
pub fn calibrate_recordings(
    models: &ReaderModels,
    segmenter: &str,
    classifier: &str,
    rec: &corpus::recordings::Recordings,
    thresholds: &[f32],
    min_frames: &[usize],
    progress: &dyn Progress,
) -> Result<Calibration> {
    let role = corpus::recordings::Role::Val;
    let scans: Vec<&corpus::recordings::Recording> = rec.role(role).collect();
    if scans.is_empty() {
        return Err(crate::Error::Data {
            path: rec.dir.clone(),
            what: "no `val` scans in its manifest: the reader's operating point is chosen on them".into(),
        });
    }
    let mut speeds: Vec<f64> = rec.conditions(role).into_iter().map(|c| c.0).collect();
    speeds.dedup();
    let grid = grid_of(thresholds, min_frames)?;
    let load = |k: usize| -> Result<Scan> {
        let r = scans[k];
        let path = rec.path(r);
        let (info, events) =
            encoders::formats::read_all(&path, &encoders::OpenOptions::default()).map_err(corpus::Error::from)?;
        Ok(Scan {
            speed: speeds.iter().position(|&v| v == r.speed_mm_s).expect("every val speed is listed"),
            events,
            resolution: info.resolution.unwrap_or(encoders::Resolution::DVXPLORER),
            truth: r.text.split_whitespace().map(str::to_uppercase).collect(),
        })
    };
    let reads = read_grid(
        &[models],
        &grid,
        scans.len(),
        &load,
        BrailleCode::Grade1Letters,
        "reading recorded val scans at every operating point",
        progress,
    )?
    .remove(0);
    let text = format!(
        "recorded scans of {}: its {} `val` scans at {:?} mm/s (commanded), speed estimated",
        rec.dir.display(),
        scans.len(),
        speeds
    );
    let mut c = choose_point(segmenter, classifier, &grid, &speeds, &reads, text, (thresholds, min_frames));
    c.data = "recorded scans";
    Ok(c)
}

/// Every point of `thresholds` with every shortest segment, checked.
fn grid_of(thresholds: &[f32], min_frames: &[usize]) -> Result<Vec<OperatingPoint>> {
    if thresholds.is_empty() || min_frames.is_empty() {
        return Err(crate::Error::Setting {
            name: "calibration grid",
            value: format!("{} thresholds, {} frame counts", thresholds.len(), min_frames.len()),
            expected: "at least one of each",
        });
    }
    let grid: Vec<OperatingPoint> = thresholds
        .iter()
        .flat_map(|&t| {
            min_frames.iter().map(move |&m| OperatingPoint {
                present_threshold: t,
                min_frames: m,
                calibration: None,
                abstain: None,
            })
        })
        .collect();
    for p in &grid {
        p.validate()?;
    }
    Ok(grid)
}

/// One validation scan: its speed's index, its events and the words printed.
struct Scan {
    speed: usize,
    events: Vec<encoders::Event>,
    resolution: encoders::Resolution,
    truth: Vec<String>,
}

/// Per scan: its speed, the printed words, and per grid point the words read (raw, lexicon).
type Read = (usize, (Vec<String>, Vec<(Vec<String>, Vec<String>)>));

/// Reads scans `0..n` (each loaded by `load`, in parallel, once for all readers) with each of
/// `readers` at every point of `grid`, each scan's network outputs computed once ([`Memo`]). The
/// words read: the letters' raw reading and the lexicon's, or in a code beyond the letters the
/// cells back-translated without spelling and by the code's lexicon beam. Per reader, per scan.
fn read_grid(
    readers: &[&ReaderModels],
    grid: &[OperatingPoint],
    n: usize,
    load: &(dyn Fn(usize) -> Result<Scan> + Sync),
    code: BrailleCode,
    what: &str,
    progress: &dyn Progress,
) -> Result<Vec<Vec<Read>>> {
    let letters = code == BrailleCode::Grade1Letters;
    let speller = Speller::new(if letters { Spell::Lexicon } else { Spell::None });
    let in_code = [Speller::in_code(Spell::None, code)?, Speller::in_code(Spell::Lexicon, code)?];
    progress.start(what, n as u64);
    let per_scan: Vec<Vec<Read>> = (0..n)
        .into_par_iter()
        .map(|k| -> Result<Vec<Read>> {
            let scan = load(k)?;
            let mut per_reader = Vec::with_capacity(readers.len());
            for models in readers {
                let (seg, cls) = (Memo::new(&models.segmenter), Memo::new(&models.classifier));
                let mut out = Vec::with_capacity(grid.len());
                for p in grid {
                    let cfg: ReaderConfig = models.config(Timing::ESTIMATED).with_operating_point(p);
                    let r = read_all(&scan.events, cfg, scan.resolution, &seg, &cls, &speller)
                        .map_err(crate::Error::from)?;
                    out.push(if letters {
                        (
                            r.words.iter().map(|w| w.raw.clone()).collect(),
                            r.words.iter().map(|w| w.text.clone()).collect(),
                        )
                    } else {
                        let spell = |sp: &Speller| r.words.iter().map(|w| sp.correct(&w.chars)).collect();
                        (spell(&in_code[0]), spell(&in_code[1]))
                    });
                }
                per_reader.push((scan.speed, (scan.truth.clone(), out)));
            }
            progress.inc();
            Ok(per_reader)
        })
        .collect::<Result<_>>()?;
    progress.finish();
    // per reader, per scan
    let mut reads: Vec<Vec<Read>> = (0..readers.len()).map(|_| Vec::with_capacity(n)).collect();
    for scan in per_scan {
        for (r, read) in reads.iter_mut().zip(scan) {
            r.push(read);
        }
    }
    Ok(reads)
}

/// Scores every point of `grid` on `reads` per speed and chooses by [`RULE`].
#[allow(clippy::too_many_arguments)]
fn choose_point(
    segmenter: &str,
    classifier: &str,
    grid: &[OperatingPoint],
    speeds_mm_s: &[f64],
    reads: &[Read],
    scans: String,
    (thresholds, min_frames): (&[f32], &[usize]),
) -> Calibration {
    let n_speeds = speeds_mm_s.len();
    let mut metrics = vec![vec![(WordMetrics::default(), WordMetrics::default()); n_speeds]; grid.len()];
    let mut words = vec![0usize; n_speeds];
    for (s, (truth, per_point)) in reads {
        words[*s] += truth.len();
        for (g, (raw, lex)) in per_point.iter().enumerate() {
            metrics[g][*s].0.add_line(truth, raw);
            metrics[g][*s].1.add_line(truth, lex);
        }
    }
    let rows: Vec<CalibrationRow> = grid
        .iter()
        .zip(&metrics)
        .map(|(p, m)| {
            CalibrationRow::of(
                p.present_threshold,
                p.min_frames,
                m.iter().map(|x| x.0.word_accuracy()).collect(),
                m.iter().map(|x| x.1.word_accuracy()).collect(),
            )
        })
        .collect();
    finish(segmenter, classifier, speeds_mm_s, words, rows, scans, (thresholds, min_frames))
}

/// The point of several pairs' calibrations on the same scans and grid (`each`, one per
/// classifier reading with the segmentation network): each point's scores averaged over the
/// pairs, chosen by [`RULE`].
fn joint_point(
    segmenter: &str,
    classifier: &str,
    each: &[Calibration],
    scans: String,
    grid: (&[f32], &[usize]),
) -> Calibration {
    let first = &each[0];
    let n = each.len() as f64;
    // point g's score at each speed, averaged over the pairs
    let mean = |g: usize, score: fn(&CalibrationRow) -> &[f64]| -> Vec<f64> {
        (0..first.speeds_mm_s.len()).map(|s| each.iter().map(|c| score(&c.rows[g])[s] / n).sum()).collect()
    };
    let rows: Vec<CalibrationRow> = (0..first.rows.len())
        .map(|g| {
            let r = &first.rows[g];
            CalibrationRow::of(r.present_threshold, r.min_frames, mean(g, |r| &r.none), mean(g, |r| &r.lexicon))
        })
        .collect();
    finish(segmenter, classifier, &first.speeds_mm_s, first.words.clone(), rows, scans, grid)
}

/// The calibration of scored `rows`: the point [`RULE`] picks, recorded with how it was chosen.
fn finish(
    segmenter: &str,
    classifier: &str,
    speeds_mm_s: &[f64],
    words: Vec<usize>,
    rows: Vec<CalibrationRow>,
    scans: String,
    (thresholds, min_frames): (&[f32], &[usize]),
) -> Calibration {
    let best = choose(&rows);
    let b = &rows[best];
    let chosen = OperatingPoint {
        present_threshold: b.present_threshold,
        min_frames: b.min_frames,
        calibration: Some(PointCalibration {
            command: "braille calibrate-reader".into(),
            data: scans.clone(),
            classifier: classifier.to_string(),
            rule: RULE.to_string(),
            mean_word_accuracy_none: b.mean_none,
            mean_word_accuracy_lexicon: b.mean_lexicon,
            grid: CalibrationGrid {
                thresholds: thresholds.iter().map(|&t| f32_as_printed(t)).collect(),
                min_frames: min_frames.to_vec(),
            },
        }),
        // a new point is chosen without abstention; its threshold is chosen for it afterwards
        abstain: None,
    };
    Calibration {
        data: "simulated (virtual Evetac)",
        segmenter: segmenter.to_string(),
        classifier: classifier.to_string(),
        scans,
        spec: None,
        speeds_mm_s: speeds_mm_s.to_vec(),
        words,
        rows,
        chosen,
        rule: RULE,
    }
}

/// The row [`RULE`] picks.
pub fn choose(rows: &[CalibrationRow]) -> usize {
    let distance = |r: &CalibrationRow| {
        (r.present_threshold as f64 - 0.5).abs() / 0.1
            + (r.min_frames as f64 - OperatingPoint::PAPER.min_frames as f64).abs()
    };
    (0..rows.len())
        .max_by(|&a, &b| {
            let (x, y) = (&rows[a], &rows[b]);
            x.mean_none
                .total_cmp(&y.mean_none)
                .then(x.mean_lexicon.total_cmp(&y.mean_lexicon))
                .then(distance(y).total_cmp(&distance(x)))
        })
        .unwrap_or(0)
}

/// The grid as Markdown.
pub fn markdown(c: &Calibration) -> String {
    let best = choose(&c.rows);
    let speeds: Vec<String> = c.speeds_mm_s.iter().map(|v| format!("{v} mm/s")).collect();
    let kind = if c.data.starts_with("simulated") { "SIMULATED" } else { "RECORDED" };
    let scans = match &c.spec {
        Some(s) => format!(
            "{}, {} world with the training sensor builds {:?}, seed {}, {} scans per row at {} ({} printed words per speed), {} mm, speed estimated from the events; no test board",
            match s.code {
                BrailleCode::Grade1Letters => format!("`VAL-WORDS`, the validation words (`{}`)", s.board.name()),
                code => format!(
                    "`VAL-UEB`, the validation sentences printed in {code} ({} rows); the words read are the cells back-translated, scored exactly (case, digits and punctuation count)",
                    s.print_rows.len()
                ),
            },
            s.world.realism,
            s.world.sensors,
            s.seed,
            s.trials,
            speeds.join(", "),
            c.words.iter().map(|w| w.to_string()).collect::<Vec<_>>().join(" / "),
            s.depth_mm
        ),
        None => format!(
            "{} ({} printed words per speed)",
            c.scans,
            c.words.iter().map(|w| w.to_string()).collect::<Vec<_>>().join(" / ")
        ),
    };
    let mut md = format!(
        "# The reader's operating point: {} ({kind})\n\nSegmentation network `{}`, character classifier `{}`. Scans: {scans}. Each cell: word accuracy (1 - WER) over every printed word without spelling / with the lexicon decoder. Rule: {}.\n\nChosen: **threshold {}, {} frames** (mean {:.3} without spelling, {:.3} with the lexicon). The paper's point (0.5, 4) is marked *paper*.\n\n",
        c.segmenter,
        c.segmenter,
        c.classifier,
        c.rule,
        c.chosen.present_threshold,
        c.chosen.min_frames,
        c.rows[best].mean_none,
        c.rows[best].mean_lexicon,
    );
    md += &format!("| threshold | min frames | {} | mean, none | mean, lexicon |\n", speeds.join(" | "));
    md += &format!("|{}\n", " --- |".repeat(4 + speeds.len()));
    for (k, r) in c.rows.iter().enumerate() {
        let cells: Vec<String> = r.none.iter().zip(&r.lexicon).map(|(a, b)| format!("{a:.3} / {b:.3}")).collect();
        let mark = if k == best {
            " **chosen**"
        } else if r.present_threshold == 0.5 && r.min_frames == 4 {
            " *paper*"
        } else {
            ""
        };
        md += &format!(
            "| {}{mark} | {} | {} | {:.3} | {:.3} |\n",
            r.present_threshold,
            r.min_frames,
            cells.join(" | "),
            r.mean_none,
            r.mean_lexicon
        );
    }
    md
}

/// The point an earlier calibration chose: `chosen` of its `operating_point_ARCH.json`, checked.
pub fn chosen_in(json: &Path) -> Result<OperatingPoint> {
    #[derive(serde::Deserialize)]
    struct Written {
        chosen: OperatingPoint,
    }
    let text = std::fs::read_to_string(json).map_err(|source| crate::Error::Io { path: json.to_path_buf(), source })?;
    let w: Written =
        serde_json::from_str(&text).map_err(|source| crate::Error::Json { path: json.to_path_buf(), source })?;
    w.chosen.validate().map_err(|e| crate::Error::Chosen { path: json.to_path_buf(), source: Box::new(e) })?;
    Ok(w.chosen)
}

/// Records `point` in the model file at `path` (its header only; the weights are written back as
/// they were read).
pub fn record(path: &Path, point: &OperatingPoint) -> Result<()> {
    let mut m = pipeline::models::load(path)?;
    let value =
        serde_json::to_value(point).map_err(|source| crate::Error::Json { path: path.to_path_buf(), source })?;
    m.set_operating_point(Some(value));
    m.save(path, true)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f32, m: usize, none: f64, lexicon: f64) -> CalibrationRow {
        CalibrationRow {
            present_threshold: t,
            min_frames: m,
            none: vec![none],
            lexicon: vec![lexicon],
            mean_none: none,
            mean_lexicon: lexicon,
        }
    }

    #[test]
    fn the_rule_prefers_the_reading_then_the_lexicon_then_the_papers_point() {
        let rows = vec![row(0.5, 4, 0.80, 0.95), row(0.8, 6, 0.85, 0.97), row(0.9, 10, 0.85, 0.99)];
        assert_eq!(choose(&rows), 2);
        let rows = vec![row(0.9, 10, 0.85, 0.97), row(0.6, 5, 0.85, 0.97), row(0.5, 4, 0.84, 0.99)];
        assert_eq!(choose(&rows), 1);
    }

    #[test]
    fn a_shared_network_takes_the_point_best_for_its_readers_together() {
        // reader A is best at (0.4, 8), reader B at (0.8, 4); together (0.6, 6) is best, though
        // neither reader's own choice
        let of = |rows: Vec<CalibrationRow>, classifier: &str| {
            finish("seg", classifier, &[16.0], vec![10], rows, "scans".into(), (&[0.4, 0.6, 0.8], &[4, 6, 8]))
        };
        let a = of(vec![row(0.4, 8, 0.95, 0.97), row(0.6, 6, 0.90, 0.95), row(0.8, 4, 0.70, 0.80)], "a");
        let b = of(vec![row(0.4, 8, 0.70, 0.80), row(0.6, 6, 0.90, 0.95), row(0.8, 4, 0.94, 0.96)], "b");
        assert_eq!((a.chosen.present_threshold, b.chosen.present_threshold), (0.4, 0.8));
        let joint = joint_point("seg", "a + b", &[a, b], "scans".into(), (&[0.4, 0.6, 0.8], &[4, 6, 8]));
        assert_eq!((joint.chosen.present_threshold, joint.chosen.min_frames), (0.6, 6));
        assert!((joint.rows[0].mean_none - 0.825).abs() < 1e-12 && (joint.rows[2].mean_lexicon - 0.88).abs() < 1e-12);
        let c = joint.chosen.calibration.as_ref().unwrap();
        assert_eq!((c.classifier.as_str(), c.mean_word_accuracy_none), ("a + b", 0.90));
    }

    #[test]
    fn the_sentences_spec_scores_each_row_against_its_print() {
        let spec = CalibrationSpec::validation_in(Realism::Nominal, BrailleCode::UebGrade2).unwrap();
        let board = corpus::boards::sentence_board(HeldOut::Validation, BrailleCode::UebGrade2).unwrap();
        assert_eq!((spec.board, spec.print_rows, spec.depth_mm), (board.kind, board.print_rows, 1.0));
        assert_eq!(
            CalibrationSpec::validation_in(Realism::Nominal, BrailleCode::Grade1Letters).unwrap(),
            CalibrationSpec::validation(Realism::Nominal)
        );
    }

    #[test]
    fn a_point_recorded_in_the_model_file_is_where_readers_read_and_a_bad_one_is_named() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/clean");
        let tmp = tempfile::tempdir().unwrap();
        let seg = tmp.path().join("seg.safetensors");
        let cls = dir.join("snn-words.safetensors");
        let write = |point: serde_json::Value| {
            let mut m = pipeline::models::load(&dir.join("snn-segment.safetensors")).unwrap();
            m.set_operating_point(Some(point));
            m.save(&seg, true).unwrap();
        };
        let load = || ReaderModels::load(&seg, &cls, pipeline::classify::SnnRunner::Sliding).map_err(|e| e.to_string());
        // never calibrated: the paper's point
        let plain =
            ReaderModels::load(&dir.join("snn-segment.safetensors"), &cls, pipeline::classify::SnnRunner::Sliding)
                .unwrap();
        let cfg = plain.config(Timing::ESTIMATED);
        assert_eq!((cfg.present_threshold, cfg.filter.min_frames), (0.5, 4));
        // a calibration is typed: one without its fields is an error naming the file and the key
        write(serde_json::json!({"present_threshold": 0.9, "min_frames": 7, "calibration": {"rule": "test"}}));
        let e = load().err().unwrap();
        assert!(e.contains("seg.safetensors") && e.contains("operating_point") && e.contains("command"), "{e}");
        let calibration = serde_json::json!({
            "command": "test", "data": "none", "classifier": "snn-words.safetensors", "rule": "test",
            "mean_word_accuracy_none": 0.5, "mean_word_accuracy_lexicon": 0.75,
            "grid": {"thresholds": [0.9], "min_frames": [7]},
        });
        write(serde_json::json!({"present_threshold": 0.9, "min_frames": 7, "calibration": calibration}));
        let m = load().unwrap();
        let cfg = m.config(Timing::Paper);
        assert_eq!((cfg.present_threshold, cfg.filter.min_frames), (0.9, 7));
        assert_eq!(m.operating_point().calibration.as_ref().map(|c| c.rule.as_str()), Some("test"));
        write(serde_json::json!({"present_threshold": 1.5, "min_frames": 7}));
        let e = load().err().unwrap();
        assert!(e.contains("seg.safetensors") && e.contains("operating_point") && e.contains("1.5"), "{e}");
        write(serde_json::json!({"threshold": 0.9}));
        let e = load().err().unwrap();
        assert!(e.contains("seg.safetensors") && e.contains("present_threshold"), "{e}");
    }

    #[test]
    fn a_memoised_reader_reads_as_the_plain_one_at_every_point() {
        // the shipped `clean` SNN pair on one short scan: the grid read through the memo gives
        // what a reader without it gives, point by point (the memo only saves work)
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/clean");
        let models = ReaderModels::load(
            &dir.join("snn-segment.safetensors"),
            &dir.join("snn-words.safetensors"),
            pipeline::classify::SnnRunner::Sliding,
        )
        .unwrap();
        let world = World::clean();
        let setup = world.setup();
        let kind = BoardKind::Text("HELP OPEN".into());
        let board = world.board(&setup, &kind).unwrap();
        let sensor = &world.sensors_at(&setup, encoders::Resolution::DVXPLORER).unwrap()[0];
        let scan = sim::simulate(&board, sensor, &setup.scan(32.0, 1.5, 0, 7)).unwrap();
        let speller = Speller::new(Spell::None);
        let (seg, cls) = (Memo::new(&models.segmenter), Memo::new(&models.classifier));
        let mut distinct = std::collections::HashSet::new();
        for (t, m) in [(0.3, 2), (0.5, 4), (0.9, 8), (0.5, 12)] {
            let p = OperatingPoint { present_threshold: t, min_frames: m, calibration: None, abstain: None };
            let cfg = || models.config(Timing::ESTIMATED).with_operating_point(&p);
            let memo = read_all(&scan.events, cfg(), sensor.camera.resolution, &seg, &cls, &speller).unwrap();
            let plain = read_all(
                &scan.events,
                cfg(),
                sensor.camera.resolution,
                &models.segmenter,
                &models.classifier,
                &speller,
            )
            .unwrap();
            assert_eq!(memo.words, plain.words, "at ({t}, {m})");
            assert!(plain.stats.classifier_calls > 0);
            distinct.insert(plain.words.iter().map(|w| w.chars.len()).sum::<usize>());
        }
        // the points do read differently (the sweep can tell them apart)
        assert!(distinct.len() > 1, "{distinct:?}");
    }
}
