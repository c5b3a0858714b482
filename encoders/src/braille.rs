//! Grade-1 Braille: which of the six dots each character raises.
//!
//! Dots are numbered as in the standard: 1, 2, 3 down the left column, 4, 5, 6 down the right.

/// The six dots of a cell as a bit set: bit `k - 1` for dot `k`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Cell(pub u8);

impl Cell {
    pub const EMPTY: Cell = Cell(0);

    /// Whether dot `k` (1..=6) is raised.
    pub fn has(self, k: u8) -> bool {
        (1..=6).contains(&k) && self.0 & (1 << (k - 1)) != 0
    }

    /// Raised dots as (column 0/1, row 0..3) from the top left.
    pub fn dots(self) -> impl Iterator<Item = (u8, u8)> {
        (1..=6u8).filter(move |&k| self.has(k)).map(|k| ((k - 1) / 3, (k - 1) % 3))
    }

    pub fn count(self) -> u32 {
        self.0.count_ones()
    }

    /// Whether both columns hold a dot.
    pub fn two_columns(self) -> bool {
        self.0 & 0b000111 != 0 && self.0 & 0b111000 != 0
    }

    /// The cell a Unicode Braille pattern writes (U+2800-U+283F, whose low six bits are dots
    /// 1-6 as here); `None` for anything else, eight-dot patterns included.
    pub fn from_unicode(c: char) -> Option<Cell> {
        let code = c as u32;
        (0x2800..=0x283F).contains(&code).then(|| Cell((code - 0x2800) as u8))
    }

    /// The cell as a Unicode Braille pattern, U+2800 for the blank.
    pub fn unicode(self) -> char {
        char::from_u32(0x2800 + u32::from(self.0 & 0b11_1111)).unwrap_or('\u{2800}')
    }
}

const fn cell(dots: &[u8]) -> Cell {
    let mut bits = 0u8;
    let mut i = 0;
    while i < dots.len() {
        bits |= 1 << (dots[i] - 1);
        i += 1;
    }
    Cell(bits)
}

/// The 26 letters of Grade-1 (uncontracted) English Braille.
const LETTERS: [Cell; 26] = [
    cell(&[1]),             // a
    cell(&[1, 2]),          // b
    cell(&[1, 4]),          // c
    cell(&[1, 4, 5]),       // d
    cell(&[1, 5]),          // e
    cell(&[1, 2, 4]),       // f
    cell(&[1, 2, 4, 5]),    // g
    cell(&[1, 2, 5]),       // h
    cell(&[2, 4]),          // i
    cell(&[2, 4, 5]),       // j
    cell(&[1, 3]),          // k
    cell(&[1, 2, 3]),       // l
    cell(&[1, 3, 4]),       // m
    cell(&[1, 3, 4, 5]),    // n
    cell(&[1, 3, 5]),       // o
    cell(&[1, 2, 3, 4]),    // p
    cell(&[1, 2, 3, 4, 5]), // q
    cell(&[1, 2, 3, 5]),    // r
    cell(&[2, 3, 4]),       // s
    cell(&[2, 3, 4, 5]),    // t
    cell(&[1, 3, 6]),       // u
    cell(&[1, 2, 3, 6]),    // v
    cell(&[2, 4, 5, 6]),    // w
    cell(&[1, 3, 4, 6]),    // x
    cell(&[1, 3, 4, 5, 6]), // y
    cell(&[1, 3, 5, 6]),    // z
];

/// The cell of a character: letters (either case) and space. `None` for anything else.
pub fn cell_of(c: char) -> Option<Cell> {
    match c {
        ' ' => Some(Cell::EMPTY),
        'a'..='z' => Some(LETTERS[c as usize - 'a' as usize]),
        'A'..='Z' => Some(LETTERS[c as usize - 'A' as usize]),
        _ => None,
    }
}

/// The cell a board prints for a character: a letter (either case), a space, or a Unicode
/// Braille pattern (U+2800-U+283F, six dots; U+2800 is the blank). `None` for anything else.
pub fn cell_on_board(c: char) -> Option<Cell> {
    cell_of(c).or_else(|| Cell::from_unicode(c))
}

/// The letter a cell spells, if any.
pub fn letter_of(cell: Cell) -> Option<char> {
    LETTERS.iter().position(|&c| c == cell).map(|i| (b'A' + i as u8) as char)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_letter_is_distinct_and_round_trips() {
        for c in 'A'..='Z' {
            let cell = cell_of(c).unwrap();
            assert!(cell.count() >= 1);
            assert_eq!(letter_of(cell), Some(c));
        }
        assert_eq!(cell_of(' '), Some(Cell::EMPTY));
        assert_eq!(cell_of('1'), None);
    }

    #[test]
    fn known_cells() {
        // e = dots 1 and 5; a missing dot 5 turns it into a
        assert_eq!(cell_of('e').unwrap().dots().collect::<Vec<_>>(), vec![(0, 0), (1, 1)]);
        assert!(!cell_of('a').unwrap().two_columns());
        assert!(cell_of('w').unwrap().two_columns());
    }

    #[test]
    fn unicode_braille_round_trips_all_64_cells() {
        for bits in 0..64u8 {
            assert_eq!(Cell::from_unicode(Cell(bits).unicode()), Some(Cell(bits)));
        }
        // w = dots 2456: U+2800 + 0b111010
        assert_eq!(cell_of('w').unwrap().unicode(), '⠺');
        assert_eq!(Cell::from_unicode('\u{2840}'), None);
        assert_eq!(Cell::from_unicode('a'), None);
        assert_eq!(cell_on_board('⠿'), Some(Cell(0b11_1111)));
        assert_eq!(cell_on_board('q'), cell_of('Q'));
        assert_eq!(cell_on_board(','), None);
    }
}
