//! The paper's speed table on SIMULATED EV scans: both architectures, with and without spelling.

use crate::Progress;
use crate::error::Result;
use crate::words::{WordsScore, WordsSpec, default_models, read_scans, score};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::Spell;
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
    pub depth_mm: f64,
    pub trials: u64,
    pub seed: u64,
    pub speeds_mm_s: Vec<f64>,
    /// Per speed, one score per architecture (ResNet, SNN).
    pub scores: Vec<Vec<WordsScore>>,
}

/// The paper's speed table (with TextBlob), correct words: 8, 16, 24, 32 mm/s.
const PAPER_SPELL: [f64; 4] = [0.903, 0.97, 0.913, 0.971];
const PAPER_NONE: [f64; 4] = [0.876, 0.866, 0.753, 0.685];

/// The paper's speed table on the EV board: every speed read by the shipped models of both
/// architectures under `models` (`speeds` in mm/s, `trials` scans per row and speed).
pub fn words_report(
    models: &Path,
    speeds: &[f64],
    depth_mm: f64,
    trials: u64,
    seed: u64,
    world: &crate::datasets::World,
    progress: &dyn Progress,
) -> Result<WordsReport> {
    let archs = [Arch::Resnet, Arch::Snn];
    let readers = archs
        .iter()
        .map(|&a| {
            let (s, c) = default_models(a, models);
            Ok(ReaderModels::load(&s, &c, SnnRunner::Sliding)?)
        })
        .collect::<Result<Vec<_>>>()?;
    let refs: Vec<&ReaderModels> = readers.iter().collect();
    let mut scores = Vec::new();
    for &speed in speeds {
        let spec = WordsSpec { board: BoardKind::Ev, speed_mm_s: speed, depth_mm, trials, seed, world: world.clone() };
        let lines = read_scans(&spec, &refs, progress)?;
        scores.push((0..archs.len()).map(|k| score(archs[k], k, &lines, speed, depth_mm)).collect());
    }
    Ok(WordsReport {
        data: "simulated (virtual Evetac)",
        board: "EV",
        depth_mm,
        trials,
        seed,
        speeds_mm_s: speeds.to_vec(),
        scores,
    })
}

/// The speed table as Markdown.
pub fn markdown(r: &WordsReport) -> String {
    let mut m = String::new();
    let _ = writeln!(
        m,
        "# Reading words at four speeds (SIMULATED)\n\nAll figures on **simulated** scans (virtual Evetac) of the EV board (two rows: RIGHT LEFT EXIT OPEN, PUSH PULL STOP HELP WATER), {} scans per row and speed, {} mm deep, seed {}. Regenerate: `braille words-report --trials {}` (or `bash scripts/words.sh`).\n\nEach architecture reads every scan from the raw event stream: the segmentation network on every frame, the character classifier where it says a character is present, the paper's temporal filter (4 frames, 70 ms, 1 s at 8 mm/s; durations scale with 8 mm/s / speed), then the spelling. The first three columns are unconditional, over every printed word: words read right (aligned to the printed line by edit distance), and the word and character error rates (edits over printed words, or printed characters with spaces). The paper's four metrics follow, each on the subset that passed the one before. TextBlob is the paper's corrector; the lexicon decoder is ours (Braille dot confusions, the classifier's letter probabilities, insertions and deletions).\n",
        r.trials, r.depth_mm, r.seed, r.trials
    );
    let _ = writeln!(
        m,
        "| speed | architecture | spelling | **word accuracy** | **WER** | **CER** | words per line | letters per word | correct words | correct letters | paper, correct words |"
    );
    let _ = writeln!(m, "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    for (i, row) in r.scores.iter().enumerate() {
        let speed = r.speeds_mm_s[i];
        let paper_idx = [8.0, 16.0, 24.0, 32.0].iter().position(|&s| s == speed);
        for s in row {
            for b in &s.by_spell {
                let paper = match (paper_idx, b.spell) {
                    (Some(p), Spell::None) if s.arch == Arch::Resnet => format!("{:.3}", PAPER_NONE[p]),
                    (Some(p), Spell::Textblob) if s.arch == Arch::Resnet => format!("{:.3}", PAPER_SPELL[p]),
                    _ => String::new(),
                };
                let _ = writeln!(
                    m,
                    "| {speed} mm/s | {} | {:?} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {paper} |",
                    s.arch,
                    b.spell,
                    b.word_accuracy,
                    b.word_error_rate,
                    b.char_error_rate,
                    b.words_per_line,
                    b.letters_per_word,
                    b.correct_words,
                    b.correct_letters
                );
            }
        }
    }
    let _ = writeln!(m, "\n![correct words against speed](words_speed.png)\n");
    let _ = writeln!(m, "## Targets (issue #5)\n");
    for arch in [Arch::Resnet, Arch::Snn] {
        let get = |spell: Spell| -> Vec<f64> {
            r.scores
                .iter()
                .filter_map(|row| row.iter().find(|s| s.arch == arch))
                .map(|s| s.by_spell.iter().find(|b| b.spell == spell).map_or(f64::NAN, |b| b.correct_words))
                .collect()
        };
        let (lex, none) = (get(Spell::Lexicon), get(Spell::None));
        let lo = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let _ = writeln!(
            m,
            "- {arch}: correct words with the lexicon decoder at least 0.97 at every speed: lowest {:.3}, {}; without spelling at least 0.90: lowest {:.3}, {}.",
            lo(&lex),
            if lo(&lex) >= 0.97 { "met" } else { "**not met**" },
            lo(&none),
            if lo(&none) >= 0.90 { "met" } else { "**not met**" }
        );
    }
    let _ = writeln!(m, "\n## Time\n");
    let _ = writeln!(
        m,
        "Reading time against the stream's duration on this machine (2 cores, both scans of a speed read in parallel, so the figures include contention; `cargo bench --bench reading` measures one row on a quiet core). Registration delay: stream time from the last event a character's detections used to the frame that registered it (the filter waits 70 ms, scaled, for the segment to end).\n"
    );
    let _ = writeln!(
        m,
        "| speed | architecture | stream (s) | read (s) | share of duration | segmentation (ms) | classifier (ms) | classifier calls | registration delay mean / max (ms) |"
    );
    let _ = writeln!(m, "| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    for (i, row) in r.scores.iter().enumerate() {
        for s in row {
            let _ = writeln!(
                m,
                "| {} mm/s | {} | {:.1} | {:.2} | {:.2}% | {:.0} | {:.0} | {} | {:.0} / {:.0} |",
                r.speeds_mm_s[i],
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
    }
    let _ = writeln!(m, "\n## What was read (first three lines per speed and architecture)\n");
    for (i, row) in r.scores.iter().enumerate() {
        for s in row {
            for (t, raw, lex) in s.examples.iter().take(3) {
                let _ = writeln!(m, "- {} mm/s, {}: `{t}` read `{raw}`, lexicon `{lex}`", r.speeds_mm_s[i], s.arch);
            }
        }
    }
    m
}
