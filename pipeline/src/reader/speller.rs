//! The speller that corrects each finished word: none, the paper's TextBlob corrector, or the
//! lexicon decoder; letters or UEB cells.

use crate::cell_spell::CellSpeller;
use crate::code::BrailleCode;
use crate::error::Result;
use crate::lexicon::LexiconDecoder;
use crate::spelling::Norvig;
use crate::words::ReadChar;
use encoders::braille::{Cell as BrailleCell, cell_on_board};
use serde::{Deserialize, Serialize};

/// How finished words are corrected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Spell {
    /// The letters as read.
    None,
    /// The paper's corrector: TextBlob's (Norvig's algorithm over TextBlob's word list).
    Textblob,
    /// The Braille-aware lexicon decoder over the classifier's letter probabilities.
    Lexicon,
}

/// A speller, built once.
#[allow(clippy::large_enum_variant)] // one per reader: the size does not matter
pub enum Speller {
    None,
    Textblob(Norvig),
    Lexicon(LexiconDecoder),
    /// Words of cells in a Braille code (UEB), back-translated to print: as read
    /// ([`Spell::None`]), then each run of letters corrected by TextBlob's corrector
    /// ([`Spell::Textblob`]), or the beam over the cell probabilities scored by the lexicon
    /// ([`Spell::Lexicon`], [`crate::cell_spell`]).
    Cells {
        spell: Spell,
        speller: CellSpeller,
        norvig: Option<Norvig>,
    },
}

impl Speller {
    /// The paper's letters' speller.
    pub fn new(spell: Spell) -> Speller {
        match spell {
            Spell::None => Speller::None,
            Spell::Textblob => Speller::Textblob(Norvig::textblob()),
            Spell::Lexicon => Speller::Lexicon(LexiconDecoder::textblob(Default::default())),
        }
    }

    /// A speller of words printed in `code`: the letters' for the paper's letters, else words of
    /// cells back-translated through the code's tables.
    pub fn in_code(spell: Spell, code: BrailleCode) -> Result<Speller> {
        Ok(match code {
            BrailleCode::Grade1Letters => Speller::new(spell),
            _ => Speller::Cells {
                spell,
                speller: CellSpeller::new(code, Default::default())?,
                norvig: (spell == Spell::Textblob).then(Norvig::textblob),
            },
        })
    }

    /// How it corrects.
    pub fn spell(&self) -> Spell {
        match self {
            Speller::None => Spell::None,
            Speller::Textblob(_) => Spell::Textblob,
            Speller::Lexicon(_) => Spell::Lexicon,
            Speller::Cells { spell, .. } => *spell,
        }
    }

    /// The word the characters spell, corrected.
    pub fn correct(&self, chars: &[ReadChar]) -> String {
        let raw: String = chars.iter().map(|c| c.letter).collect();
        match self {
            Speller::None => raw,
            Speller::Textblob(n) => n.correct(&raw),
            Speller::Lexicon(d) => {
                let obs: Vec<crate::lexicon::LetterProbs> = chars
                    .iter()
                    .map(|c| match <[f32; 26]>::try_from(c.probs.as_slice()) {
                        Ok(p) => p,
                        Err(_) => crate::lexicon::one_hot(&c.letter.to_string(), c.confidence.clamp(0.04, 0.999))
                            .first()
                            .copied()
                            .unwrap_or([1.0 / 26.0; 26]),
                    })
                    .collect();
                d.decode(&obs).0
            }
            Speller::Cells { spell, speller, norvig } => {
                // a letter classifier's letters are their Grade-1 cells
                let cells: Vec<BrailleCell> =
                    chars.iter().map(|c| cell_on_board(c.letter).unwrap_or(BrailleCell::EMPTY)).collect();
                match (spell, norvig) {
                    (Spell::Lexicon, _) => {
                        let probs: Vec<Vec<f32>> = chars.iter().map(|c| c.probs.clone()).collect();
                        speller.correct(&cells, &probs)
                    }
                    (Spell::Textblob, Some(n)) => correct_letter_runs(&speller.as_read(&cells), n),
                    _ => speller.as_read(&cells),
                }
            }
        }
    }
}

/// Each run of ASCII letters in `text` corrected by `n` (in its case pattern); the rest kept.
fn correct_letter_runs(text: &str, n: &Norvig) -> String {
    let mut out = String::with_capacity(text.len());
    let mut run = String::new();
    for c in text.chars().chain(std::iter::once('\0')) {
        if c.is_ascii_alphabetic() {
            run.push(c);
            continue;
        }
        if !run.is_empty() {
            out.push_str(&n.correct(&run));
            run.clear();
        }
        if c != '\0' {
            out.push(c);
        }
    }
    out
}
