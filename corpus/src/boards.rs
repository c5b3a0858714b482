//! The boards of the simulated protocols beyond the paper's: rows of random English words for
//! training, unseen words for testing and validation words apart from both, each drawn from its
//! own slice of TextBlob's word list by a seeded rule (SIMULATED data).

use crate::world::VALIDATION_SEED;
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

/// A board named as the command line names it: the simulator's boards
/// ([`BoardKind`]'s `FromStr`), and `VAL-WORDS` ([`validation_words_board`]).
pub fn parse_board(s: &str) -> std::result::Result<BoardKind, String> {
    if s.eq_ignore_ascii_case("VAL-WORDS") {
        return Ok(validation_words_board());
    }
    s.parse::<BoardKind>().map_err(|e| format!("{e}, or VAL-WORDS"))
}

/// Words of the EV board, kept out of the random word rows so that EV stays a test board.
pub const EV_WORDS: [&str; 9] = ["RIGHT", "LEFT", "EXIT", "OPEN", "PUSH", "PULL", "STOP", "HELP", "WATER"];

#[cfg(test)]
mod tests {
    use super::*;

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
