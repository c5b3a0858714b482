//! Braille boards: the paper's four (SAB, UN, RAB, EV), a validation board (VAL), the cell
//! boards of every six-dot pattern (RCB, VCB) or any text,
//! as dots with positions and heights, including manufacturing tolerances drawn from the board's
//! own seed.

use crate::error::{Error, Result, check};
use encoders::braille::{Cell, cell_on_board};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Which board to print.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum BoardKind {
    /// Standard alphabet board: A-I, J-R, S-Z in three rows, letters spread evenly.
    Sab,
    /// "UNIVERSITY" / "OF" / "DARMSTADT", letters spread evenly.
    Un,
    /// The 26 letters in a fixed random order over three rows (9, 9, 8), spread evenly.
    Rab,
    /// The validation board: like RAB, another fixed random order, printed with its own seed.
    /// Recipes, epochs and augmentation are chosen on it, never on RAB or EV (the test boards).
    Val,
    /// Everyday vocabulary: "RIGHT LEFT EXIT OPEN" / "PUSH PULL STOP HELP WATER", as text.
    Ev,
    /// The random cell board: the 63 raised-dot patterns of the six-dot cell (U+2801-U+283F) in
    /// a fixed random order, in runs of three at the standard cell spacing (a blank between
    /// runs), six runs a row. Unlike RAB the cells are not spread: a cell of one dot column
    /// alone on the board (dots 1-2-3 or 4-5-6 only) gives the same window whichever column it
    /// is, and only its neighbours in view tell them apart, as in print. A test board.
    Rcb,
    /// The validation cell board: like RCB, another fixed order, printed with its own seed.
    /// Choices for the cell classifiers are made on it, never on RCB.
    Vcb,
    /// Any text; `/` starts a new row. Letters (printed as capitals), spaces and Unicode Braille
    /// cells (U+2800-U+283F), e.g. print translated by a Braille code
    /// (`corpus::boards::in_code`).
    Text(String),
}

impl BoardKind {
    pub fn name(&self) -> String {
        match self {
            BoardKind::Sab => "SAB".into(),
            BoardKind::Un => "UN".into(),
            BoardKind::Rab => "RAB".into(),
            BoardKind::Val => "VAL".into(),
            BoardKind::Ev => "EV".into(),
            BoardKind::Rcb => "RCB".into(),
            BoardKind::Vcb => "VCB".into(),
            BoardKind::Text(t) => format!("text:{t}"),
        }
    }

    /// Row texts and whether the letters are spread evenly (single-character boards) or set at
    /// the standard cell spacing (word boards).
    pub fn rows(&self) -> (Vec<String>, bool) {
        match self {
            BoardKind::Sab => (vec!["ABCDEFGHI".into(), "JKLMNOPQR".into(), "STUVWXYZ".into()], true),
            BoardKind::Un => (vec!["UNIVERSITY".into(), "OF".into(), "DARMSTADT".into()], true),
            BoardKind::Rab | BoardKind::Val => {
                // A fixed permutation: the same on every run and machine.
                let mut letters: Vec<char> = ('A'..='Z').collect();
                let seed = if *self == BoardKind::Rab { 0x5241_4221 } else { 0x5641_4c21 };
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                for i in (1..letters.len()).rev() {
                    letters.swap(i, rng.random_range(0..=i));
                }
                let s: String = letters.into_iter().collect();
                (vec![s[..9].into(), s[9..18].into(), s[18..].into()], true)
            }
            BoardKind::Rcb | BoardKind::Vcb => {
                let mut cells: Vec<char> = (1..64u8).map(|b| Cell(b).unicode()).collect();
                let seed = if *self == BoardKind::Rcb { 0x5243_4221 } else { 0x5643_4221 };
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                for i in (1..cells.len()).rev() {
                    cells.swap(i, rng.random_range(0..=i));
                }
                let runs: Vec<String> = cells.chunks(3).map(|r| r.iter().collect()).collect();
                (runs.chunks(6).map(|r| r.join(" ")).collect(), false)
            }
            BoardKind::Ev => (vec!["RIGHT LEFT EXIT OPEN".into(), "PUSH PULL STOP HELP WATER".into()], false),
            BoardKind::Text(t) => (t.split('/').map(|r| r.trim().to_uppercase()).collect(), false),
        }
    }
}

impl std::str::FromStr for BoardKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if let Some(text) = s.strip_prefix("text:") {
            if let Some(bad) = text.chars().find(|&c| c != '/' && cell_on_board(c).is_none()) {
                return Err(format!(
                    "text boards take letters, spaces, Unicode Braille cells and / (new row); {bad:?} is not one \
                     (other print takes a Braille code: --braille ueb-g1 or ueb-g2)"
                ));
            }
            if text.trim().is_empty() {
                return Err("text: needs some letters".into());
            }
            return Ok(BoardKind::Text(text.to_string()));
        }
        match s.to_ascii_uppercase().as_str() {
            "SAB" => Ok(BoardKind::Sab),
            "UN" => Ok(BoardKind::Un),
            "RAB" => Ok(BoardKind::Rab),
            "VAL" => Ok(BoardKind::Val),
            "EV" => Ok(BoardKind::Ev),
            "RCB" => Ok(BoardKind::Rcb),
            "VCB" => Ok(BoardKind::Vcb),
            _ => Err(format!("unknown board {s:?}: expected SAB, UN, RAB, VAL, EV, RCB, VCB or text:\"ANY WORDS\"")),
        }
    }
}

/// The printed geometry. Defaults follow the seed paper (hemispherical dots of 0.5 mm, 2.5 mm dot
/// spacing) and Marburg Medium (6.0 mm cells, 10 mm lines).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoardGeometry {
    /// Radius of the sphere each dot is a cap of.
    pub dot_radius_mm: f64,
    /// Height of a dot above the board (equal to the radius for a hemisphere).
    pub dot_height_mm: f64,
    /// Distance between dots in a cell, along and across the row.
    pub dot_spacing_mm: f64,
    /// Distance between cells of a word board (left column to left column).
    pub cell_spacing_mm: f64,
    /// Distance between rows (centre to centre).
    pub line_spacing_mm: f64,
    /// Board length before the first and after the last cell of a spread row.
    pub margin_mm: f64,
    /// Length of the row the sensor slides over.
    pub row_length_mm: f64,
    /// Standard deviation of each dot's position error (assumed: +-0.05 mm tolerance as 2 sigma).
    pub position_sigma_mm: f64,
    /// Standard deviation of each dot's height error (assumed, as above).
    pub height_sigma_mm: f64,
    /// Standard deviation of each dot's base radius (FDM PLA: +-0.035 mm, half the measured
    /// +-0.07 mm spread of the diameter). The sphere each dot is a cap of follows from its base
    /// and height.
    #[serde(default)]
    pub base_radius_sigma_mm: f64,
    /// The print's surface texture: the top layer's extrusion lines, as a sinusoid of this
    /// amplitude and pitch whose crests run at `texture_angle_deg` to the row. 0 for a smooth board.
    #[serde(default)]
    pub texture_amplitude_mm: f64,
    #[serde(default = "default_texture_pitch")]
    pub texture_pitch_mm: f64,
    #[serde(default = "default_texture_angle")]
    pub texture_angle_deg: f64,
}

fn default_texture_pitch() -> f64 {
    0.4
}

fn default_texture_angle() -> f64 {
    45.0
}

impl Default for BoardGeometry {
    fn default() -> Self {
        Self {
            dot_radius_mm: 0.5,
            dot_height_mm: 0.5,
            dot_spacing_mm: 2.5,
            cell_spacing_mm: 6.0,
            line_spacing_mm: 10.0,
            margin_mm: 20.0,
            row_length_mm: 195.0,
            position_sigma_mm: 0.025,
            height_sigma_mm: 0.025,
            base_radius_sigma_mm: 0.0,
            texture_amplitude_mm: 0.0,
            texture_pitch_mm: default_texture_pitch(),
            texture_angle_deg: default_texture_angle(),
        }
    }
}

impl BoardGeometry {
    /// Radius of a dot's base on the board.
    pub fn dot_base_radius_mm(&self) -> f64 {
        let (r, h) = (self.dot_radius_mm, self.dot_height_mm);
        (2.0 * r * h - h * h).max(0.0).sqrt()
    }

    /// The sphere radius of a cap with this base radius and height.
    pub fn sphere_radius_mm(base_radius_mm: f64, height_mm: f64) -> f64 {
        ((base_radius_mm * base_radius_mm + height_mm * height_mm) / (2.0 * height_mm)).max(height_mm)
    }

    pub fn validate(&self) -> Result<()> {
        const POSITIVE: &str = "a positive length";
        check("dot_radius_mm", self.dot_radius_mm, f64::MIN_POSITIVE..100.0, POSITIVE)?;
        check("dot_height_mm", self.dot_height_mm, f64::MIN_POSITIVE..100.0, POSITIVE)?;
        check("dot_spacing_mm", self.dot_spacing_mm, f64::MIN_POSITIVE..100.0, POSITIVE)?;
        check("cell_spacing_mm", self.cell_spacing_mm, f64::MIN_POSITIVE..100.0, POSITIVE)?;
        check("line_spacing_mm", self.line_spacing_mm, f64::MIN_POSITIVE..1000.0, POSITIVE)?;
        check("row_length_mm", self.row_length_mm, f64::MIN_POSITIVE..1e5, POSITIVE)?;
        check("margin_mm", self.margin_mm, 0.0..1e5, "zero or more")?;
        check("position_sigma_mm", self.position_sigma_mm, 0.0..1.0, "in [0, 1) mm")?;
        check("height_sigma_mm", self.height_sigma_mm, 0.0..1.0, "in [0, 1) mm")?;
        check("base_radius_sigma_mm", self.base_radius_sigma_mm, 0.0..1.0, "in [0, 1) mm")?;
        check("texture_amplitude_mm", self.texture_amplitude_mm, 0.0..0.5, "in [0, 0.5) mm")?;
        check("texture_pitch_mm", self.texture_pitch_mm, 0.01..100.0, "at least 0.01 mm")?;
        check("texture_angle_deg", self.texture_angle_deg, -180.0..=180.0, "in [-180, 180] degrees")?;
        if self.dot_height_mm > self.dot_radius_mm {
            return Err(Error::Inconsistent {
                names: "dot_height_mm, dot_radius_mm",
                why: format!(
                    "the height {} exceeds the radius {}: a dot is a cap of a sphere",
                    self.dot_height_mm, self.dot_radius_mm
                ),
            });
        }
        Ok(())
    }
}

/// One printed dot.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Dot {
    pub x_mm: f64,
    pub y_mm: f64,
    pub height_mm: f64,
    /// Radius of the sphere the dot is a cap of.
    pub radius_mm: f64,
    /// Index into [`Board::characters`].
    pub character: usize,
}

/// One printed character (spaces included, as empty cells).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Character {
    pub letter: char,
    pub row: usize,
    /// Index of the word in its row (spaces belong to no word: `None`).
    pub word: Option<usize>,
    /// Nominal position of the cell's left dot column and of the row's centre line.
    pub x_mm: f64,
    pub y_mm: f64,
    /// Raised dots as (column, row) pairs.
    pub dots: Vec<(u8, u8)>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Board {
    pub kind: BoardKind,
    pub geometry: BoardGeometry,
    pub seed: u64,
    pub rows: Vec<String>,
    pub characters: Vec<Character>,
    pub dots: Vec<Dot>,
}

/// `text` broken at spaces into rows of at most `fits` characters (a word longer than a row is
/// left whole, for the caller to refuse).
fn wrap(text: &str, fits: usize) -> Vec<String> {
    let mut rows: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > fits {
            rows.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() || rows.is_empty() {
        rows.push(line);
    }
    rows
}

/// A stable 64-bit hash (FNV-1a), for seeds derived from names.
pub fn stable_hash(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3))
}

impl Board {
    /// Prints a board. Its tolerances come from `seed`; by default use [`Board::default_seed`],
    /// so that one board is the same physical object in every scan.
    pub fn new(kind: BoardKind, geometry: BoardGeometry, seed: u64) -> Result<Board> {
        geometry.validate()?;
        let (rows, spread) = kind.rows();
        let usable = geometry.row_length_mm - 2.0 * geometry.margin_mm;
        // Rows of words wrap at spaces onto as many rows as they need, as a printed page does.
        let rows = if spread {
            rows
        } else {
            let fits = (usable / geometry.cell_spacing_mm + 1e-9).floor() as usize + 1;
            rows.iter().flat_map(|r| wrap(r, fits)).collect()
        };
        let mut characters = Vec::new();
        for (r, text) in rows.iter().enumerate() {
            let n = text.chars().count();
            if n == 0 {
                continue;
            }
            let pitch = if spread && n > 1 { usable / (n - 1) as f64 } else { geometry.cell_spacing_mm };
            let width = pitch * (n - 1) as f64 + geometry.dot_spacing_mm;
            if width > usable + geometry.dot_spacing_mm + 1e-9 {
                return Err(Error::RowTooLong { row: r, text: text.clone(), needed_mm: width, usable_mm: usable });
            }
            let mut word = None;
            let mut words = 0;
            for (i, c) in text.chars().enumerate() {
                let cell = cell_on_board(c).ok_or(Error::NoCell(c))?;
                if c == ' ' {
                    word = None;
                } else if word.is_none() {
                    word = Some(words);
                    words += 1;
                }
                characters.push(Character {
                    letter: c,
                    row: r,
                    word,
                    x_mm: geometry.margin_mm + pitch * i as f64,
                    y_mm: r as f64 * geometry.line_spacing_mm,
                    dots: cell.dots().collect(),
                });
            }
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let pos = Normal::new(0.0, geometry.position_sigma_mm).map_err(Error::distribution("position_sigma_mm"))?;
        let height = Normal::new(0.0, geometry.height_sigma_mm).map_err(Error::distribution("height_sigma_mm"))?;
        let base =
            Normal::new(0.0, geometry.base_radius_sigma_mm).map_err(Error::distribution("base_radius_sigma_mm"))?;
        let mut dots = Vec::new();
        for (i, ch) in characters.iter().enumerate() {
            for &(col, row) in &ch.dots {
                let x_mm = ch.x_mm + col as f64 * geometry.dot_spacing_mm + pos.sample(&mut rng);
                let y_mm = ch.y_mm + (row as f64 - 1.0) * geometry.dot_spacing_mm + pos.sample(&mut rng);
                let height_mm = (geometry.dot_height_mm + height.sample(&mut rng)).max(0.05);
                // A spread base is drawn after the rest, so that boards without it keep their dots.
                let radius_mm = if geometry.base_radius_sigma_mm > 0.0 {
                    let b = (geometry.dot_base_radius_mm() + base.sample(&mut rng)).max(0.05);
                    BoardGeometry::sphere_radius_mm(b, height_mm)
                } else {
                    geometry.dot_radius_mm.max(height_mm)
                };
                dots.push(Dot { x_mm, y_mm, height_mm, radius_mm, character: i });
            }
        }
        Ok(Board { kind, geometry, seed, rows, characters, dots })
    }

    /// The seed a board gets from its name.
    pub fn default_seed(kind: &BoardKind) -> u64 {
        stable_hash(&kind.name())
    }

    pub fn cell(&self, character: usize) -> Cell {
        cell_on_board(self.characters[character].letter).unwrap_or(Cell::EMPTY)
    }

    /// Centre line of row `r`.
    pub fn row_y_mm(&self, r: usize) -> f64 {
        r as f64 * self.geometry.line_spacing_mm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_papers_boards() {
        let g = BoardGeometry::default();
        let sab = Board::new(BoardKind::Sab, g.clone(), 1).unwrap();
        assert_eq!(sab.rows, ["ABCDEFGHI", "JKLMNOPQR", "STUVWXYZ"]);
        let rab = Board::new(BoardKind::Rab, g.clone(), 1).unwrap();
        let mut all: Vec<char> = rab.rows.concat().chars().collect();
        assert_ne!(rab.rows.concat(), "ABCDEFGHIJKLMNOPQRSTUVWXYZ");
        all.sort();
        assert_eq!(all.into_iter().collect::<String>(), "ABCDEFGHIJKLMNOPQRSTUVWXYZ");
        let ev = Board::new(BoardKind::Ev, g.clone(), 1).unwrap();
        assert_eq!(ev.characters.iter().filter(|c| c.row == 1).filter_map(|c| c.word).max(), Some(4));
        let dots: usize = sab.characters.iter().map(|c| c.dots.len()).sum();
        assert_eq!(dots, sab.dots.len());
    }

    #[test]
    fn tolerances_come_from_the_board_seed() {
        let g = BoardGeometry::default();
        let a = Board::new(BoardKind::Sab, g.clone(), 7).unwrap();
        assert_eq!(a, Board::new(BoardKind::Sab, g.clone(), 7).unwrap());
        assert_ne!(a.dots, Board::new(BoardKind::Sab, g, 8).unwrap().dots);
    }

    #[test]
    fn parsing_names_the_choices() {
        assert_eq!("ev".parse::<BoardKind>().unwrap(), BoardKind::Ev);
        assert!("XYZ".parse::<BoardKind>().unwrap_err().contains("SAB, UN, RAB, VAL, EV, RCB"));
        // the cell boards: every raised-dot pattern once, in two different orders
        let (rcb, vcb) = (BoardKind::Rcb.rows().0, BoardKind::Vcb.rows().0);
        let mut cells: Vec<char> = rcb.concat().chars().collect();
        cells.retain(|&c| c != ' ');
        cells.sort();
        assert_eq!(cells, (0x2801..=0x283F).filter_map(char::from_u32).collect::<Vec<_>>());
        assert_eq!(rcb.iter().map(|r| r.chars().count()).collect::<Vec<_>>(), [23, 23, 23, 11]);
        assert_ne!(rcb, vcb);
        assert_eq!("rcb".parse::<BoardKind>().unwrap(), BoardKind::Rcb);
        // the validation board: every letter once, in another order than RAB's
        let (val, rab) = (BoardKind::Val.rows().0, BoardKind::Rab.rows().0);
        let mut letters: Vec<char> = val.concat().chars().collect();
        letters.sort();
        assert_eq!(letters, ('A'..='Z').collect::<Vec<_>>());
        assert_ne!(val, rab);
        assert!("text:HI 2".parse::<BoardKind>().is_err());
        let too_long = BoardKind::Text("A".repeat(40));
        assert!(Board::new(too_long, BoardGeometry::default(), 1).is_err(), "a word longer than a row");
    }

    #[test]
    fn text_longer_than_a_row_wraps_at_spaces() {
        // 35 characters need 206.5 mm at 6 mm a cell; the row has 155 mm
        let text = "THE QUICK BROWN FOX JUMPS OVER DOGS";
        let g = BoardGeometry::default();
        let b = Board::new(BoardKind::Text(text.into()), g.clone(), 1).unwrap();
        assert_eq!(b.rows, ["THE QUICK BROWN FOX JUMPS", "OVER DOGS"]);
        assert_eq!(b.rows.join(" "), text);
        let last = b.characters.iter().map(|c| c.x_mm).fold(0.0, f64::max);
        assert!(last <= g.row_length_mm - g.margin_mm, "every cell on the board: {last} mm");
        // explicit rows are kept, and wrapped each on its own
        let b = Board::new(BoardKind::Text("HI/THERE".into()), BoardGeometry::default(), 1).unwrap();
        assert_eq!(b.rows, ["HI", "THERE"]);
    }
}
