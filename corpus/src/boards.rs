//! The boards of the simulated protocols beyond the paper's: rows of random English words for
//! training, unseen words for testing and validation words apart from both, each drawn from its
//! own slice of TextBlob's word list by a seeded rule (SIMULATED data).

use crate::world::VALIDATION_SEED;
use encoders::braille::Cell;
use pipeline::code::BrailleCode;
use serde::{Deserialize, Serialize};
use sim::BoardKind;

/// How many of TextBlob's most frequent words training rows draw from; the next as many are the
/// unseen words of test boards.
pub const TRAINING_WORDS: usize = 3000;

/// TextBlob's words of 2-8 capital letters by falling frequency, none of them in `exclude`:
/// `take` of them after the first `skip`.
fn word_pool(skip: usize, take: usize, exclude: &[&str]) -> Vec<String> {
    pipeline::spelling::Norvig::textblob()
        .most_frequent(usize::MAX)
        .into_iter()
        .map(|(w, _)| w.to_uppercase())
        .filter(|w| (2..=8).contains(&w.len()) && w.bytes().all(|b| b.is_ascii_uppercase()))
        .filter(|w| !exclude.iter().any(|e| e.eq_ignore_ascii_case(w)))
        .skip(skip)
        .take(take)
        .collect()
}

/// `rows` rows of words drawn uniformly from `words`, each at most `max_chars` long, joined by
/// `/` as a text board takes them. Seeded.
fn rows_of(words: &[String], seed: u64, rows: usize, max_chars: usize) -> String {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(rows);
    for _ in 0..rows {
        let mut row = String::new();
        loop {
            let w = &words[rng.random_range(0..words.len())];
            if row.len() + usize::from(!row.is_empty()) + w.len() > max_chars {
                break;
            }
            if !row.is_empty() {
                row.push(' ');
            }
            row.push_str(w);
        }
        out.push(row);
    }
    out.join("/")
}

/// `rows` board rows of random English words in capitals (uniform over the
/// [`TRAINING_WORDS`] most frequent words of TextBlob's list with 2-8 letters, none of them in
/// `exclude`), each at most `max_chars` long, joined by `/` as a text board takes them. Seeded.
pub fn random_word_rows(seed: u64, rows: usize, max_chars: usize, exclude: &[&str]) -> String {
    rows_of(&word_pool(0, TRAINING_WORDS, exclude), seed, rows, max_chars)
}

/// Rows of words no training row can hold: drawn from the next [`TRAINING_WORDS`] of TextBlob's
/// list after those training rows draw from (less frequent, still everyday words). Seeded.
pub fn unseen_word_rows(seed: u64, rows: usize, max_chars: usize) -> String {
    rows_of(&word_pool(TRAINING_WORDS, TRAINING_WORDS, &EV_WORDS), seed, rows, max_chars)
}

/// Rows of words for validation, none a training row or a test board can hold: drawn from the
/// [`TRAINING_WORDS`] of TextBlob's list after the unseen test words. Word-level choices (the
/// reader's settings, a recipe for word rows) are made on them, never on EV or the unseen words.
pub fn validation_word_rows(seed: u64, rows: usize, max_chars: usize) -> String {
    rows_of(&word_pool(2 * TRAINING_WORDS, TRAINING_WORDS, &EV_WORDS), seed, rows, max_chars)
}

/// The board of validation words, `VAL-WORDS` on the command line: four rows of at most 25
/// characters of [`validation_word_rows`] at [`VALIDATION_SEED`].
pub fn validation_words_board() -> BoardKind {
    BoardKind::Text(validation_word_rows(VALIDATION_SEED, 4, 25))
}

/// The validation sentences ([`VALIDATION_SENTENCES`]) in the paper's letters, `VAL-SENTENCES` on
/// the command line: each word's letters in capitals (digits and punctuation left out), rows of
/// at most 25 letters. Short words ("A", "AT", "THE") that the validation words lack.
pub fn validation_sentences_letters_board() -> BoardKind {
    let mut rows: Vec<String> = vec![String::new()];
    let words = VALIDATION_SENTENCES
        .split_whitespace()
        .map(|w| w.chars().filter(char::is_ascii_alphabetic).collect::<String>().to_ascii_uppercase())
        .filter(|w| !w.is_empty());
    for w in words {
        let row = rows.last_mut().expect("one row at least");
        if row.is_empty() {
            row.push_str(&w);
        } else if row.len() + 1 + w.len() > 25 {
            rows.push(w);
        } else {
            row.push(' ');
            row.push_str(&w);
        }
    }
    BoardKind::Text(rows.join("/"))
}

/// Where a letter stands in its row: the first of the row, the first of a later word, inside a
/// word, or the last of a word (a one-letter word's letter counts as a start). The all-letters
/// boards hold every letter at each place, and the word scores count letters by it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LetterPlace {
    RowStart,
    WordStart,
    Middle,
    WordEnd,
}

impl LetterPlace {
    pub const ALL: [LetterPlace; 4] =
        [LetterPlace::RowStart, LetterPlace::WordStart, LetterPlace::Middle, LetterPlace::WordEnd];

    pub fn name(self) -> &'static str {
        match self {
            LetterPlace::RowStart => "row start",
            LetterPlace::WordStart => "word start",
            LetterPlace::Middle => "middle",
            LetterPlace::WordEnd => "word end",
        }
    }

    /// Its index in [`LetterPlace::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The place of letter `i` of word `word` (0 the row's first) of `len` letters.
    pub fn of(word: usize, i: usize, len: usize) -> LetterPlace {
        match (word, i) {
            (0, 0) => LetterPlace::RowStart,
            (_, 0) => LetterPlace::WordStart,
            _ if i + 1 == len => LetterPlace::WordEnd,
            _ => LetterPlace::Middle,
        }
    }
}

/// Which held-out words an all-letters board draws from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum HeldOut {
    /// The unseen test words ([`unseen_word_rows`]' slice) and every other word of TextBlob's
    /// list past the validation words: `ALL-LETTERS`, a test board.
    Test,
    /// The validation words' slice and the other half of the list past it: `VAL-LETTERS`.
    Validation,
}

impl HeldOut {
    /// The board's name on the command line.
    pub fn board_name(self) -> &'static str {
        match self {
            HeldOut::Test => "ALL-LETTERS",
            HeldOut::Validation => "VAL-LETTERS",
        }
    }
}

/// Times an all-letters board holds each letter at each [`LetterPlace`], where the held-out
/// words allow.
pub const ALL_LETTERS_TIMES: usize = 3;

/// An all-letters board: its rows, and the (letter, place) cells its words could not fill
/// [`ALL_LETTERS_TIMES`] times (letter, place, times held).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AllLetters {
    pub rows: Vec<String>,
    pub short: Vec<(char, LetterPlace, usize)>,
}

impl AllLetters {
    /// The rows joined by `/`, as a text board takes them.
    pub fn text(&self) -> String {
        self.rows.join("/")
    }
}

/// The held-out words of `which`, by falling frequency: none a training row, the EV board or
/// the other kind can hold, and no Roman numeral (TextBlob's list has XII, XIV, ...).
fn held_out_pool(which: HeldOut) -> Vec<String> {
    let all = word_pool(0, usize::MAX, &EV_WORDS);
    let (slice, rest) = match which {
        HeldOut::Test => (TRAINING_WORDS..2 * TRAINING_WORDS, 0),
        HeldOut::Validation => (2 * TRAINING_WORDS..3 * TRAINING_WORDS, 1),
    };
    let past = all.get(3 * TRAINING_WORDS..).unwrap_or_default();
    all[slice]
        .iter()
        .chain(past.iter().skip(rest).step_by(2))
        .filter(|w| !w.bytes().all(|b| matches!(b, b'I' | b'V' | b'X')))
        .cloned()
        .collect()
}

/// Rows of held-out words that hold every letter at every [`LetterPlace`] at least `times`
/// times where the words allow, each row at most `max_chars` long, by a fixed rule (no seed):
/// row `r` starts with the most frequent word beginning with letter `r mod 26` (26 `times` rows;
/// every row's first word is chosen before the rows are filled), and every later word is the one
/// that fills the most (letter, place) cells still short, the more frequent of equals.
/// Each word is used once, unless it alone fills a cell (no unused word begins a row with the
/// letter, or fills the cell and fits): then up to `times` times, in as many rows. Rows are filled to `max_chars` with the most frequent
/// words that fit once nothing is short.
pub fn all_letters_rows(words: &[String], times: usize, max_chars: usize) -> AllLetters {
    let cell = |c: u8, place: LetterPlace| (c - b'A') as usize * 4 + place.index();
    let mut need = vec![times; 26 * 4];
    // Cells a word fills if placed first in its row or after another word.
    let cells = |w: &str, first: bool| -> Vec<usize> {
        let b = w.as_bytes();
        (0..b.len()).map(|i| cell(b[i], LetterPlace::of(usize::from(!first), i, b.len()))).collect()
    };
    let gain = |need: &[usize], cs: &[usize]| {
        let mut taken: Vec<usize> = Vec::with_capacity(cs.len());
        cs.iter()
            .filter(|&&c| {
                let before = taken.iter().filter(|&&t| t == c).count();
                taken.push(c);
                need[c] > before
            })
            .count()
    };
    // Uses of each word: once while unused ones serve, `times` at most, once a row.
    let mut uses = vec![0u8; words.len()];
    // First every row's first word, so that the rare letters' few words begin rows before they
    // fill a later word's place.
    let mut rows: Vec<(String, Vec<usize>)> = Vec::with_capacity(26 * times);
    for r in 0..26 * times {
        let letter = b'A' + (r % 26) as u8;
        let fits = |w: &String| w.len() <= max_chars && w.as_bytes()[0] == letter;
        // The most frequent unused word beginning with the letter; else a used one. (Not the one
        // that fills most: that would load the first words with the rare letters, and the first
        // word's score would measure the letters, not the place.)
        let best = |n: u8| (0..words.len()).find(|&k| uses[k] == n && fits(&words[k]));
        let Some(first) = (0..times as u8).find_map(best) else { continue };
        uses[first] += 1;
        cells(&words[first], true).into_iter().for_each(|c| need[c] = need[c].saturating_sub(1));
        rows.push((words[first].clone(), vec![first]));
    }
    for (row, in_row) in &mut rows {
        loop {
            let room = max_chars.saturating_sub(row.len() + 1);
            let best = |n: u8| {
                words
                    .iter()
                    .enumerate()
                    .filter(|&(k, w)| uses[k] == n && w.len() <= room && !in_row.contains(&k))
                    .map(|(k, w)| (gain(&need, &cells(w, false)), std::cmp::Reverse(k)))
                    .max()
            };
            // A used word again only when it fills a cell no unused word can.
            let next = match best(0) {
                Some((g, k)) if g > 0 => Some(k.0),
                unused => (1..times as u8).filter_map(best).find(|&(g, _)| g > 0).or(unused).map(|(_, k)| k.0),
            };
            let Some(k) = next else { break };
            uses[k] += 1;
            in_row.push(k);
            cells(&words[k], false).into_iter().for_each(|c| need[c] = need[c].saturating_sub(1));
            row.push(' ');
            row.push_str(&words[k]);
        }
    }
    let rows = rows.into_iter().map(|(row, _)| row).collect();
    let short = (0..26u8)
        .flat_map(|l| LetterPlace::ALL.into_iter().map(move |p| (l, p)))
        .filter(|&(l, p)| need[cell(b'A' + l, p)] > 0)
        .map(|(l, p)| ((b'A' + l) as char, p, times - need[cell(b'A' + l, p)]))
        .collect();
    AllLetters { rows, short }
}

/// Training rows that hold every letter at every [`LetterPlace`] `times` times where the training
/// words allow ([`all_letters_rows`] over the [`TRAINING_WORDS`] random word rows draw from, no
/// Roman numeral), rows of at most `max_chars`: the rare letters' share of a training set.
pub fn training_letter_rows(times: usize, max_chars: usize) -> AllLetters {
    let words: Vec<String> = word_pool(0, TRAINING_WORDS, &EV_WORDS)
        .into_iter()
        .filter(|w| !w.bytes().all(|b| matches!(b, b'I' | b'V' | b'X')))
        .collect();
    all_letters_rows(&words, times, max_chars)
}

/// The all-letters board of `which` ([`all_letters_rows`] over its held-out words,
/// [`ALL_LETTERS_TIMES`] times, rows of at most 25 characters as the unseen-words boards), made
/// once per process.
pub fn all_letters(which: HeldOut) -> &'static AllLetters {
    static TEST: std::sync::OnceLock<AllLetters> = std::sync::OnceLock::new();
    static VALIDATION: std::sync::OnceLock<AllLetters> = std::sync::OnceLock::new();
    let lock = match which {
        HeldOut::Test => &TEST,
        HeldOut::Validation => &VALIDATION,
    };
    lock.get_or_init(|| all_letters_rows(&held_out_pool(which), ALL_LETTERS_TIMES, 25))
}

/// The all-letters board of `which` as a text board.
pub fn all_letters_board(which: HeldOut) -> BoardKind {
    BoardKind::Text(all_letters(which).text())
}

/// A board's name as the command line gives it: the generated boards' names (VAL-WORDS,
/// ALL-LETTERS, VAL-LETTERS) in place of their text.
pub fn board_name(kind: &BoardKind) -> String {
    if let BoardKind::Text(t) = kind {
        if *kind == validation_words_board() {
            return "VAL-WORDS".into();
        }
        if *kind == validation_sentences_letters_board() {
            return "VAL-SENTENCES".into();
        }
        if let Some((_, name)) = sentence_boards().iter().find(|(b, _)| b == kind) {
            return name.clone();
        }
        for h in [HeldOut::Test, HeldOut::Validation] {
            if *t == all_letters(h).text() {
                return h.board_name().into();
            }
        }
    }
    kind.name()
}

/// A board named as the command line names it: the simulator's boards
/// ([`BoardKind`]'s `FromStr`), `VAL-WORDS` ([`validation_words_board`]), `VAL-SENTENCES`
/// ([`validation_sentences_letters_board`]), and the all-letters
/// boards `ALL-LETTERS` (test) and `VAL-LETTERS` (validation; [`all_letters_board`]).
pub fn parse_board(s: &str) -> std::result::Result<BoardKind, String> {
    if s.eq_ignore_ascii_case("VAL-WORDS") {
        return Ok(validation_words_board());
    }
    if s.eq_ignore_ascii_case("VAL-SENTENCES") {
        return Ok(validation_sentences_letters_board());
    }
    if s.eq_ignore_ascii_case("ALL-LETTERS") {
        return Ok(all_letters_board(HeldOut::Test));
    }
    if s.eq_ignore_ascii_case("VAL-LETTERS") {
        return Ok(all_letters_board(HeldOut::Validation));
    }
    s.parse::<BoardKind>().map_err(|e| format!("{e}, VAL-WORDS, VAL-SENTENCES, ALL-LETTERS or VAL-LETTERS"))
}

/// A board named as [`parse_board`] names it, with a `text:` board's print written in `code`:
/// with the paper's letters it must hold letters and spaces only (any other character is an
/// error naming it and its place); with UEB each row (`/` between rows) is translated to cells
/// by liblouis's tables, the blank cell between words, and wrapped at spaces to rows of
/// [`UEB_ROW_CELLS`] ([`PrintBoard`]). `UEB-SENTENCES` and `VAL-UEB` are the sentence boards
/// ([`sentence_board`]; UEB only); the other named boards are the same in every code.
pub fn parse_board_in(s: &str, code: BrailleCode) -> crate::Result<BoardKind> {
    if let Some(which) = sentence_board_name(s) {
        return Ok(sentence_board(which, needs_cells(s, code)?)?.kind);
    }
    let Some(text) = s.strip_prefix("text:") else {
        return parse_board(s).map_err(|what| crate::Error::Board { board: s.to_string(), what });
    };
    if code != BrailleCode::Grade1Letters {
        return Ok(parse_print_board(s, code)?.kind);
    }
    let translator = code.translator()?;
    let mut rows = Vec::new();
    for row in text.split('/') {
        let row = row.trim();
        // Unicode Braille cells are printed as they are, in any code
        if !row.chars().all(|c| encoders::braille::cell_on_board(c).is_some()) {
            translator.to_cells(row)?;
        }
        rows.push(row.to_string());
    }
    if rows.iter().all(|r| r.trim().is_empty()) {
        return Err(crate::Error::Board { board: s.to_string(), what: "text: needs some print".into() });
    }
    Ok(BoardKind::Text(rows.join("/")))
}

/// Cells a row of UEB holds on the simulated boards (the unseen-words boards' 25).
pub const UEB_ROW_CELLS: usize = 25;

/// Training rows that hold every raised-dot cell (the 63 patterns) `times` times, each time in
/// its own seeded order, in runs of one to five cells (neighbours at the cell spacing, as in
/// contracted text, and a blank between runs), rows of at most `max_chars` cells, joined by `/`
/// as a text board takes them.
pub fn training_cell_rows(seed: u64, times: usize, max_chars: usize) -> String {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut rows: Vec<String> = Vec::new();
    for _ in 0..times {
        let mut cells: Vec<char> = (1..64u8).map(|b| Cell(b).unicode()).collect();
        for i in (1..cells.len()).rev() {
            cells.swap(i, rng.random_range(0..=i));
        }
        let mut row = String::new();
        let mut rest = &cells[..];
        while !rest.is_empty() {
            let run = rng.random_range(1..=5usize).min(rest.len());
            let used = row.chars().count();
            if used > 0 && used + 1 + run > max_chars {
                rows.push(std::mem::take(&mut row));
            }
            if !row.is_empty() {
                row.push(' ');
            }
            row.extend(&rest[..run]);
            rest = &rest[run..];
        }
        rows.push(row);
    }
    rows.join("/")
}

/// Training rows of letter strings that hold every ordered pair of letters inside a word `times`
/// times (the neighbours a classifier's window sees; the training words hold 256 of the 676
/// pairs, and letters after an unseen pair were misread 3.7% of the time on VAL-LETTERS against
/// 0.05% after a seen one: docs/log/letters-2026-11-29.md). Each pass is an Eulerian circuit of
/// the pairs (a de Bruijn sequence of order 2 over A-Z, 677 letters) in a seeded order, cut into
/// strings of 3-8 letters where each string begins with the last letter of the one before, so
/// that no pair is lost at a cut; rows of at most `max_chars`, joined by `/`. Seeded.
pub fn training_pair_rows(seed: u64, times: usize, max_chars: usize) -> String {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut rows: Vec<String> = Vec::new();
    let mut row = String::new();
    for _ in 0..times {
        // Hierholzer's algorithm on the complete digraph with loops, each vertex's exits shuffled.
        let mut exits: Vec<Vec<u8>> = (0..26u8)
            .map(|_| {
                let mut e: Vec<u8> = (0..26).collect();
                for i in (1..e.len()).rev() {
                    e.swap(i, rng.random_range(0..=i));
                }
                e
            })
            .collect();
        let mut stack = vec![rng.random_range(0..26u8)];
        let mut circuit: Vec<u8> = Vec::with_capacity(26 * 26 + 1);
        while let Some(&v) = stack.last() {
            match exits[usize::from(v)].pop() {
                Some(u) => stack.push(u),
                None => circuit.extend(stack.pop()),
            }
        }
        circuit.reverse();
        let letters: Vec<char> = circuit.iter().map(|&c| char::from(b'A' + c)).collect();
        let mut start = 0;
        while start + 1 < letters.len() {
            let end = (start + rng.random_range(3..=8usize)).min(letters.len());
            let word: String = letters[start..end].iter().collect();
            if !row.is_empty() && row.len() + 1 + word.len() > max_chars {
                rows.push(std::mem::take(&mut row));
            }
            if !row.is_empty() {
                row.push(' ');
            }
            row.push_str(&word);
            start = end - 1;
        }
    }
    if !row.is_empty() {
        rows.push(row);
    }
    rows.join("/")
}

/// A board of print in a Braille code: the rows as printed and the board of their cells, row
/// for row (print wrapped at spaces so that each row's cells fit [`UEB_ROW_CELLS`]; the
/// simulator wraps no further).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PrintBoard {
    pub code: BrailleCode,
    pub print_rows: Vec<String>,
    pub kind: BoardKind,
}

impl PrintBoard {
    /// `lines` of print translated through `code`, each wrapped at spaces into rows of at most
    /// `max_cells` cells (a word longer than a row is an error naming it).
    pub fn new(lines: &[&str], code: BrailleCode, max_cells: usize) -> crate::Result<PrintBoard> {
        let t = code.translator()?;
        let row_cells = |print: &str| -> crate::Result<String> {
            Ok(t.to_cells(print)?.iter().map(|&c| if c == Cell::EMPTY { ' ' } else { c.unicode() }).collect())
        };
        let (mut print_rows, mut cell_rows) = (Vec::new(), Vec::new());
        for line in lines {
            let mut row: Vec<&str> = Vec::new();
            for word in line.split_whitespace() {
                let with = [row.as_slice(), &[word]].concat().join(" ");
                if row.is_empty() || row_cells(&with)?.chars().count() <= max_cells {
                    row.push(word);
                    continue;
                }
                let print = row.join(" ");
                cell_rows.push(row_cells(&print)?);
                print_rows.push(print);
                row = vec![word];
            }
            if !row.is_empty() {
                let print = row.join(" ");
                cell_rows.push(row_cells(&print)?);
                print_rows.push(print);
            }
        }
        if let Some((print, cells)) = print_rows.iter().zip(&cell_rows).find(|(_, c)| c.chars().count() > max_cells) {
            return Err(crate::Error::Board {
                board: print.clone(),
                what: format!("{} cells in {code}, a row holds {max_cells}", cells.chars().count()),
            });
        }
        if print_rows.is_empty() {
            return Err(crate::Error::Board { board: lines.join("/"), what: "no print".into() });
        }
        Ok(PrintBoard { code, print_rows, kind: BoardKind::Text(cell_rows.join("/")) })
    }
}

/// Everyday sentences in print, with capitals, digits and punctuation, that no training row
/// holds: the test set (`UEB-SENTENCES`) and the validation set (`VAL-UEB`), 24 each.
pub const TEST_SENTENCES: &str = include_str!("../../data/ueb/test_sentences.txt");
pub const VALIDATION_SENTENCES: &str = include_str!("../../data/ueb/validation_sentences.txt");

/// The sentence board of `which` in `code` (`UEB-SENTENCES` for the test, `VAL-UEB` for
/// validation).
pub fn sentence_board(which: HeldOut, code: BrailleCode) -> crate::Result<PrintBoard> {
    let text = match which {
        HeldOut::Test => TEST_SENTENCES,
        HeldOut::Validation => VALIDATION_SENTENCES,
    };
    let lines: Vec<&str> = text.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
    PrintBoard::new(&lines, code, UEB_ROW_CELLS)
}

/// Training rows of print for a Braille code: `rows` rows of random training words (the
/// [`TRAINING_WORDS`] of [`random_word_rows`], none of EV's), each word lower case, capitalised
/// (one in five) or in capitals (one in twenty), now and then a number (one in twelve), a
/// possessive `'s` (one in thirty), a hyphenated pair (one in fifty) or quoted (one in forty),
/// and punctuation after one word in four (`,` `.` `;` `:` `?` `!`). Seeded; each row's cells fit
/// `max_cells`.
pub fn ueb_training_board(seed: u64, rows: usize, code: BrailleCode, max_cells: usize) -> crate::Result<PrintBoard> {
    use rand::{Rng, SeedableRng};
    let words: Vec<String> =
        word_pool(0, TRAINING_WORDS, &EV_WORDS).into_iter().map(|w| w.to_ascii_lowercase()).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let pick = |rng: &mut rand_chacha::ChaCha8Rng| words[rng.random_range(0..words.len())].clone();
    let word = |rng: &mut rand_chacha::ChaCha8Rng| -> String {
        let roll: f64 = rng.random();
        let mut w = if roll < 1.0 / 12.0 {
            rng.random_range(0..2100u32).to_string()
        } else {
            let mut w = pick(rng);
            if rng.random_bool(1.0 / 50.0) {
                w = format!("{w}-{}", pick(rng));
            }
            if rng.random_bool(1.0 / 30.0) {
                w.push_str("'s");
            }
            let case: f64 = rng.random();
            if case < 0.05 {
                w.to_ascii_uppercase()
            } else if case < 0.25 {
                let mut c = w.chars();
                c.next().map(|f| f.to_ascii_uppercase().to_string() + c.as_str()).unwrap_or_default()
            } else {
                w
            }
        };
        if rng.random_bool(0.25) {
            const MARKS: [&str; 8] = [",", ",", ",", ".", ".", ";", ":", "?"];
            let m = if rng.random_bool(0.1) { "!" } else { MARKS[rng.random_range(0..MARKS.len())] };
            w.push_str(m);
        }
        if rng.random_bool(1.0 / 40.0) {
            w = format!("\"{w}\"");
        }
        w
    };
    // a line of about two rows' words, wrapped by the board to rows that fit
    let mut lines = Vec::new();
    let mut made = 0;
    while made < rows {
        let line: Vec<String> = (0..8).map(|_| word(&mut rng)).collect();
        lines.push(line.join(" "));
        made += 2;
    }
    let refs: Vec<&str> = lines.iter().map(String::as_str).collect();
    let mut b = PrintBoard::new(&refs, code, max_cells)?;
    if let BoardKind::Text(t) = &b.kind {
        let kept: Vec<&str> = t.split('/').take(rows).collect();
        b.kind = BoardKind::Text(kept.join("/"));
        b.print_rows.truncate(rows);
    }
    Ok(b)
}

/// The sentence boards in both grades of UEB with their names (made once per process).
fn sentence_boards() -> &'static [(BoardKind, String)] {
    static BOARDS: std::sync::OnceLock<Vec<(BoardKind, String)>> = std::sync::OnceLock::new();
    BOARDS.get_or_init(|| {
        let mut out = Vec::new();
        for code in [BrailleCode::UebGrade1, BrailleCode::UebGrade2] {
            for (which, name) in [(HeldOut::Test, "UEB-SENTENCES"), (HeldOut::Validation, "VAL-UEB")] {
                if let Ok(b) = sentence_board(which, code) {
                    out.push((b.kind, format!("{name} ({code})")));
                }
            }
        }
        out
    })
}

/// The sentence boards' names: `UEB-SENTENCES` (test) and `VAL-UEB` (validation).
pub fn sentence_board_name(s: &str) -> Option<HeldOut> {
    if s.eq_ignore_ascii_case("UEB-SENTENCES") {
        Some(HeldOut::Test)
    } else if s.eq_ignore_ascii_case("VAL-UEB") {
        Some(HeldOut::Validation)
    } else {
        None
    }
}

/// `code`, when it writes more than the paper's letters (a board of punctuation and digits
/// needs UEB).
fn needs_cells(board: &str, code: BrailleCode) -> crate::Result<BrailleCode> {
    match code {
        BrailleCode::Grade1Letters => Err(crate::Error::Board {
            board: board.to_string(),
            what: "print with digits and punctuation: read it with --braille ueb-g1 or ueb-g2".into(),
        }),
        c => Ok(c),
    }
}

/// A board as [`parse_board_in`] names it, with its print where it has one: a `text:` board in
/// UEB and the sentence boards keep their print rows (what a reader of the code is scored
/// against); any other board's print is its cells' rows.
pub fn parse_print_board(s: &str, code: BrailleCode) -> crate::Result<PrintBoard> {
    if let Some(which) = sentence_board_name(s) {
        return sentence_board(which, needs_cells(s, code)?);
    }
    match (s.strip_prefix("text:"), code) {
        (Some(text), BrailleCode::UebGrade1 | BrailleCode::UebGrade2) => {
            let lines: Vec<&str> = text.split('/').map(str::trim).collect();
            PrintBoard::new(&lines, code, UEB_ROW_CELLS)
        }
        _ => {
            let kind = parse_board_in(s, code)?;
            Ok(PrintBoard { code, print_rows: kind.rows().0, kind })
        }
    }
}

/// Words of the EV board, kept out of the random word rows so that EV stays a test board.
pub const EV_WORDS: [&str; 9] = ["RIGHT", "LEFT", "EXIT", "OPEN", "PUSH", "PULL", "STOP", "HELP", "WATER"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_text_board_is_written_in_its_code() {
        let g2 = parse_board_in("text:The children./and 12", BrailleCode::UebGrade2).unwrap();
        assert_eq!(g2, BoardKind::Text("⠠⠮ ⠡⠝⠲/⠯ ⠼⠁⠃".into()));
        let letters = parse_board_in("text:push pull", BrailleCode::Grade1Letters).unwrap();
        assert_eq!(letters, BoardKind::Text("push pull".into()));
        match parse_board_in("text:one, two", BrailleCode::Grade1Letters) {
            Err(crate::Error::Pipeline(e)) => {
                assert!(matches!(*e, pipeline::Error::Untranslatable { index: 3, character: ',', .. }), "{e}")
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(parse_board_in("RAB", BrailleCode::UebGrade2).unwrap(), BoardKind::Rab);
        // The board prints the cells it was given.
        let board = sim::Board::new(g2, sim::BoardGeometry::default(), 1).unwrap();
        assert_eq!(board.cell(0), Cell(0b10_0000));
    }

    #[test]
    fn cell_boards_hold_every_cell_and_print_boards_keep_their_print_row_for_row() {
        // every cell `times` times, in runs at the cell spacing, rows that fit
        let rows = training_cell_rows(3, 4, 22);
        assert_eq!(rows, training_cell_rows(3, 4, 22));
        let mut n = std::collections::HashMap::new();
        for r in rows.split('/') {
            assert!(r.chars().count() <= 22, "{r}");
            for c in r.chars().filter(|&c| c != ' ') {
                *n.entry(c).or_insert(0) += 1;
            }
        }
        assert_eq!(n.len(), 63);
        assert!(n.values().all(|&k| k == 4));
        // the sentence boards: print rows and cell rows one for one, none too long
        for which in [HeldOut::Test, HeldOut::Validation] {
            let b = sentence_board(which, BrailleCode::UebGrade2).unwrap();
            let BoardKind::Text(cells) = &b.kind else { panic!("a text board") };
            let cell_rows: Vec<&str> = cells.split('/').collect();
            assert_eq!(cell_rows.len(), b.print_rows.len());
            let t = BrailleCode::UebGrade2.translator().unwrap();
            for (print, cells) in b.print_rows.iter().zip(&cell_rows) {
                assert!(cells.chars().count() <= UEB_ROW_CELLS, "{print}: {cells}");
                assert_eq!(t.to_text(&pipeline::code::parse_cells(cells).unwrap()), *print);
                let board =
                    sim::Board::new(BoardKind::Text(cells.to_string()), sim::BoardGeometry::default(), 1).unwrap();
                assert_eq!(board.rows.len(), 1, "the simulator wraps no further: {print}");
            }
        }
        // no test sentence is a validation sentence
        let val: Vec<&str> = VALIDATION_SENTENCES.lines().collect();
        assert!(TEST_SENTENCES.lines().all(|l| !val.contains(&l)));
        assert_eq!(
            board_name(&sentence_board(HeldOut::Test, BrailleCode::UebGrade2).unwrap().kind),
            "UEB-SENTENCES (ueb-g2)"
        );
        assert!(parse_board_in("UEB-SENTENCES", BrailleCode::Grade1Letters).is_err());
        // training print: seeded, with capitals, digits and punctuation, rows that fit
        let p = ueb_training_board(5, 30, BrailleCode::UebGrade2, 22).unwrap();
        assert_eq!(p, ueb_training_board(5, 30, BrailleCode::UebGrade2, 22).unwrap());
        assert_eq!(p.print_rows.len(), 30);
        let print = p.print_rows.join(" ");
        assert!(print.chars().any(|c| c.is_ascii_uppercase()), "{print}");
        assert!(print.chars().any(|c| c.is_ascii_digit()), "{print}");
        assert!(print.chars().any(|c| c.is_ascii_punctuation()), "{print}");
        assert!(!print.split(' ').any(|w| EV_WORDS.contains(&w.to_uppercase().as_str())), "{print}");
    }

    #[test]
    fn word_rows_are_seeded_bounded_and_leave_out_the_excluded() {
        let a = random_word_rows(7, 5, 22, &["THE", "OF"]);
        assert_eq!(a, random_word_rows(7, 5, 22, &["THE", "OF"]));
        assert_ne!(a, random_word_rows(8, 5, 22, &["THE", "OF"]));
        let rows: Vec<&str> = a.split('/').collect();
        assert_eq!(rows.len(), 5);
        for r in rows {
            assert!(!r.is_empty() && r.len() <= 22, "{r}");
            assert!(r.split(' ').all(|w| w != "THE" && w != "OF" && w.len() >= 2), "{r}");
        }
    }

    #[test]
    fn validation_words_are_neither_training_nor_test_words() {
        let training: std::collections::HashSet<String> = word_pool(0, TRAINING_WORDS, &EV_WORDS).into_iter().collect();
        let unseen: std::collections::HashSet<String> =
            word_pool(TRAINING_WORDS, TRAINING_WORDS, &EV_WORDS).into_iter().collect();
        let BoardKind::Text(rows) = validation_words_board() else { panic!("a text board") };
        let words: Vec<&str> = rows.split(['/', ' ']).collect();
        assert!(words.len() >= 12 && rows.split('/').count() == 4, "{rows}");
        for w in words {
            assert!(!training.contains(w) && !unseen.contains(w) && !EV_WORDS.contains(&w), "{w}");
        }
        assert_eq!(parse_board("val-words"), Ok(validation_words_board()));
        assert_eq!(parse_board("RAB"), Ok(BoardKind::Rab));
        assert!(parse_board("XYZ").unwrap_err().contains("VAL-WORDS"));
    }

    /// Counts of (letter, place) over rows of text.
    fn places(rows: &[String]) -> std::collections::HashMap<(char, LetterPlace), usize> {
        let mut n = std::collections::HashMap::new();
        for row in rows {
            for (w, word) in row.split(' ').enumerate() {
                for (i, c) in word.chars().enumerate() {
                    *n.entry((c, LetterPlace::of(w, i, word.len()))).or_insert(0) += 1;
                }
            }
        }
        n
    }

    #[test]
    fn a_small_all_letters_board_by_hand() {
        // Three letters' worth of words: row 0 must start with A, row 1 with B, row 2 with C.
        let words: Vec<String> = ["ABBA", "BAA", "AB", "BA", "CAB"].map(String::from).to_vec();
        let b = all_letters_rows(&words, 1, 9);
        // First words: the most frequent beginning with each letter, ABBA, BAA, CAB. Then the rows
        // are filled: after ABBA only AB and BA fit, one cell short each (A or B at a word's start;
        // CAB filled B at a word's end), AB the more frequent; BA after BAA; nothing is left.
        assert_eq!(b.rows, ["ABBA AB", "BAA BA", "CAB"]);
        assert!(b.short.contains(&('D', LetterPlace::RowStart, 0)));
        assert!(b.short.contains(&('Z', LetterPlace::RowStart, 0)));
        // a word serves once at one time: at two, CAB begins the second row C as well
        let twice = all_letters_rows(&words, 2, 9);
        assert!(twice.rows[3].starts_with("AB"), "{:?}", twice.rows);
        assert!(twice.rows[5].starts_with("CAB"), "{:?}", twice.rows);
        assert!(!b.short.iter().any(|&(c, p, _)| c == 'A' && p == LetterPlace::RowStart));
    }

    #[test]
    fn all_letters_boards_hold_every_letter_at_every_place_from_held_out_words() {
        let training: std::collections::HashSet<String> = word_pool(0, TRAINING_WORDS, &EV_WORDS).into_iter().collect();
        let validation_words: std::collections::HashSet<String> =
            word_pool(2 * TRAINING_WORDS, TRAINING_WORDS, &EV_WORDS).into_iter().collect();
        let test = all_letters(HeldOut::Test);
        let val = all_letters(HeldOut::Validation);
        let words = |b: &AllLetters| -> std::collections::HashSet<String> {
            b.rows.iter().flat_map(|r| r.split(' ').map(String::from)).collect()
        };
        let (tw, vw) = (words(test), words(val));
        assert!(tw.is_disjoint(&vw), "test and validation boards share {:?}", tw.intersection(&vw).collect::<Vec<_>>());
        for w in tw.iter().chain(&vw) {
            assert!(!training.contains(w) && !EV_WORDS.contains(&w.as_str()), "{w} could be in a training row");
        }
        assert!(tw.is_disjoint(&validation_words), "a test word is a validation word");
        for b in [test, val] {
            assert_eq!(b.rows.len(), 26 * ALL_LETTERS_TIMES);
            let n = places(&b.rows);
            for (r, row) in b.rows.iter().enumerate() {
                assert!(row.len() <= 25, "{row}");
                assert_eq!(row.as_bytes()[0], b'A' + (r % 26) as u8, "{row}");
            }
            for c in 'A'..='Z' {
                for p in LetterPlace::ALL {
                    let have = n.get(&(c, p)).copied().unwrap_or(0);
                    match b.short.iter().find(|s| s.0 == c && s.1 == p) {
                        Some(&(_, _, k)) => assert_eq!(have, k),
                        None => assert!(have >= ALL_LETTERS_TIMES, "{c} at {}: {have}", p.name()),
                    }
                }
            }
        }
        // English words hardly end in J or Q, and the validation words hold one word beginning
        // with X (XIPHI), which begins the three X rows (a word serves three times at most) and
        // is left for no later word's start; every other cell is filled.
        assert_eq!(test.short, vec![('J', LetterPlace::WordEnd, 0)]);
        assert_eq!(val.short, vec![('Q', LetterPlace::WordEnd, 0), ('X', LetterPlace::WordStart, 0)]);
        let pool = held_out_pool(HeldOut::Validation);
        assert_eq!(pool.iter().filter(|w| w.starts_with('X')).collect::<Vec<_>>(), ["XIPHI"]);
        assert!(!pool.iter().any(|w| w.ends_with('Q')));
        assert_eq!(parse_board("ALL-LETTERS"), Ok(BoardKind::Text(test.text())));
        assert_eq!(board_name(&parse_board("all-letters").unwrap()), "ALL-LETTERS");
        assert_eq!(board_name(&parse_board("VAL-LETTERS").unwrap()), "VAL-LETTERS");
        assert_eq!(board_name(&parse_board("val-words").unwrap()), "VAL-WORDS");
        assert_eq!(board_name(&parse_board("val-sentences").unwrap()), "VAL-SENTENCES");
        let BoardKind::Text(sentences) = validation_sentences_letters_board() else { panic!("a text board") };
        assert!(sentences.starts_with("THE MUSEUM IS CLOSED ON/SUNDAYS TURN"), "{sentences}");
        assert!(sentences.split('/').all(|r| r.len() <= 25 && r.chars().all(|c| c == ' ' || c.is_ascii_uppercase())));
        assert_eq!(board_name(&BoardKind::Ev), "EV");
        assert_eq!(parse_board("val-letters"), Ok(BoardKind::Text(val.text())));
        assert_eq!(all_letters_rows(&held_out_pool(HeldOut::Test), ALL_LETTERS_TIMES, 25), *test, "a fixed rule");
    }

    #[test]
    fn training_pair_rows_hold_every_pair_inside_words() {
        let text = training_pair_rows(7, 2, 22);
        assert_eq!(text, training_pair_rows(7, 2, 22), "seeded");
        assert_ne!(text, training_pair_rows(8, 2, 22));
        let mut pairs = vec![0usize; 26 * 26];
        for row in text.split('/') {
            assert!(row.len() <= 22, "{row}");
            for word in row.split(' ') {
                assert!((2..=8).contains(&word.len()), "{word}");
                for p in word.as_bytes().windows(2) {
                    pairs[usize::from(p[0] - b'A') * 26 + usize::from(p[1] - b'A')] += 1;
                }
            }
        }
        assert!(pairs.iter().all(|&n| n == 2), "every pair exactly twice: {pairs:?}");
    }

    #[test]
    fn training_letter_rows_draw_on_training_words_only() {
        let training: std::collections::HashSet<String> = word_pool(0, TRAINING_WORDS, &EV_WORDS).into_iter().collect();
        let b = training_letter_rows(3, 22);
        // no training word begins with X (but Roman numerals, left out): three rows fewer
        assert_eq!(b.rows.len(), 75);
        for w in b.rows.iter().flat_map(|r| r.split(' ')) {
            assert!(training.contains(w), "{w} is not a training word");
        }
        assert!(b.rows.iter().all(|r| r.len() <= 22));
        // the frequent words hold no word ending in J, Q or Z, and few beginning with X
        assert!(b.short.iter().all(|&(c, _, _)| matches!(c, 'J' | 'Q' | 'X' | 'Z')), "{:?}", b.short);
        assert!(b.short.contains(&('X', LetterPlace::RowStart, 0)), "{:?}", b.short);
    }

    #[test]
    fn unseen_words_are_none_a_training_row_can_hold() {
        let training: std::collections::HashSet<String> = word_pool(0, TRAINING_WORDS, &EV_WORDS).into_iter().collect();
        let unseen = unseen_word_rows(1_000_003, 4, 25);
        assert_eq!(unseen, unseen_word_rows(1_000_003, 4, 25));
        let words: Vec<&str> = unseen.split(['/', ' ']).collect();
        assert!(words.len() >= 8, "{unseen}");
        for w in words {
            assert!(!training.contains(w) && !EV_WORDS.contains(&w), "{w} could be in a training row");
        }
    }
}
