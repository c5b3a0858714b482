//! The UEB readers' report (SIMULATED, docs/braille.md): both architectures' cell readers
//! (`models/REALISM/ueb/`) on every cell of a random cell board, cell by cell, and on contracted
//! sentences no training row holds at a sweep of speeds, scored on cells and on the print read
//! back, exactly and blind to case and punctuation. `braille words-report --braille ueb-g2`.

use crate::Progress;
use crate::error::Result;
use crate::eval::chars::CharEval;
use crate::eval::ueb::UebScore;
use crate::eval::words::WordsSpec;
use corpus::boards::HeldOut;
use corpus::windows::{CharSetSpec, Task};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::code::BrailleCode;
use pipeline::reader::{Spell, TimingMode};
use serde::Serialize;
use sim::BoardKind;
use snn::model_file::Arch;
use std::path::Path;

/// What the report reads.
#[derive(Debug, Clone, Serialize)]
pub struct UebReportSpec {
    pub code: BrailleCode,
    /// Test: RCB and UEB-SENTENCES (reported figures); validation: VCB and VAL-UEB (choices).
    pub held_out: HeldOut,
    /// The cell board's speed, depth and scans per row.
    pub cell_speed_mm_s: f64,
    pub cell_depth_mm: f64,
    pub cell_trials: u64,
    /// The sentences' speeds, depth and scans per row.
    pub speeds_mm_s: Vec<f64>,
    pub depth_mm: f64,
    pub trials: u64,
    pub timing: TimingMode,
    /// Whether the readers place cells of one dot column on the cell grid (`pipeline::grid`;
    /// the cell board's table shows the classifier alone beside it either way).
    pub cell_grid: bool,
    pub seed: u64,
    pub world: corpus::world::World,
}

/// One cell of the cell board: how often its windows were read right (windows found; a scan
/// the labeler miscounted gives none), and what it was read as most when wrong.
#[derive(Debug, Clone, Serialize)]
pub struct CellRow {
    pub cell: String,
    pub windows: u32,
    pub read_right: u32,
    pub most_read_as: Option<(String, u32)>,
}

/// Both architectures' cells and sentences.
#[derive(Debug, Clone, Serialize)]
pub struct UebReport {
    pub spec: UebReportSpec,
    pub cells: Vec<CharEval>,
    /// Per architecture (SNN, ResNet), per speed.
    pub sentences: Vec<UebScore>,
}

/// The architectures, in the tables' order.
const ARCHS: [Arch; 2] = [Arch::Snn, Arch::Resnet];

/// Reads the report's boards with the cell readers in `models` (`models/REALISM/`, whose `ueb/`
/// holds them).
pub fn ueb_report(models: &Path, spec: &UebReportSpec, progress: &dyn Progress) -> Result<UebReport> {
    let cell_board = match spec.held_out {
        HeldOut::Test => BoardKind::Rcb,
        HeldOut::Validation => BoardKind::Vcb,
    };
    let sentences = corpus::boards::sentence_board(spec.held_out, spec.code)?;
    let mut r = UebReport { spec: spec.clone(), cells: Vec::new(), sentences: Vec::new() };
    for arch in ARCHS {
        let files = pipeline::shipped::reader_for(models, arch, spec.code);
        let cells = CharSetSpec {
            boards: vec![cell_board.clone()],
            speed_mm_s: spec.cell_speed_mm_s,
            depth_mm: spec.cell_depth_mm,
            trials: spec.cell_trials,
            seed: spec.seed,
            task: Task::Cells,
            jitter_ms: 0.0,
            world: spec.world.clone(),
            blank_cells: false,
            sweep: None,
        };
        r.cells.push(crate::eval::chars::eval(&files.classifier, &cells, progress)?);
        let mut readers = ReaderModels::load(&files.segmenter, &files.classifier, SnnRunner::Sliding)?;
        if !spec.cell_grid {
            readers.cell_grid = None;
        }
        for &speed_mm_s in &spec.speeds_mm_s {
            let words = WordsSpec {
                board: sentences.kind.clone(),
                speed_mm_s,
                speed_variation: 0.0,
                depth_mm: spec.depth_mm,
                trials: spec.trials,
                seed: spec.seed,
                world: spec.world.clone(),
            };
            r.sentences.push(crate::eval::ueb::eval_ueb(&sentences, &words, &readers, &files, spec.timing, progress)?);
        }
    }
    Ok(r)
}

/// The cell board's cells from `e`'s confusion matrix (rows: printed, columns: read), in class
/// order.
pub fn cell_rows(e: &CharEval) -> Vec<CellRow> {
    let names = Task::Cells.classes();
    e.score
        .confusion
        .iter()
        .enumerate()
        .map(|(k, row)| {
            let windows = row.iter().sum();
            let read_right = row.get(k).copied().unwrap_or(0);
            let most_read_as = row
                .iter()
                .enumerate()
                .filter(|&(j, &n)| j != k && n > 0)
                .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(&a.0)))
                .map(|(j, &n)| (names.get(j).map_or_else(|| j.to_string(), |s| s.to_string()), n));
            CellRow {
                cell: names.get(k).map_or_else(|| k.to_string(), |s| s.to_string()),
                windows,
                read_right,
                most_read_as,
            }
        })
        .collect()
}

fn spell_score(s: &UebScore, spell: Spell) -> Option<&crate::eval::ueb::PrintScore> {
    s.by_spell.iter().find(|p| p.spell == spell)
}

/// The report as Markdown: the cells, the cells read worst, the sentences against speed.
pub fn markdown(r: &UebReport) -> String {
    let s = &r.spec;
    let (cell_board, sentence_board) = match s.held_out {
        HeldOut::Test => ("RCB", "UEB-SENTENCES"),
        HeldOut::Validation => ("VCB", "VAL-UEB"),
    };
    let mut md = format!(
        "# UEB readers (SIMULATED, {})\n\nMade by `braille words-report --braille {} --realism {}{}{}` ({} sensor builds, seed {}; \
         the cell readers of models/{}/ueb/). Reading times were measured beside whatever else ran; the cost against the \
         letters' reader is [cost.md](cost.md) (`bash scripts/ueb/cost.sh`).\n\n",
        s.world.realism,
        s.code,
        s.world.realism,
        if s.held_out == HeldOut::Validation { " --validation" } else { "" },
        if s.cell_grid { "" } else { " --no-cell-grid" },
        if s.held_out == HeldOut::Validation { "training" } else { "test" },
        s.seed,
        s.world.realism,
    );
    md += &format!(
        "## Cells: {cell_board}, {} mm/s, {} mm, {} scans a row\n\n\
         A cell of one dot column is put in the column the cell grid gives it (`pipeline::grid`: its distance from \
         its two-column neighbours, at the speed estimated from the scan's events); the classifier's own reading \
         of the window beside it.\n\n\
         | architecture | printed cells | read right, over every printed cell | over the windows found | \
         the classifier alone, over every printed cell | moved by the grid | scans miscounted |\n\
         | --- | --- | --- | --- | --- | --- | --- |\n",
        s.cell_speed_mm_s, s.cell_depth_mm, s.cell_trials
    );
    for e in &r.cells {
        md += &format!(
            "| {} | {} | {:.2}% | {:.2}% | {} | {} | {} of {} |\n",
            e.arch,
            e.printed,
            100.0 * e.accuracy_all,
            100.0 * e.score.accuracy,
            e.grid.as_ref().map_or("-".into(), |g| format!("{:.2}%", 100.0 * g.accuracy_all_classifier_alone)),
            e.grid.as_ref().map_or("-".into(), |g| g.moved.to_string()),
            e.skipped_scans,
            e.scans
        );
    }
    md += "\nThe cells read worst (over the windows found), each architecture's ten lowest, with what each was \
           read as most:\n\n| architecture | cell | windows | read right | read as most |\n| --- | --- | --- | --- | --- |\n";
    for e in &r.cells {
        let mut rows = cell_rows(e);
        rows.retain(|c| c.windows > 0);
        rows.sort_by(|a, b| {
            let (fa, fb) = (a.read_right as f64 / a.windows as f64, b.read_right as f64 / b.windows as f64);
            fa.total_cmp(&fb).then(a.cell.cmp(&b.cell))
        });
        for c in rows.iter().take(10) {
            md += &format!(
                "| {} | {} | {} | {:.1}% | {} |\n",
                e.arch,
                c.cell,
                c.windows,
                100.0 * c.read_right as f64 / c.windows as f64,
                c.most_read_as.as_ref().map_or("-".to_string(), |(n, k)| format!("{n} ({k})"))
            );
        }
    }
    md += &format!(
        "\n## Contracted sentences: {sentence_board} ({}), {} mm, {} timing, {} scans a row\n\n\
         Word accuracy is 1 - WER over every printed word (inserted words count); exact compares case, digits and \
         punctuation; blind compares lower-case letters and digits only.\n\n\
         | architecture | speed | cells printed | cell error rate | words exact, as read | exact, TextBlob | exact, lexicon | \
         blind, lexicon | reading s per s of stream | lexicon, ms per s of stream |\n\
         | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n",
        s.code, s.depth_mm, s.timing, s.trials
    );
    let acc = |w: &UebScore, spell: Spell, blind: bool| {
        spell_score(w, spell)
            .map_or("-".to_string(), |p| format!("{:.3}", if blind { p.blind_word_accuracy } else { p.word_accuracy }))
    };
    for w in &r.sentences {
        md += &format!(
            "| {} | {} mm/s | {} | {:.4} | {} | {} | {} | {} | {:.4} | {:.3} |\n",
            w.arch,
            w.speed_mm_s,
            w.cells_printed,
            w.cell_error_rate,
            acc(w, Spell::None, false),
            acc(w, Spell::Textblob, false),
            acc(w, Spell::Lexicon, false),
            acc(w, Spell::Lexicon, true),
            w.read_s / w.stream_s.max(1e-9),
            1000.0 * w.spell_lexicon_s / w.stream_s.max(1e-9),
        );
    }
    let middle = s.speeds_mm_s.get(s.speeds_mm_s.len() / 2).copied();
    if let Some(v) = middle {
        md += &format!("\n## Examples ({v} mm/s, trial 0, lexicon): print, cells read, print read\n\n");
        for w in r.sentences.iter().filter(|w| w.speed_mm_s == v) {
            for (print, cells, read) in w.examples.iter().take(3) {
                md += &format!("- {}: `{print}` -> `{cells}` -> `{read}`\n", w.arch);
            }
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::chars::Score;

    #[test]
    fn the_cells_read_worst_come_first_with_what_they_were_read_as() {
        // ⠈ (dots 4: class 7) read as ⠁ (class 0) three times in four; every other cell right
        let mut confusion = vec![vec![0u32; 63]; 63];
        for (k, row) in confusion.iter_mut().enumerate() {
            row[k] = 4;
        }
        confusion[7][7] = 1;
        confusion[7][0] = 3;
        let score = Score {
            n: 252,
            accuracy: 249.0 / 252.0,
            macro_f1: 0.99,
            loss: 0.1,
            confusion,
            synops_per_sample: None,
            spikes_per_sample: None,
            input_events_per_sample: None,
            accuracy_async: None,
            predictions: Vec::new(),
            first_trial: Vec::new(),
        };
        let e = CharEval {
            data: "simulated (virtual Evetac)",
            arch: Arch::Snn,
            model: "m".into(),
            board: "RCB".into(),
            speed_mm_s: 8.0,
            depth_mm: 1.5,
            scan_seed: Some(1),
            sensor_builds: vec![101, 102],
            scans: 4,
            skipped_scans: 0,
            printed: 252,
            accuracy_all: 249.0 / 252.0,
            score,
            grid: Some(crate::eval::chars::GridEffect {
                moved: 3,
                accuracy_classifier_alone: 0.9,
                accuracy_all_classifier_alone: 0.9,
            }),
        };
        let rows = cell_rows(&e);
        assert_eq!(rows.len(), 63);
        assert_eq!((rows[7].cell.as_str(), rows[7].windows, rows[7].read_right), ("⠈", 4, 1));
        assert_eq!(rows[7].most_read_as, Some(("⠁".to_string(), 3)));
        assert_eq!(rows[0].most_read_as, None);
        let r = UebReport {
            spec: UebReportSpec {
                code: BrailleCode::UebGrade2,
                held_out: HeldOut::Test,
                cell_speed_mm_s: 8.0,
                cell_depth_mm: 1.5,
                cell_trials: 1,
                speeds_mm_s: vec![16.0],
                depth_mm: 1.0,
                trials: 1,
                timing: TimingMode::Estimated,
                cell_grid: true,
                seed: 1,
                world: corpus::world::World::test(sim::Realism::Nominal),
            },
            cells: vec![e],
            sentences: Vec::new(),
        };
        let md = markdown(&r);
        // the cell grid's figures beside the classifier's own
        assert!(md.contains("| snn | 252 | 98.81% | 98.81% | 90.00% | 3 | 0 of 4 |"), "{md}");
        let worst = md.lines().find(|l| l.starts_with("| snn | ⠈")).unwrap();
        assert_eq!(worst, "| snn | ⠈ | 4 | 25.0% | ⠁ (3) |");
        assert!(md.find("| snn | ⠈").unwrap() < md.find("| snn | ⠁ |").unwrap_or(usize::MAX));
    }
}
