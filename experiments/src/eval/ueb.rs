//! Reading print written in Unified English Braille on SIMULATED scans (`braille eval words
//! --braille ueb-g2`): each reader reads every scan of a print board from its raw event stream;
//! the cells it registers are scored against the printed cells, and each word's print (cells
//! back-translated by the code, with each spelling) against the printed words: exactly (case,
//! digits and punctuation count) and blind to case and punctuation, beside.

use crate::Progress;
use crate::error::Result;
use crate::eval::scoring::WordMetrics;
use crate::eval::words::{SPELLS, WordsSpec, read_scans};
use corpus::boards::PrintBoard;
use pipeline::classify::ReaderModels;
use pipeline::code::BrailleCode;
use pipeline::reader::{Spell, Speller, TimingMode};
use serde::Serialize;
use snn::model_file::Arch;

/// One spelling's words against the print.
#[derive(Debug, Clone, Serialize)]
pub struct PrintScore {
    pub spell: Spell,
    /// Exact: word accuracy `1 - WER` over every printed word (inserted words count), WER, and
    /// the character error rate of the print.
    pub word_accuracy: f64,
    pub word_error_rate: f64,
    pub char_error_rate: f64,
    /// Blind to case and punctuation (each word lower case, letters and digits only; words of
    /// punctuation alone left out on both sides).
    pub blind_word_accuracy: f64,
    pub blind_word_error_rate: f64,
}

/// A reader of a Braille code on a print board.
#[derive(Debug, Clone, Serialize)]
pub struct UebScore {
    pub data: &'static str,
    pub board: String,
    pub code: BrailleCode,
    pub arch: Arch,
    pub segmenter: std::path::PathBuf,
    pub classifier: std::path::PathBuf,
    pub timing: TimingMode,
    pub speed_mm_s: f64,
    pub depth_mm: f64,
    pub lines: usize,
    /// Cells printed (blanks between words left out) and the cell error rate over them (edit
    /// distance of the cells read to the cells printed, line by line, the blank between words
    /// counted as a cell).
    pub cells_printed: usize,
    pub cell_error_rate: f64,
    /// Words of cells read exactly as printed, `1 - WER` over the cell words.
    pub cell_word_accuracy: f64,
    /// Per spelling (none, textblob, lexicon).
    pub by_spell: Vec<PrintScore>,
    /// Seconds of stream read, and the wall time reading took (segmentation, classifier, filter;
    /// not the simulation, not the spelling).
    pub stream_s: f64,
    pub read_s: f64,
    /// Wall time of the lexicon spelling of every word (the beam's back-translations).
    pub spell_lexicon_s: f64,
    /// Trial 0 of each row: print, cells read, and print read (lexicon).
    pub examples: Vec<(String, String, String)>,
}

/// `s` lower case, letters and digits only.
fn blind(words: &[String]) -> Vec<String> {
    words
        .iter()
        .map(|w| w.chars().filter(|c| c.is_alphanumeric()).flat_map(char::to_lowercase).collect::<String>())
        .filter(|w| !w.is_empty())
        .collect()
}

/// Reads every scan of `board` (its cells in `spec.board`'s place) with `readers` and `timing`
/// and scores cells and print.
pub fn eval_ueb(
    board: &PrintBoard,
    spec: &WordsSpec,
    readers: &ReaderModels,
    files: &pipeline::shipped::ReaderFiles,
    timing: TimingMode,
    progress: &dyn Progress,
) -> Result<UebScore> {
    let spec = WordsSpec { board: board.kind.clone(), ..spec.clone() };
    let lines = read_scans(&spec, &[readers], &[timing], progress)?;
    let spellers: Vec<Speller> =
        SPELLS.iter().map(|&s| Speller::in_code(s, board.code)).collect::<pipeline::Result<_>>()?;
    let (mut cells, mut exact, mut blinded) = (
        WordMetrics::default(),
        vec![WordMetrics::default(); SPELLS.len()],
        vec![WordMetrics::default(); SPELLS.len()],
    );
    let mut s = UebScore {
        data: "simulated (virtual Evetac)",
        board: board_name(board),
        code: board.code,
        arch: readers.classifier.arch(),
        segmenter: files.segmenter.clone(),
        classifier: files.classifier.clone(),
        timing,
        speed_mm_s: spec.speed_mm_s,
        depth_mm: spec.depth_mm,
        lines: lines.len(),
        cells_printed: 0,
        cell_error_rate: 0.0,
        cell_word_accuracy: 0.0,
        by_spell: Vec::new(),
        stream_s: 0.0,
        read_s: 0.0,
        spell_lexicon_s: 0.0,
        examples: Vec::new(),
    };
    // read_scans reads row by row, `trials` scans each
    for (i, scan) in lines.iter().enumerate() {
        let (row, trial) = (i / spec.trials.max(1) as usize, i as u64 % spec.trials.max(1));
        let l = &scan[0];
        let print: Vec<String> =
            board.print_rows.get(row).map_or(Vec::new(), |r| r.split_whitespace().map(str::to_string).collect());
        let raw: Vec<String> = l.words.iter().map(|w| w.raw.clone()).collect();
        cells.add_line(&l.truth, &raw);
        s.cells_printed += l.truth.iter().map(|w| w.chars().count()).sum::<usize>();
        for ((sp, e), b) in spellers.iter().zip(&mut exact).zip(&mut blinded) {
            let t = std::time::Instant::now();
            let read: Vec<String> = l.words.iter().map(|w| sp.correct(&w.chars)).collect();
            let lexicon = sp.spell() == Spell::Lexicon;
            if lexicon {
                s.spell_lexicon_s += t.elapsed().as_secs_f64();
            }
            e.add_line(&print, &read);
            b.add_line(&blind(&print), &blind(&read));
            if trial == 0 && lexicon {
                s.examples.push((print.join(" "), raw.join(" "), read.join(" ")));
            }
        }
        s.stream_s += l.stream_s;
        s.read_s += l.read_s;
    }
    s.cell_error_rate = cells.char_error_rate();
    s.cell_word_accuracy = cells.word_accuracy();
    s.by_spell = SPELLS
        .iter()
        .zip(exact.iter().zip(&blinded))
        .map(|(&spell, (e, b))| PrintScore {
            spell,
            word_accuracy: e.word_accuracy(),
            word_error_rate: e.word_error_rate(),
            char_error_rate: e.char_error_rate(),
            blind_word_accuracy: b.word_accuracy(),
            blind_word_error_rate: b.word_error_rate(),
        })
        .collect();
    Ok(s)
}

/// The board's name: the sentence boards' names, else its print.
fn board_name(board: &PrintBoard) -> String {
    match corpus::boards::board_name(&board.kind) {
        n if n.starts_with("text:") => format!("text:{}", board.print_rows.join("/")),
        n => n,
    }
}

/// The lines `braille eval words --braille ueb-g2` prints.
impl std::fmt::Display for UebScore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "models: {} + {}", self.segmenter.display(), self.classifier.display())?;
        writeln!(
            f,
            "SIMULATED {} ({}) at {} mm/s, {} mm, {} lines, {} architecture, {} timing: cell error rate {:.4} over {} printed cells, cell words read exactly {:.3} (1 - WER); read {:.1} s of stream in {:.2} s, the lexicon's spelling {:.2} s",
            self.board,
            self.code,
            self.speed_mm_s,
            self.depth_mm,
            self.lines,
            self.arch,
            self.timing,
            self.cell_error_rate,
            self.cells_printed,
            self.cell_word_accuracy,
            self.stream_s,
            self.read_s,
            self.spell_lexicon_s
        )?;
        for p in &self.by_spell {
            writeln!(
                f,
                "  spelling {:?}: word accuracy (1 - WER) {:.3} exact, {:.3} blind to case and punctuation; CER {:.3}",
                p.spell, p.word_accuracy, p.blind_word_accuracy, p.char_error_rate
            )?;
        }
        for (print, cells, read) in self.examples.iter().take(4) {
            writeln!(f, "  {print:?} -> {cells} -> {read:?}")?;
        }
        Ok(())
    }
}
