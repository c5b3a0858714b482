//! The paper's speed table on SIMULATED EV scans: both architectures, with and without spelling.

use crate::Progress;
use crate::error::Result;
use crate::eval::words::{WordsScore, WordsSpec, read_scans, score};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{Spell, TimingMode};
use serde::Serialize;
use sim::BoardKind;
use snn::model_file::Arch;
use std::fmt::Write as _;
use std::path::Path;

/// The speed table's data.
#[derive(Debug, Clone, Serialize)]
pub struct WordsReport {
    pub data: &'static str,
    pub board: &'static str,
    pub realism: sim::Realism,
    pub depth_mm: f64,
    pub trials: u64,
    pub seed: u64,
    pub speeds_mm_s: Vec<f64>,
    /// Hand-held rows: these mean speeds with the speed swinging by `hand_speed_variation`.
    pub hand_speeds_mm_s: Vec<f64>,
    pub hand_speed_variation: f64,
    pub timings: Vec<TimingMode>,
    /// Every condition (the arm's speeds, then the hand-held ones) read with every timing by
    /// both architectures.
    pub scores: Vec<WordsScore>,
    /// A text board of words no training row used (rows `/`-separated), read at the arm's
    /// speeds with estimated timing, `unseen_trials` scans per row.
    pub unseen_board: String,
    pub unseen_trials: u64,
    pub unseen: Vec<WordsScore>,
}

impl WordsReport {
    /// The score of one condition.
    pub fn get(&self, arch: Arch, timing: TimingMode, speed_mm_s: f64, hand: bool) -> Option<&WordsScore> {
        self.scores.iter().find(|s| {
            s.arch == arch && s.timing == timing && s.speed_mm_s == speed_mm_s && (s.speed_variation > 0.0) == hand
        })
    }
}

/// The paper's speed table (with TextBlob), correct words: 8, 16, 24, 32 mm/s.
const PAPER_SPELL: [f64; 4] = [0.903, 0.97, 0.913, 0.971];
const PAPER_NONE: [f64; 4] = [0.876, 0.866, 0.753, 0.685];

/// What the report reads.
#[derive(Debug, Clone)]
pub struct WordsReportSpec {
    pub speeds_mm_s: Vec<f64>,
    pub hand_speeds_mm_s: Vec<f64>,
    pub hand_speed_variation: f64,
    pub timings: Vec<TimingMode>,
    pub depth_mm: f64,
    pub trials: u64,
    pub seed: u64,
    pub world: corpus::world::World,
    /// Rows of unseen words (none: 0), and scans per row of them.
    pub unseen_rows: usize,
    pub unseen_trials: u64,
}

/// The paper's speed table on the EV board: every condition read by the shipped models of both
/// architectures under `models`, with every timing (`trials` scans per row and condition).
pub fn words_report(models: &Path, spec: &WordsReportSpec, progress: &dyn Progress) -> Result<WordsReport> {
    let archs = [Arch::Resnet, Arch::Snn];
    let readers = archs
        .iter()
        .map(|&a| {
            let pipeline::shipped::ReaderFiles { segmenter: s, classifier: c } =
                pipeline::shipped::reader_in(models, a);
            Ok(ReaderModels::load(&s, &c, SnnRunner::Sliding)?)
        })
        .collect::<Result<Vec<_>>>()?;
    let refs: Vec<&ReaderModels> = readers.iter().collect();
    let conditions = spec
        .speeds_mm_s
        .iter()
        .map(|&v| (v, 0.0))
        .chain(spec.hand_speeds_mm_s.iter().map(|&v| (v, spec.hand_speed_variation)));
    let mut scores = Vec::new();
    for (speed, variation) in conditions {
        let ws = WordsSpec {
            board: BoardKind::Ev,
            speed_mm_s: speed,
            speed_variation: variation,
            depth_mm: spec.depth_mm,
            trials: spec.trials,
            seed: spec.seed,
            world: spec.world.clone(),
        };
        let lines = read_scans(&ws, &refs, &spec.timings, progress)?;
        for (t, &timing) in spec.timings.iter().enumerate() {
            for (a, &arch) in archs.iter().enumerate() {
                scores.push(score(arch, timing, t * archs.len() + a, &lines, ws.condition()));
            }
        }
    }
    let unseen_text = if spec.unseen_rows > 0 {
        corpus::boards::unseen_word_rows(spec.seed, spec.unseen_rows, 25)
    } else {
        String::new()
    };
    let mut unseen = Vec::new();
    if !unseen_text.is_empty() {
        for &speed in &spec.speeds_mm_s {
            let ws = WordsSpec {
                board: BoardKind::Text(unseen_text.clone()),
                speed_mm_s: speed,
                speed_variation: 0.0,
                depth_mm: spec.depth_mm,
                trials: spec.unseen_trials,
                seed: spec.seed,
                world: spec.world.clone(),
            };
            let lines = read_scans(&ws, &refs, &[TimingMode::Estimated], progress)?;
            for (a, &arch) in archs.iter().enumerate() {
                unseen.push(score(arch, TimingMode::Estimated, a, &lines, ws.condition()));
            }
        }
    }
    Ok(WordsReport {
        unseen_board: unseen_text,
        unseen_trials: spec.unseen_trials,
        unseen,
        data: "simulated (virtual Evetac)",
        board: "EV",
        realism: spec.world.realism,
        depth_mm: spec.depth_mm,
        trials: spec.trials,
        seed: spec.seed,
        speeds_mm_s: spec.speeds_mm_s.clone(),
        hand_speeds_mm_s: spec.hand_speeds_mm_s.clone(),
        hand_speed_variation: spec.hand_speed_variation,
        timings: spec.timings.clone(),
        scores,
    })
}

/// A condition's name: the speed, and "hand-held" with its swing.
fn condition(s: &WordsScore) -> String {
    if s.speed_variation > 0.0 {
        format!("{} mm/s hand-held (±{:.0}%)", s.speed_mm_s, 100.0 * s.speed_variation)
    } else {
        format!("{} mm/s", s.speed_mm_s)
    }
}

/// The speed table as Markdown.
pub fn markdown(r: &WordsReport) -> String {
    let mut m = String::new();
    let speeds = r.speeds_mm_s.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(",");
    let hand = r.hand_speeds_mm_s.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(",");
    let timings = r.timings.iter().map(|t| t.to_string()).collect::<Vec<_>>().join(",");
    let realism = format!("{:?}", r.realism).to_lowercase();
    let _ = writeln!(
        m,
        "# Reading words at every speed (SIMULATED)\n\nAll figures on **simulated** scans (virtual Evetac, realism `{realism}`, test sensor builds) of the EV board (two rows: RIGHT LEFT EXIT OPEN, PUSH PULL STOP HELP WATER), {} scans per row and condition, {} mm deep, seed {}. The hand-held rows swing the speed along the row by ±{:.0}% (slow swings of 1-5 Hz) around the mean given. Regenerate: `braille words-report --trials {} --speeds {speeds} --hand-speeds {hand} --hand-variation {} --timings {timings} --realism {realism}` (or `REALISM={realism} bash scripts/words.sh`).\n\nEach architecture reads every scan from its raw event stream alone: the segmentation network on every frame, the character classifier where it says a character is present, the paper's temporal filter, then the spelling. The bins and the filter's gaps are the paper's 10 ms, 70 ms and 1 s at 8 mm/s, scaled by 8 mm/s over the reader's speed, and that speed comes from one of three **timings**:\n\n- **estimated** (the headline; deployable): the reader estimates the speed online from the events (contrast maximisation, `pipeline::speed`), holding the first events until its first estimate and following the median of its last three estimates;\n- **paper**: the paper's fixed 10 ms, 70 ms and 1 s whatever the speed, as its table was made;\n- **given**: the scan's true mean speed handed to the reader by the simulator: an **oracle**, a bound on what estimating the speed costs, not a reader one could deploy.\n\nThe first three metric columns are unconditional, over every printed word: words read right (the read line aligned to the printed line by edit distance), and the word and character error rates (edits over printed words, or over printed characters with spaces). The paper's four metrics follow, each **conditional** on the subset that passed the one before (a word read as two drops out of its denominator). TextBlob is the paper's corrector; the lexicon decoder is ours (Braille dot confusions, the classifier's letter probabilities, insertions and deletions). The paper's column is its ResNet-34 on real Evetac scans with the paper's fixed timing and conditional counting: set beside the **paper**-timing rows' conditional `correct words`, not beside our headline.\n",
        r.trials,
        r.depth_mm,
        r.seed,
        100.0 * r.hand_speed_variation,
        r.trials,
        r.hand_speed_variation,
    );
    let paper_at = |s: &WordsScore, spell: Spell| -> String {
        let p = [8.0, 16.0, 24.0, 32.0].iter().position(|&v| v == s.speed_mm_s);
        match (p, spell) {
            (Some(p), Spell::None) if s.arch == Arch::Resnet && s.speed_variation == 0.0 => {
                format!("{:.3}", PAPER_NONE[p])
            }
            (Some(p), Spell::Textblob) if s.arch == Arch::Resnet && s.speed_variation == 0.0 => {
                format!("{:.3}", PAPER_SPELL[p])
            }
            _ => String::new(),
        }
    };
    for &timing in &r.timings {
        let title = match timing {
            TimingMode::Estimated => "Headline: speed estimated from the events",
            TimingMode::Paper => "The paper's fixed timing (10 ms, 70 ms, 1 s at every speed)",
            TimingMode::Given => "Oracle: the true mean speed given to the reader",
        };
        let _ = writeln!(m, "## {title}\n");
        let _ = writeln!(
            m,
            "| condition | architecture | spelling | **word accuracy (1 - WER)** | percent correct | **WER** | **CER** | words per line | letters per word | correct words | correct letters | paper, correct words (its protocol) |"
        );
        let _ = writeln!(m, "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |");
        for s in r.scores.iter().filter(|s| s.timing == timing) {
            for b in &s.by_spell {
                // a conditional metric whose subset is empty is undefined
                let f = |x: f64| if x.is_finite() { format!("{x:.3}") } else { "–".into() };
                let _ = writeln!(
                    m,
                    "| {} | {} | {:?} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} | {} | {} | {} |",
                    condition(s),
                    s.arch,
                    b.spell,
                    b.word_accuracy,
                    b.percent_correct,
                    b.word_error_rate,
                    b.char_error_rate,
                    f(b.words_per_line),
                    f(b.letters_per_word),
                    f(b.correct_words),
                    f(b.correct_letters),
                    if timing == TimingMode::Paper { paper_at(s, b.spell) } else { String::new() }
                );
            }
        }
        let _ = writeln!(m);
    }
    if !r.unseen.is_empty() {
        let _ = writeln!(
            m,
            "## Unseen words (estimated timing)\n\nA text board of {} rows of words that no training row holds (TextBlob's words ranked {}-{} by frequency; training rows draw from the first {}): `{}`, {} scans per row.\n\n| speed | architecture | spelling | **word accuracy (1 - WER)** | percent correct | **WER** | **CER** | correct words (conditional) |\n| --- | --- | --- | --- | --- | --- | --- | --- |",
            r.unseen_board.split('/').count(),
            corpus::boards::TRAINING_WORDS + 1,
            2 * corpus::boards::TRAINING_WORDS,
            corpus::boards::TRAINING_WORDS,
            r.unseen_board.replace('/', " / "),
            r.unseen_trials
        );
        for s in &r.unseen {
            for b in s.by_spell.iter().filter(|b| b.spell != Spell::Textblob) {
                let _ = writeln!(
                    m,
                    "| {} mm/s | {} | {:?} | {:.3} | {:.3} | {:.3} | {:.3} | {} |",
                    s.speed_mm_s,
                    s.arch,
                    b.spell,
                    b.word_accuracy,
                    b.percent_correct,
                    b.word_error_rate,
                    b.char_error_rate,
                    if b.correct_words.is_finite() { format!("{:.3}", b.correct_words) } else { "–".into() }
                );
            }
        }
        let _ = writeln!(m);
    }
    let _ = writeln!(m, "![word accuracy against speed](words_speed.png)\n");
    let _ = writeln!(m, "## The speed estimate\n");
    let _ = writeln!(
        m,
        "The speed each character was read at (with estimated timing) against the true speed under the sensor then (the simulated motion's speed, with its ripple and swings, at the middle of the character's detections), over every character read; relative error.\n\n| condition | architecture | characters | median | mean absolute | 90th percentile absolute | largest |\n| --- | --- | --- | --- | --- | --- | --- |"
    );
    for s in r.scores.iter().filter(|s| s.timing == TimingMode::Estimated) {
        let e = &s.speed_error;
        let _ = writeln!(
            m,
            "| {} | {} | {} | {:+.1}% | {:.1}% | {:.1}% | {:.1}% |",
            condition(s),
            s.arch,
            e.chars,
            100.0 * e.median,
            100.0 * e.mean_abs,
            100.0 * e.p90_abs,
            100.0 * e.max_abs
        );
    }
    let _ = writeln!(m, "\n## Targets (issue #23: estimated timing, unconditional word accuracy)\n");
    let verdict = |v: f64, target: f64| {
        if !v.is_finite() {
            "not measured".to_string()
        } else if v >= target {
            format!("{v:.3}, met")
        } else {
            format!("{v:.3}, **not met** by {:.3}", target - v)
        }
    };
    let ev: Vec<WordsScore> =
        r.scores.iter().filter(|s| s.timing == TimingMode::Estimated && s.speed_variation == 0.0).cloned().collect();
    for (board, scores) in [("unseen words", &r.unseen), ("EV", &ev)] {
        if scores.is_empty() {
            continue;
        }
        for arch in [Arch::Resnet, Arch::Snn] {
            let wa = |spell: Spell, keep: &dyn Fn(f64) -> bool| -> f64 {
                scores
                    .iter()
                    .filter(|s| s.arch == arch && keep(s.speed_mm_s))
                    .filter_map(|s| s.by_spell.iter().find(|b| b.spell == spell).map(|b| b.word_accuracy))
                    .fold(f64::INFINITY, f64::min)
            };
            let _ = writeln!(
                m,
                "- {board}, {arch}: with the lexicon at least 0.95 at 8-32 mm/s: lowest {}; at least 0.85 at 64 mm/s: {}; without spelling at least 0.85 at 8-32 mm/s: lowest {}.",
                verdict(wa(Spell::Lexicon, &|v| (8.0..=32.0).contains(&v)), 0.95),
                verdict(wa(Spell::Lexicon, &|v| v == 64.0), 0.85),
                verdict(wa(Spell::None, &|v| (8.0..=32.0).contains(&v)), 0.85),
            );
        }
    }
    let _ = writeln!(
        m,
        "\nThe EV board's words are the paper's test words; the `+ words` classifiers were trained on rows of other words (docs/training.md)."
    );
    let _ = writeln!(m, "\n## Time\n");
    let _ = writeln!(
        m,
        "Reading time against the stream's duration on this machine, estimated timing (2 cores, the scans of a condition read in parallel, so the figures include contention; `cargo bench --bench reading` measures one row on a quiet core). Registration delay: stream time from the last event a character's detections used to the frame that registered it (the filter waits 70 ms, scaled, for the segment to end).\n"
    );
    let _ = writeln!(
        m,
        "| condition | architecture | stream (s) | read (s) | share of duration | segmentation (ms) | classifier (ms) | classifier calls | registration delay mean / max (ms) |"
    );
    let _ = writeln!(m, "| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    for s in r.scores.iter().filter(|s| s.timing == TimingMode::Estimated) {
        let _ = writeln!(
            m,
            "| {} | {} | {:.1} | {:.2} | {:.2}% | {:.0} | {:.0} | {} | {:.0} / {:.0} |",
            condition(s),
            s.arch,
            s.stream_s,
            s.read_s,
            100.0 * s.read_s / s.stream_s.max(1e-9),
            s.segmenter_ms,
            s.classifier_ms,
            s.classifier_calls,
            s.registration_delay_ms_mean,
            s.registration_delay_ms_max
        );
    }
    let _ = writeln!(
        m,
        "\n## Letters and places (estimated timing, before spelling)\n\nEvery printed letter scored in the line's character alignment: the five lowest letters, letters by place in the row, printed words by place (percent correct), and the most frequent confusions. The EV board holds few letters (`braille letters-report` reads a board that holds every letter at every place: [letters.md](letters.md)).\n"
    );
    for (board, scores) in [("EV", &r.scores), ("unseen words", &r.unseen)] {
        for s in scores.iter().filter(|s| s.timing == TimingMode::Estimated && s.speed_variation == 0.0) {
            let none = &s.by_spell.iter().find(|b| b.spell == Spell::None).expect("every spelling is scored").counts;
            let _ = writeln!(m, "- {board}, {}, {}: {}", condition(s), s.arch, crate::eval::words::letters_line(none));
        }
    }
    let _ = writeln!(m, "\n## What was read (first two lines per condition and architecture, estimated timing)\n");
    for s in r.scores.iter().filter(|s| s.timing == TimingMode::Estimated) {
        for (t, raw, lex) in s.examples.iter().take(2) {
            let _ = writeln!(m, "- {}, {}: `{t}` read `{raw}`, lexicon `{lex}`", condition(s), s.arch);
        }
    }
    m
}
