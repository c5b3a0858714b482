//! Word reading on SIMULATED scans: each architecture reads every scan of a board from its raw
//! event stream, and the lines are scored with the paper's four conditional metrics
//! (`braille eval words`, the speed table).

use crate::Progress;
use crate::error::Result;
use crate::eval::scoring::WordMetrics;
use pipeline::classify::ReaderModels;
use pipeline::reader::{ReadWord, ReaderStats, Spell, Speller, Timing, TimingMode};
use rayon::prelude::*;
use serde::Serialize;
use sim::BoardKind;
use snn::model_file::Arch;
use std::path::PathBuf;
use std::time::Instant;

/// The three spellings, in the order reports give them.
pub const SPELLS: [Spell; 3] = [Spell::None, Spell::Textblob, Spell::Lexicon];

/// What one architecture read on a set of scans.
#[derive(Debug, Clone, Serialize)]
pub struct WordsScore {
    pub arch: Arch,
    /// Where the reader's speed came from (`given` is the simulator's truth: an oracle).
    pub timing: TimingMode,
    pub speed_mm_s: f64,
    /// Hand-held swings of the speed along the row (relative amplitude; 0 for the arm).
    pub speed_variation: f64,
    pub depth_mm: f64,
    pub lines: usize,
    /// The speed each character was read at against the true speed under the sensor then
    /// (relative error, over every character read).
    pub speed_error: SpeedError,
    /// Per spelling (none, textblob, lexicon): the paper's four metrics.
    pub by_spell: Vec<SpellScore>,
    /// Seconds of stream read, and the wall time reading took (segmentation, classifier,
    /// filter; not the simulation).
    pub stream_s: f64,
    pub read_s: f64,
    /// Stream time from the last event a character's detections used to its registration.
    pub registration_delay_ms_mean: f64,
    pub registration_delay_ms_max: f64,
    pub frames: u64,
    pub segmenter_calls: u64,
    pub classifier_calls: u64,
    pub segmenter_ms: f64,
    pub classifier_ms: f64,
    pub synops: u64,
    /// Every line: truth and what was read (raw letters; spelled by the lexicon decoder).
    pub examples: Vec<(String, String, String)>,
}

#[derive(Debug, Clone, Serialize)]
pub struct SpellScore {
    pub spell: Spell,
    /// Unconditional, over every printed word: word accuracy `1 - WER` (inserted words count),
    /// percent correct (printed words read right, aligned to the line; blind to insertions, as a
    /// fraction), and the word and character error rates.
    pub word_accuracy: f64,
    pub percent_correct: f64,
    pub word_error_rate: f64,
    pub char_error_rate: f64,
    /// The paper's four conditional metrics.
    pub words_per_line: f64,
    pub letters_per_word: f64,
    pub correct_words: f64,
    pub correct_letters: f64,
    pub counts: WordMetrics,
}

/// The relative error of the speed the reader read at, over the characters read.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SpeedError {
    pub chars: usize,
    /// Signed median, and the mean and 90th percentile of the absolute error.
    pub median: f64,
    pub mean_abs: f64,
    pub p90_abs: f64,
    pub max_abs: f64,
}

impl SpeedError {
    pub fn of(errors: &[f64]) -> SpeedError {
        if errors.is_empty() {
            return SpeedError::default();
        }
        let mut e = errors.to_vec();
        e.sort_by(f64::total_cmp);
        let mut a: Vec<f64> = e.iter().map(|x| x.abs()).collect();
        a.sort_by(f64::total_cmp);
        let q = |v: &[f64], p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
        SpeedError {
            chars: e.len(),
            median: q(&e, 0.5),
            mean_abs: a.iter().sum::<f64>() / a.len() as f64,
            p90_abs: q(&a, 0.9),
            max_abs: a[a.len() - 1],
        }
    }
}

/// The true speed under the sensor at stream time `t_s`: the motion's speed then
/// ([`sim::ScanTruth::speed_at_mm_s`]). Truth files without the motion's swings (written before
/// 2026-11-25) give the mean speed between the two dot columns that passed the sensor's centre
/// nearest before and after `t_s` (a whole row's mean speed when fewer than two did).
pub fn truth_speed_at(truth: &sim::ScanTruth, t_s: f64) -> f64 {
    if !truth.speed_swings.is_empty() {
        return truth.speed_at_mm_s(t_s);
    }
    let mut c: Vec<(f64, f64)> = truth
        .characters
        .iter()
        .flat_map(|c| c.columns.iter().filter_map(|k| k.t_center_s.map(|t| (t, k.x_mm))))
        .collect();
    c.sort_by(|a, b| a.0.total_cmp(&b.0));
    c.dedup_by(|b, a| b.0 <= a.0);
    if c.len() < 2 {
        return truth.scan.speed_mm_s;
    }
    let k = c.partition_point(|p| p.0 < t_s).clamp(1, c.len() - 1);
    let (a, b) = (c[k - 1], c[k]);
    ((b.1 - a.1) / (b.0 - a.0)).abs()
}

/// One scan (simulated or recorded), read.
#[derive(Clone)]
pub struct LineRead {
    /// The row's words as printed.
    pub truth: Vec<String>,
    pub words: Vec<ReadWord>,
    pub stats: ReaderStats,
    /// Seconds of stream, and the wall time reading took.
    pub stream_s: f64,
    pub read_s: f64,
    /// Time in the segmentation network and in the classifier, and synaptic operations (SNN).
    pub seg_ns: u64,
    pub cls_ns: u64,
    pub synops: u64,
    /// Per character read: the speed it was read at over the true speed then, minus one.
    pub speed_errors: Vec<f64>,
}

/// Which scans to read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WordsSpec {
    pub board: BoardKind,
    pub speed_mm_s: f64,
    /// Hand-held swings of the speed along the row (relative amplitude; 0 for the arm).
    pub speed_variation: f64,
    pub depth_mm: f64,
    /// Scans per board row.
    pub trials: u64,
    pub seed: u64,
    /// The simulated world of the scans.
    pub world: corpus::world::World,
}

/// One scan's events read by each of `readers` with each of `timings` (`[timing * readers.len()
/// + reader]`); `speed_mm_s` is what [`TimingMode::Given`] tells the reader, and each
/// character's speed error is against `true_speed` at the middle of its segment (s of stream).
fn read_lines(
    readers: &[&ReaderModels],
    timings: &[TimingMode],
    events: &[encoders::Event],
    resolution: encoders::Resolution,
    speed_mm_s: f64,
    truth: &[String],
    true_speed: &dyn Fn(f64) -> f64,
) -> Result<Vec<LineRead>> {
    let speller = Speller::new(Spell::None);
    let stream_s = events.last().map_or(0.0, |e| e.t_us as f64 / 1e6);
    let mut out = Vec::new();
    for (&mode, r) in timings.iter().flat_map(|m| readers.iter().map(move |r| (m, r))) {
        let timing = match mode {
            TimingMode::Estimated => Timing::ESTIMATED,
            TimingMode::Paper => Timing::Paper,
            TimingMode::Given => Timing::Given { speed_mm_s },
        };
        let t = Instant::now();
        let read = r.read(events, resolution, timing, &speller)?;
        let speed_errors = read
            .words
            .iter()
            .flat_map(|w| &w.chars)
            .filter_map(|c| {
                let t_s = 0.5 * (c.t_start_us + c.t_end_us) as f64 / 1e6;
                c.speed_mm_s.map(|v| v / true_speed(t_s) - 1.0)
            })
            .collect();
        out.push(LineRead {
            speed_errors,
            truth: truth.to_vec(),
            words: read.words,
            stats: read.stats,
            stream_s,
            read_s: t.elapsed().as_secs_f64(),
            seg_ns: read.segmenter.stats.nanos,
            cls_ns: read.classifier.stats.nanos,
            synops: read.segmenter.stats.synops + read.classifier.stats.synops,
        });
    }
    Ok(out)
}

/// The scans of every row of the board, `trials` each, read by each of `readers` with each of
/// `timings` (each scan simulated once for all; the models are shared by the threads);
/// `[scan][timing * readers.len() + reader]`. The readers get the events only; with
/// [`TimingMode::Given`] they are told the scan's mean speed (an oracle).
pub fn read_scans(
    spec: &WordsSpec,
    readers: &[&ReaderModels],
    timings: &[TimingMode],
    progress: &dyn Progress,
) -> Result<Vec<Vec<LineRead>>> {
    read_scans_in(spec, &spec.world.setup(), readers, timings, progress)
}

/// [`read_scans`] with the world's preset replaced by `setup` (a robustness sweep's nuisance
/// levels); the world still picks the sensor builds and the scan seeds.
pub fn read_scans_in(
    spec: &WordsSpec,
    setup: &sim::Setup,
    readers: &[&ReaderModels],
    timings: &[TimingMode],
    progress: &dyn Progress,
) -> Result<Vec<Vec<LineRead>>> {
    let (board, speed_mm_s, depth_mm) = (&spec.board, spec.speed_mm_s, spec.depth_mm);
    let b = spec.world.board(setup, board)?;
    let sensors = spec.world.sensors_at(setup, encoders::Resolution::DVXPLORER)?;
    let jobs: Vec<(usize, u64)> = (0..b.rows.len()).flat_map(|r| (0..spec.trials).map(move |t| (r, t))).collect();
    progress.start("reading simulated scans", jobs.len() as u64);
    let lines: Vec<Vec<LineRead>> = jobs
        .par_iter()
        .map(|&(row, trial)| -> Result<Vec<LineRead>> {
            let scan_seed = spec.world.scan_seed(spec.seed, board, row, trial, speed_mm_s, depth_mm);
            let sensor = &sensors[(trial % sensors.len() as u64) as usize];
            let scan = sim::ScanConfig {
                speed_variation: spec.speed_variation,
                ..setup.scan(speed_mm_s, depth_mm, row, scan_seed)
            };
            let s = sim::simulate(&b, sensor, &scan)?;

            let truth: Vec<String> = s.truth.row_text.split_whitespace().map(str::to_string).collect();
            let true_speed = |t_s: f64| truth_speed_at(&s.truth, t_s);
            let resolution = sensor.camera.resolution;
            let out = read_lines(readers, timings, &s.events, resolution, speed_mm_s, &truth, &true_speed)?;
            progress.inc();
            Ok(out)
        })
        .collect::<Result<_>>()?;
    progress.finish();
    Ok(lines)
}

/// The scan condition a score is of: the (commanded) speed, its hand-held swing and the depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Condition {
    pub speed_mm_s: f64,
    pub speed_variation: f64,
    pub depth_mm: f64,
}

impl WordsSpec {
    pub fn condition(&self) -> Condition {
        Condition { speed_mm_s: self.speed_mm_s, speed_variation: self.speed_variation, depth_mm: self.depth_mm }
    }
}

/// Scores the lines of reader `k` (`lines[scan][k]`), an `arch` reader with `timing`, scans of
/// `spec`'s condition.
pub fn score(arch: Arch, timing: TimingMode, k: usize, lines: &[Vec<LineRead>], spec: Condition) -> WordsScore {
    let spellers: Vec<Speller> = SPELLS.iter().map(|&s| Speller::new(s)).collect();
    let mut metrics = vec![WordMetrics::default(); SPELLS.len()];
    let (mut delays, mut examples) = (Vec::new(), Vec::new());
    let mut s = WordsScore {
        arch,
        timing,
        speed_mm_s: spec.speed_mm_s,
        speed_variation: spec.speed_variation,
        depth_mm: spec.depth_mm,
        lines: lines.len(),
        speed_error: SpeedError::of(
            &lines.iter().flat_map(|scan| scan[k].speed_errors.iter().copied()).collect::<Vec<_>>(),
        ),
        by_spell: Vec::new(),
        stream_s: 0.0,
        read_s: 0.0,
        registration_delay_ms_mean: 0.0,
        registration_delay_ms_max: 0.0,
        frames: 0,
        segmenter_calls: 0,
        classifier_calls: 0,
        segmenter_ms: 0.0,
        classifier_ms: 0.0,
        synops: 0,
        examples: Vec::new(),
    };
    for scan in lines {
        let l = &scan[k];
        for (m, sp) in metrics.iter_mut().zip(&spellers) {
            // a word the reader marked unreadable is not a word of its text: the printed word
            // under it counts as missed
            let read: Vec<String> = l.words.iter().filter(|w| !w.unreadable).map(|w| sp.correct(&w.chars)).collect();
            m.add_line(&l.truth, &read);
        }
        let raw: Vec<String> =
            l.words.iter().map(|w| if w.unreadable { format!("[{}?]", w.raw) } else { w.raw.clone() }).collect();
        let lex: Vec<String> =
            l.words.iter().filter(|w| !w.unreadable).map(|w| spellers[2].correct(&w.chars)).collect();
        examples.push((l.truth.join(" "), raw.join(" "), lex.join(" ")));
        delays
            .extend(l.words.iter().flat_map(|w| w.chars.iter().map(|c| (c.t_registered_us - c.t_end_us) as f64 / 1e3)));
        s.stream_s += l.stream_s;
        s.read_s += l.read_s;
        s.frames += l.stats.frames;
        s.segmenter_calls += l.stats.segmenter_calls;
        s.classifier_calls += l.stats.classifier_calls;
        s.segmenter_ms += l.seg_ns as f64 / 1e6;
        s.classifier_ms += l.cls_ns as f64 / 1e6;
        s.synops += l.synops;
    }
    s.registration_delay_ms_mean = delays.iter().sum::<f64>() / delays.len().max(1) as f64;
    s.registration_delay_ms_max = delays.iter().copied().fold(0.0, f64::max);
    s.by_spell = SPELLS
        .iter()
        .zip(metrics)
        .map(|(&spell, m)| SpellScore {
            spell,
            word_accuracy: m.word_accuracy(),
            percent_correct: m.percent_correct(),
            word_error_rate: m.word_error_rate(),
            char_error_rate: m.char_error_rate(),
            words_per_line: m.words_per_line(),
            letters_per_word: m.letters_per_word(),
            correct_words: m.correct_words_rate(),
            correct_letters: m.correct_letters_rate(),
            counts: m,
        })
        .collect();
    s.examples = examples;
    s
}

/// A reader's words on a board's SIMULATED scans (`braille eval words`): the paper's four metrics
/// with the spelling asked for, and the score with every spelling.
#[derive(Debug, Clone, Serialize)]
pub struct EvalWords {
    pub data: &'static str,
    pub board: String,
    /// The networks that read (a mixed pair, or a validation run, names itself), where the
    /// segmentation network was read, and the sensor builds that scanned.
    pub segmenter: PathBuf,
    pub classifier: PathBuf,
    pub operating_point: pipeline::reader::OperatingPoint,
    /// The simulated world's builds (none for recorded scans).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor_builds: Option<corpus::world::SensorBuilds>,
    /// The chip whose arithmetic ran the classifier (and the segmentation network), and its
    /// quantisation (none: the float engine).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chip: Option<(snn::chip::Chip, snn::chip::xylo::Quantisation)>,
    pub spell: Spell,
    /// Unconditional, over every printed word: word accuracy `1 - WER` (inserted words count),
    /// percent correct (printed words read right; blind to insertions, as a fraction), and the word
    /// and character error rates (edit distance over the line).
    pub word_accuracy: f64,
    pub percent_correct: f64,
    #[serde(rename = "wer")]
    pub word_error_rate: f64,
    #[serde(rename = "cer")]
    pub char_error_rate: f64,
    /// The paper's conditional metrics.
    pub words_per_line: f64,
    pub letters_per_word: f64,
    pub correct_words: f64,
    pub correct_letters: f64,
    #[serde(flatten)]
    pub score: WordsScore,
}

/// Reads every scan of `spec` with `readers` (loaded from `files`) and `timing`, and scores it;
/// `builds` names the sensor builds of `spec`'s world.
pub fn eval_words(
    spec: &WordsSpec,
    readers: &ReaderModels,
    files: &pipeline::shipped::ReaderFiles,
    builds: corpus::world::SensorBuilds,
    timing: TimingMode,
    spell: Spell,
    progress: &dyn Progress,
) -> Result<EvalWords> {
    let lines = read_scans(spec, &[readers], &[timing], progress)?;
    let score = score(readers.classifier.arch(), timing, 0, &lines, spec.condition());
    Ok(EvalWords::of(
        "simulated (virtual Evetac)",
        corpus::boards::board_name(&spec.board),
        files,
        readers,
        Some(builds),
        spell,
        score,
    ))
}

impl EvalWords {
    /// The table of `score` with `spell`'s metrics in front, read by `readers` (from `files`).
    fn of(
        data: &'static str,
        board: String,
        files: &pipeline::shipped::ReaderFiles,
        readers: &ReaderModels,
        sensor_builds: Option<corpus::world::SensorBuilds>,
        spell: Spell,
        score: WordsScore,
    ) -> EvalWords {
        let m = score.by_spell.iter().find(|b| b.spell == spell).expect("every spelling is scored").clone();
        EvalWords {
            data,
            board,
            segmenter: files.segmenter.clone(),
            classifier: files.classifier.clone(),
            operating_point: readers.operating_point().clone(),
            sensor_builds,
            chip: readers.classifier.chip(),
            spell,
            word_accuracy: m.word_accuracy,
            percent_correct: m.percent_correct,
            word_error_rate: m.word_error_rate,
            char_error_rate: m.char_error_rate,
            words_per_line: m.words_per_line,
            letters_per_word: m.letters_per_word,
            correct_words: m.correct_words,
            correct_letters: m.correct_letters,
            score,
        }
    }
}

/// The lines `braille eval words` prints.
impl std::fmt::Display for EvalWords {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (s, p) = (&self.score, &self.operating_point);
        writeln!(
            f,
            "models: {} + {} (segmentation read above {}, characters from {} frames{}){}{}",
            self.segmenter.display(),
            self.classifier.display(),
            p.present_threshold,
            p.min_frames,
            if p.calibration.is_none() { ", the paper's point" } else { ", calibrated" },
            self.sensor_builds.map_or(String::new(), |b| format!("; {b:?} sensor builds")),
            self.chip.map_or(String::new(), |(c, q)| format!("; in {c}'s arithmetic ({q:?} quantisation)"))
        )?;
        writeln!(
            f,
            "{} {} at {} mm/s{}, {} mm, {} lines, {} architecture, {} timing (speed error median {:+.1}%, mean absolute {:.1}% over {} characters), spelling {:?}: word accuracy (1 - WER) {:.3} over all printed words, percent correct {:.3}, WER {:.3}, CER {:.3}; the paper's conditional metrics: words per line {:.3}, letters per word {:.3}, correct words {:.3}, correct letters {:.3}; read {:.1} s of stream in {:.2} s",
            if self.data.starts_with("simulated") { "SIMULATED" } else { "RECORDED" },
            self.board,
            s.speed_mm_s,
            if s.speed_variation > 0.0 {
                format!(" hand-held ±{:.0}%", 100.0 * s.speed_variation)
            } else {
                String::new()
            },
            s.depth_mm,
            s.lines,
            s.arch,
            s.timing,
            100.0 * s.speed_error.median,
            100.0 * s.speed_error.mean_abs,
            s.speed_error.chars,
            self.spell,
            self.word_accuracy,
            self.percent_correct,
            self.word_error_rate,
            self.char_error_rate,
            self.words_per_line,
            self.letters_per_word,
            self.correct_words,
            self.correct_letters,
            s.stream_s,
            s.read_s
        )?;
        let counts = &s.by_spell.iter().find(|b| b.spell == self.spell).expect("every spelling is scored").counts;
        writeln!(f, "{}", letters_line(counts))
    }
}

/// Per-letter accuracy (the five lowest), by place in the row, words by place, and the most
/// frequent confusions of one spelling's counts, on one line.
pub fn letters_line(counts: &WordMetrics) -> String {
    use crate::eval::scoring::LetterPlace;
    let l = &counts.letter_scores;
    let pct = |t: crate::eval::scoring::Tally| t.percent();
    let mut letters: Vec<(char, crate::eval::scoring::Tally)> =
        (0..26).map(|k| ((b'A' + k as u8) as char, l.by_letter[k])).filter(|(_, t)| t.printed > 0).collect();
    letters.sort_by(|a, b| a.1.rate().total_cmp(&b.1.rate()).then(a.0.cmp(&b.0)));
    let lowest: Vec<String> =
        letters.iter().take(5).map(|(c, t)| format!("{c} {} of {}", pct(*t), t.printed)).collect();
    let confusions: Vec<String> = l
        .confusions()
        .iter()
        .take(6)
        .map(|p| format!("{}->{} {}", p.printed, p.read_as("space", "nothing"), p.count))
        .collect();
    format!(
        "letters: {} of {} printed; lowest {}; by place: row start {}, word start {}, middle {}, word end {}; words by place: first {}, middle {}, last {}; confusions: {}",
        pct(l.total()),
        l.total().printed,
        lowest.join(", "),
        pct(l.at(LetterPlace::RowStart)),
        pct(l.at(LetterPlace::WordStart)),
        pct(l.at(LetterPlace::Middle)),
        pct(l.at(LetterPlace::WordEnd)),
        pct(counts.word_places.first),
        pct(counts.word_places.middle),
        pct(counts.word_places.last),
        if confusions.is_empty() { "none".to_string() } else { confusions.join(", ") }
    )
}

/// The scans of one role of a recordings folder, read by each of `readers` with each of
/// `timings` as [`read_scans`] reads simulated ones (`[scan][timing * readers.len() + reader]`),
/// with the manifest's line of each. The readers get the events only; with
/// [`TimingMode::Given`] they are told the commanded speed (the manifest's label). The speed
/// error is against the commanded speed (a recording has no truth of the speed under the sensor).
pub fn read_recordings(
    rec: &corpus::recordings::Recordings,
    role: corpus::recordings::Role,
    readers: &[&ReaderModels],
    timings: &[TimingMode],
    progress: &dyn Progress,
) -> Result<Vec<(corpus::recordings::Recording, Vec<LineRead>)>> {
    let scans: Vec<&corpus::recordings::Recording> = rec.role(role).collect();
    progress.start("reading recorded scans", scans.len() as u64);
    let out = scans
        .par_iter()
        .map(|r| -> Result<(corpus::recordings::Recording, Vec<LineRead>)> {
            let path = rec.path(r);
            let (info, events) =
                encoders::formats::read_all(&path, &encoders::OpenOptions::default()).map_err(corpus::Error::from)?;
            let resolution = info.resolution.unwrap_or(encoders::Resolution::DVXPLORER);
            let truth: Vec<String> = r.text.split_whitespace().map(str::to_uppercase).collect();
            // against the commanded speed: a recording has no truth of the speed under the sensor
            let commanded = |_: f64| r.speed_mm_s;
            let lines = read_lines(readers, timings, &events, resolution, r.speed_mm_s, &truth, &commanded)?;
            progress.inc();
            Ok(((*r).clone(), lines))
        })
        .collect::<Result<Vec<_>>>()?;
    progress.finish();
    Ok(out)
}

/// A reader's words on a recordings folder's scans of one role, one table per condition (the
/// commanded speed and depth, in order), as [`eval_words`] scores simulated scans.
pub fn eval_recordings(
    rec: &corpus::recordings::Recordings,
    role: corpus::recordings::Role,
    readers: &ReaderModels,
    files: &pipeline::shipped::ReaderFiles,
    timing: TimingMode,
    spell: Spell,
    progress: &dyn Progress,
) -> Result<Vec<EvalWords>> {
    let read = read_recordings(rec, role, &[readers], &[timing], progress)?;
    let mut out = Vec::new();
    for (speed_mm_s, depth_mm) in rec.conditions(role) {
        let lines: Vec<Vec<LineRead>> = read
            .iter()
            .filter(|(r, _)| r.speed_mm_s == speed_mm_s && r.depth_mm == depth_mm)
            .map(|(_, l)| l.clone())
            .collect();
        let condition = Condition { speed_mm_s, speed_variation: 0.0, depth_mm };
        let score = score(readers.classifier.arch(), timing, 0, &lines, condition);
        let board = format!("{} ({} scans)", rec.dir.display(), role.name());
        out.push(EvalWords::of("recorded scans", board, files, readers, None, spell, score));
    }
    Ok(out)
}
