//! Every letter at every place in a row: both architectures read the all-letters board
//! (`ALL-LETTERS`, or `VAL-LETTERS` for choices) over speed and depth, with per-letter accuracy,
//! the confusions, and accuracy by the letter's and the word's place in the row (SIMULATED;
//! `braille letters-report`).

use crate::Progress;
use crate::error::Result;
use crate::eval::scoring::{LetterPlace, Tally};
use crate::eval::words::{WordsScore, WordsSpec, read_scans, score};
use corpus::boards::{AllLetters, HeldOut};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{Spell, TimingMode};
use serde::Serialize;
use snn::model_file::Arch;
use std::fmt::Write as _;
use std::path::PathBuf;

/// What the report reads.
#[derive(Debug, Clone)]
pub struct LettersReportSpec {
    /// The test board (`ALL-LETTERS`, test sensor builds, test seed) or the validation one
    /// (`VAL-LETTERS`, training builds, validation seed): `world` and `seed` say which builds
    /// and scans.
    pub held_out: HeldOut,
    pub speeds_mm_s: Vec<f64>,
    pub depths_mm: Vec<f64>,
    /// Scans per row at each condition of the grid.
    pub trials: u64,
    /// The condition of the per-letter table, read with `focus_trials` scans per row (in place of
    /// `trials`, so that each letter is read often enough to be scored on its own).
    pub focus_speed_mm_s: f64,
    pub focus_depth_mm: f64,
    pub focus_trials: u64,
    pub seed: u64,
    pub world: corpus::world::World,
    /// Only the board's first rows (a quick check; `None`: every row).
    pub first_rows: Option<usize>,
}

/// The report's data.
#[derive(Debug, Clone, Serialize)]
pub struct LettersReport {
    pub data: &'static str,
    /// `ALL-LETTERS` or `VAL-LETTERS`, its rows, and the (letter, place) cells its words could not
    /// fill [`corpus::boards::ALL_LETTERS_TIMES`] times.
    pub board: &'static str,
    /// The rows read: every row of the board unless the run was cut short (`first_rows`).
    pub rows: Vec<String>,
    pub board_rows: usize,
    pub short: Vec<(char, LetterPlace, usize)>,
    pub realism: sim::Realism,
    pub sensor_builds: Vec<u64>,
    pub seed: u64,
    /// The grid of conditions; the per-letter tables' condition is read beside it when the grid
    /// does not hold it.
    pub speeds_mm_s: Vec<f64>,
    pub depths_mm: Vec<f64>,
    pub trials: u64,
    pub focus_speed_mm_s: f64,
    pub focus_depth_mm: f64,
    pub focus_trials: u64,
    /// The networks each architecture read with.
    pub readers: Vec<(Arch, PathBuf, PathBuf)>,
    /// Every condition (speed, then depth) read by both architectures with estimated timing.
    pub scores: Vec<WordsScore>,
}

/// Reads the all-letters board at every speed and depth of `spec` with each reader (loaded from
/// its segmentation network and classifier: both architectures' shipped pairs, or candidates).
pub fn letters_report(
    readers: &[pipeline::shipped::ReaderFiles],
    spec: &LettersReportSpec,
    progress: &dyn Progress,
) -> Result<LettersReport> {
    let models = readers
        .iter()
        .map(|f| Ok(ReaderModels::load(&f.segmenter, &f.classifier, SnnRunner::Sliding)?))
        .collect::<Result<Vec<_>>>()?;
    let refs: Vec<&ReaderModels> = models.iter().collect();
    let board: &AllLetters = corpus::boards::all_letters(spec.held_out);
    let rows = &board.rows[..spec.first_rows.unwrap_or(usize::MAX).min(board.rows.len())];
    // the grid, then the per-letter tables' condition where the grid does not hold it
    let mut conditions: Vec<(f64, f64)> =
        spec.depths_mm.iter().flat_map(|&d| spec.speeds_mm_s.iter().map(move |&v| (d, v))).collect();
    if !conditions.contains(&(spec.focus_depth_mm, spec.focus_speed_mm_s)) {
        conditions.push((spec.focus_depth_mm, spec.focus_speed_mm_s));
    }
    let mut scores = Vec::new();
    for (depth_mm, speed_mm_s) in conditions {
        let focus = speed_mm_s == spec.focus_speed_mm_s && depth_mm == spec.focus_depth_mm;
        let ws = WordsSpec {
            board: sim::BoardKind::Text(rows.join("/")),
            speed_mm_s,
            speed_variation: 0.0,
            depth_mm,
            trials: if focus { spec.focus_trials } else { spec.trials },
            seed: spec.seed,
            world: spec.world.clone(),
        };
        let lines = read_scans(&ws, &refs, &[TimingMode::Estimated], progress)?;
        for (k, m) in models.iter().enumerate() {
            scores.push(score(m.classifier.arch(), TimingMode::Estimated, k, &lines, ws.condition()));
        }
    }
    Ok(LettersReport {
        data: "simulated (virtual Evetac)",
        board: spec.held_out.board_name(),
        rows: rows.to_vec(),
        board_rows: board.rows.len(),
        short: board.short.clone(),
        realism: spec.world.realism,
        sensor_builds: spec.world.sensors.clone(),
        seed: spec.seed,
        speeds_mm_s: spec.speeds_mm_s.clone(),
        depths_mm: spec.depths_mm.clone(),
        trials: spec.trials,
        focus_speed_mm_s: spec.focus_speed_mm_s,
        focus_depth_mm: spec.focus_depth_mm,
        focus_trials: spec.focus_trials,
        readers: readers
            .iter()
            .zip(&models)
            .map(|(f, m)| (m.classifier.arch(), f.segmenter.clone(), f.classifier.clone()))
            .collect(),
        scores,
    })
}

/// Per-letter accuracy must reach this for every letter (issue #47).
pub const LETTER_TARGET: f64 = 0.97;

impl LettersReport {
    /// The score of `arch` at a condition.
    pub fn get(&self, arch: Arch, speed_mm_s: f64, depth_mm: f64) -> Option<&WordsScore> {
        self.scores.iter().find(|s| s.arch == arch && s.speed_mm_s == speed_mm_s && s.depth_mm == depth_mm)
    }

    fn archs(&self) -> Vec<Arch> {
        let mut a: Vec<Arch> = self.readers.iter().map(|r| r.0).collect();
        a.dedup();
        a
    }
}

fn spelled(s: &WordsScore, spell: Spell) -> &crate::eval::words::SpellScore {
    s.by_spell.iter().find(|b| b.spell == spell).expect("every spelling is scored")
}

fn pct(t: Tally) -> String {
    t.percent()
}

/// The report as Markdown.
pub fn markdown(r: &LettersReport) -> String {
    let mut m = String::new();
    let realism = format!("{:?}", r.realism).to_lowercase();
    let (speeds, depths) = (&r.speeds_mm_s, &r.depths_mm);
    let list = |v: &[f64]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(",");
    let validation = r.board == "VAL-LETTERS";
    let held_out_builds = r.sensor_builds[..] == corpus::world::VALIDATION_SENSORS[..];
    let _ = writeln!(
        m,
        "# Every letter at every place in a row (SIMULATED)\n\n{}All figures on **simulated** scans (virtual Evetac, realism `{realism}`, sensor builds {:?}{}) of the `{}` board: {} rows of held-out words{} chosen by a fixed rule so that every letter stands at least {} times at a row's start, a later word's start, inside a word and at a word's end (`corpus::boards::all_letters_rows`). Cells its words could not fill: {}. Seed {}; {} scans per row at each condition, {} at {} mm/s and {} mm (the per-letter tables). Each architecture reads every scan from its raw events with the speed estimated from them. Regenerate: `braille letters-report --realism {realism} --speeds {} --depths {} --trials {} --focus-trials {}{}{}`.\n",
        if r.rows.len() < r.board_rows {
            format!("**A quick check: the board's first {} rows of {} only.** ", r.rows.len(), r.board_rows)
        } else {
            String::new()
        },
        r.sensor_builds,
        match (validation, held_out_builds) {
            (true, false) => ", the training builds: a validation board, for choices",
            (true, true) =>
                ", builds held out of training and test: a validation board, for choices on a sensor never trained on",
            (false, _) => ", never trained on",
        },
        r.board,
        r.board_rows,
        if validation {
            " (TextBlob's words ranked 6001-9000 by frequency, and every other word past 9000: none a training, test or EV word)"
        } else {
            " (TextBlob's words ranked 3001-6000 by frequency, the unseen test words, and every other word past 9000: none a training, validation or EV word)"
        },
        corpus::boards::ALL_LETTERS_TIMES,
        if r.short.is_empty() {
            "none".to_string()
        } else {
            r.short.iter().map(|(c, p, k)| format!("{c} at a {} ({k} times)", p.name())).collect::<Vec<_>>().join(", ")
        },
        r.seed,
        r.trials,
        r.focus_trials,
        r.focus_speed_mm_s,
        r.focus_depth_mm,
        list(speeds),
        list(depths),
        r.trials,
        r.focus_trials,
        match (validation, held_out_builds) {
            (true, false) => " --validation",
            (true, true) => " --validation --sensor-builds validation",
            (false, _) => "",
        },
        if r.rows.len() < r.board_rows { format!(" --rows {}", r.rows.len()) } else { String::new() },
    );
    for (arch, seg, cls) in &r.readers {
        let _ = writeln!(m, "- {arch}: segmentation `{}`, classifier `{}`", seg.display(), cls.display());
    }
    let archs = r.archs();
    let focus: Vec<&WordsScore> =
        archs.iter().filter_map(|&a| r.get(a, r.focus_speed_mm_s, r.focus_depth_mm)).collect();
    if !focus.is_empty() {
        let _ = writeln!(
            m,
            "\n## Per letter at {} mm/s and {} mm\n\nEvery printed letter, read right when the line's characters aligned to the printed ones match it (the reader's letters, before spelling). Below {:.0}% in bold.\n",
            r.focus_speed_mm_s,
            r.focus_depth_mm,
            100.0 * LETTER_TARGET
        );
        let head: Vec<String> = focus.iter().map(|s| format!("{}", s.arch)).collect();
        let _ = writeln!(m, "| letter | printed | {} |", head.join(" | "));
        let _ = writeln!(m, "| --- | --- |{}", " --- |".repeat(focus.len()));
        for k in 0..26 {
            let printed = spelled(focus[0], Spell::None).counts.letter_scores.by_letter[k].printed;
            let cells: Vec<String> = focus
                .iter()
                .map(|s| {
                    let t = spelled(s, Spell::None).counts.letter_scores.by_letter[k];
                    if t.printed > 0 && t.rate() < LETTER_TARGET { format!("**{}**", pct(t)) } else { pct(t) }
                })
                .collect();
            let _ = writeln!(m, "| {} | {printed} | {} |", (b'A' + k as u8) as char, cells.join(" | "));
        }
        let _ = writeln!(m, "\n### The most frequent confusions (printed → read; ␣ a split word, ∅ nothing read)\n");
        for s in &focus {
            let c = spelled(s, Spell::None).counts.letter_scores.confusions();
            let top: Vec<String> =
                c.iter().take(12).map(|p| format!("{}→{} {}", p.printed, p.read_as("␣", "∅"), p.count)).collect();
            let _ = writeln!(m, "- {}: {}", s.arch, if top.is_empty() { "none".into() } else { top.join(", ") });
        }
        let _ = writeln!(
            m,
            "\n### By place in the row\n\nLetters (before spelling) by where they stand; *the same letters at a later word's start*: what the row-start letters score at later words' starts, each letter weighted as printed at row starts (the place's effect with the letters held fixed: row starts hold every letter alike, later word starts mostly frequent ones). Words by their place in the row, read right in the line's word alignment (percent correct: an inserted word has no printed place), without spelling and with the lexicon. Each row's first word is the most frequent word beginning with its letter.\n\n| architecture | row start | the same letters at a later word's start | word start | middle | word end | first word | middle words | last word | first word, lexicon | middle, lexicon | last, lexicon |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
        );
        for s in &focus {
            let (none, lex) = (&spelled(s, Spell::None).counts, &spelled(s, Spell::Lexicon).counts);
            let l = &none.letter_scores;
            let _ = writeln!(
                m,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                s.arch,
                pct(l.at(LetterPlace::RowStart)),
                {
                    let (_, there) = l.place_against(LetterPlace::RowStart, LetterPlace::WordStart);
                    if there.is_finite() { format!("{:.1}%", 100.0 * there) } else { "–".into() }
                },
                pct(l.at(LetterPlace::WordStart)),
                pct(l.at(LetterPlace::Middle)),
                pct(l.at(LetterPlace::WordEnd)),
                pct(none.word_places.first),
                pct(none.word_places.middle),
                pct(none.word_places.last),
                pct(lex.word_places.first),
                pct(lex.word_places.middle),
                pct(lex.word_places.last),
            );
        }
    }
    let _ = writeln!(
        m,
        "\n## Word accuracy (1 - WER) over speed and depth\n\nEvery printed word; inserted words count. Without spelling / with the lexicon decoder.\n"
    );
    let _ = writeln!(m, "| depth | speed | {} |", archs.iter().map(|a| format!("{a}")).collect::<Vec<_>>().join(" | "));
    let _ = writeln!(m, "| --- | --- |{}", " --- |".repeat(archs.len()));
    for &d in depths {
        for &v in speeds {
            let cells: Vec<String> = archs
                .iter()
                .map(|&a| match r.get(a, v, d) {
                    Some(s) => format!(
                        "{:.3} / {:.3}",
                        spelled(s, Spell::None).word_accuracy,
                        spelled(s, Spell::Lexicon).word_accuracy
                    ),
                    None => "–".into(),
                })
                .collect();
            let _ = writeln!(m, "| {d} mm | {v} mm/s | {} |", cells.join(" | "));
        }
    }
    let _ = writeln!(m, "\n## Targets (issue #47)\n");
    for line in targets(r) {
        let _ = writeln!(m, "- {line}");
    }
    let _ =
        writeln!(m, "\n## What was read (first three rows at {} mm/s, {} mm)\n", r.focus_speed_mm_s, r.focus_depth_mm);
    for s in &focus {
        for (t, raw, lex) in s.examples.iter().take(3) {
            let _ = writeln!(m, "- {}: `{t}` read `{raw}`, lexicon `{lex}`", s.arch);
        }
    }
    m
}

/// The targets, each with its verdict.
pub fn targets(r: &LettersReport) -> Vec<String> {
    let mut out = Vec::new();
    let verdict = |ok: bool| if ok { "met" } else { "**not met**" };
    for arch in r.archs() {
        if let Some(s) = r.get(arch, r.focus_speed_mm_s, r.focus_depth_mm) {
            let l = &spelled(s, Spell::None).counts.letter_scores;
            let low: Vec<String> = (0..26)
                .filter(|&k| l.by_letter[k].printed > 0 && l.by_letter[k].rate() < LETTER_TARGET)
                .map(|k| format!("{} {}", (b'A' + k as u8) as char, pct(l.by_letter[k])))
                .collect();
            out.push(format!(
                "{arch}: every letter at least {:.0}% at {} mm/s, {} mm: {} ({})",
                100.0 * LETTER_TARGET,
                r.focus_speed_mm_s,
                r.focus_depth_mm,
                verdict(low.is_empty()),
                if low.is_empty() { "every letter".to_string() } else { format!("below: {}", low.join(", ")) }
            ));
            let none = &spelled(s, Spell::None).counts;
            let first = none.word_places.first.rate();
            let mut rest = none.word_places.middle;
            rest.printed += none.word_places.last.printed;
            rest.right += none.word_places.last.right;
            let (here, there) = l.place_against(LetterPlace::RowStart, LetterPlace::WordStart);
            out.push(format!(
                "{arch}: the first word of a row read as often as the rest, within 2 points (without spelling): {:.1}% against {:.1}%: {} (letters at a row's start {:.1}%, the same letters at a later word's start {:.1}%)",
                100.0 * first,
                100.0 * rest.rate(),
                verdict(first >= rest.rate() - 0.02),
                100.0 * here,
                100.0 * there
            ));
        }
    }
    let (snn, resnet) = (Arch::Snn, Arch::Resnet);
    let mut worst_gap: Option<(f64, f64, f64)> = None;
    let mut worst_none: Option<(f64, f64, f64)> = None;
    for s in r.scores.iter().filter(|s| s.arch == snn) {
        let snn_lex = spelled(s, Spell::Lexicon).word_accuracy;
        if let Some(c) = r.get(resnet, s.speed_mm_s, s.depth_mm) {
            let gap = spelled(c, Spell::Lexicon).word_accuracy - snn_lex;
            if worst_gap.is_none_or(|w| gap > w.0) {
                worst_gap = Some((gap, s.speed_mm_s, s.depth_mm));
            }
        }
        let none = spelled(s, Spell::None).word_accuracy;
        if worst_none.is_none_or(|w| none < w.0) {
            worst_none = Some((none, s.speed_mm_s, s.depth_mm));
        }
    }
    if let Some((gap, v, d)) = worst_gap {
        out.push(format!(
            "SNN word accuracy with the lexicon within 1 point of the ResNet's at every condition: the ResNet's largest lead {:+.1} points ({}) at {v} mm/s, {d} mm: {}",
            100.0 * gap,
            if gap > 0.0 { "the ResNet ahead" } else { "the SNN level or ahead at every condition" },
            verdict(gap <= 0.01)
        ));
    }
    if let Some((w, v, d)) = worst_none {
        out.push(format!(
            "SNN word accuracy without spelling at least 0.9 at every condition: lowest {w:.3} at {v} mm/s, {d} mm: {}",
            verdict(w >= 0.9)
        ));
    }
    out
}
