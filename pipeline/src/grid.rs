//! The cell grid: which column a cell of one dot column stands in.
//!
//! A cell whose raised dots are all in one column (dots 1-2-3 only, as ⠁ ⠇ ⠄, or dots 4-5-6 only,
//! as ⠈ ⠸ ⠠) makes the same window whichever column it is, since a window is placed by the dots
//! it sees. Print tells the two apart by the grid every cell stands on: the cells of a row are a
//! whole number of cell spacings apart (a word space is a blank cell), so a lone column a whole
//! number of spacings from a neighbour's right column is a right column, and one a dot spacing
//! short of that is a left column. A reader knows when each character passed and the speed it
//! estimates, so it places a lone column on the grid its two-column neighbours draw; nothing the
//! print's maker knows is used.
//!
//! The positions come from marks: when a character's last dot column (its only one, for a
//! one-column cell) passed, as the labeler's peaks or the reader's segments give it, and the
//! speed then. [`CellGrid::columns`] compares each lone column with its nearest two-column marks:
//! the hypothesis whose grid points lie nearer the distances measured wins.

use encoders::braille::Cell;
use serde::{Deserialize, Serialize};

/// Dots 1-3, the left column.
const LEFT: u8 = 0b000_111;
/// Dots 4-6, the right column.
const RIGHT: u8 = 0b111_000;

/// A cell's column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Column {
    Left,
    Right,
}

impl Column {
    /// The column a cell's dots all stand in; `None` for a cell of both columns or none.
    pub fn of(cell: Cell) -> Option<Column> {
        match (cell.0 & LEFT != 0, cell.0 & RIGHT != 0) {
            (true, false) => Some(Column::Left),
            (false, true) => Some(Column::Right),
            _ => None,
        }
    }

    /// A cell classifier's probabilities over the 63 cells (class `k` the cell of dot bits
    /// `k + 1`) with each one-column cell's probability moved onto its twin in this column (⠈'s
    /// onto ⠁ for the left column): what the classifier read, placed on the grid. Other classes,
    /// and probabilities of another length, as they are.
    pub fn place_probs(self, probs: &mut [f32]) {
        if probs.len() != 63 {
            return;
        }
        for bits in 1..8u8 {
            let (left, right) = (usize::from(bits) - 1, usize::from(bits << 3) - 1);
            let (from, to) = match self {
                Column::Left => (right, left),
                Column::Right => (left, right),
            };
            probs[to] += std::mem::take(&mut probs[from]);
        }
    }

    /// `cell` with its dots moved into this column, row for row (⠇ in the right column is ⠸); a
    /// cell of both columns, or none, as it is.
    pub fn holding(self, cell: Cell) -> Cell {
        match (Column::of(cell), self) {
            (Some(Column::Left), Column::Right) => Cell((cell.0 & LEFT) << 3),
            (Some(Column::Right), Column::Left) => Cell((cell.0 & RIGHT) >> 3),
            _ => cell,
        }
    }
}

/// Where a character passed: the time its last dot column (its only one, for a one-column cell)
/// passed the reference point, whether it had two columns, and the speed estimated then (`None`:
/// none known, and the mark places nothing).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GridMark {
    pub t_us: i64,
    pub two_columns: bool,
    pub speed_mm_s: Option<f64>,
}

/// The print's geometry and how far a lone column looks for neighbours. The spacings are the
/// Braille standard's (Marburg Medium, as the simulated boards): a property of the print, not of
/// a scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct CellGrid {
    /// Between a cell's two columns.
    pub dot_spacing_mm: f64,
    /// From one cell to the next.
    pub cell_spacing_mm: f64,
    /// A lone column is placed by its nearest two-column marks, at most this many ...
    pub neighbours: usize,
    /// ... within this many cell spacings (the speed estimate's error grows with distance).
    pub reach_cells: f64,
}

impl Default for CellGrid {
    fn default() -> Self {
        CellGrid { dot_spacing_mm: 2.5, cell_spacing_mm: 6.0, neighbours: 2, reach_cells: 4.0 }
    }
}

impl CellGrid {
    /// How far `distance_mm` lies from the nearest whole number of cell spacings.
    fn off_grid_mm(&self, distance_mm: f64) -> f64 {
        let p = self.cell_spacing_mm;
        (distance_mm - p * (distance_mm / p).round()).abs()
    }

    /// For each mark of one column, the column the grid puts it in ([`Self::column_at`]); `None`
    /// for marks of two columns.
    pub fn columns(&self, marks: &[GridMark]) -> Vec<Option<Column>> {
        (0..marks.len()).map(|i| self.column_at(marks, i)).collect()
    }

    /// The column the grid puts mark `i` of one column in, judged by its nearest two-column
    /// marks within reach (`marks`: one row's, in any order); `None` for a mark of two columns,
    /// and where no neighbour is within reach, the speed is unknown, or both columns fit alike.
    pub fn column_at(&self, marks: &[GridMark], i: usize) -> Option<Column> {
        let m = marks.get(i)?;
        let speed = m.speed_mm_s.filter(|s| s.is_finite() && *s > 0.0)?;
        if m.two_columns {
            return None;
        }
        let reach_mm = self.reach_cells * self.cell_spacing_mm;
        let mut near: Vec<f64> = marks
            .iter()
            .filter(|n| n.two_columns)
            .map(|n| (m.t_us - n.t_us) as f64 * 1e-6 * speed)
            .filter(|d_mm| d_mm.abs() <= reach_mm)
            .collect();
        near.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
        near.truncate(self.neighbours.max(1));
        if near.is_empty() {
            return None;
        }
        // the lone column's distance from a neighbour's right column: a whole number of
        // spacings if it is a right column, a dot spacing short of one if a left column
        let right: f64 = near.iter().map(|&d| self.off_grid_mm(d).powi(2)).sum();
        let left: f64 = near.iter().map(|&d| self.off_grid_mm(d + self.dot_spacing_mm).powi(2)).sum();
        match right.total_cmp(&left) {
            std::cmp::Ordering::Less => Some(Column::Right),
            std::cmp::Ordering::Greater => Some(Column::Left),
            std::cmp::Ordering::Equal => None,
        }
    }

    /// `cells` (one row's, in reading order, each with its mark) with every one-column cell moved
    /// into the column the grid puts it in; the others as they are.
    pub fn place(&self, cells: &[Cell], marks: &[GridMark]) -> Vec<Cell> {
        let columns = self.columns(marks);
        cells.iter().zip(&columns).map(|(&cell, column)| column.map_or(cell, |c| c.holding(cell))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Marks of a row printed at `speed` from its cells' left columns (mm) and column counts, each
    /// mark at its last column.
    fn marks(cells: &[(f64, Cell)], speed: f64, grid: &CellGrid) -> Vec<GridMark> {
        cells
            .iter()
            .map(|&(x_mm, c)| {
                let last = if c.0 & RIGHT != 0 { x_mm + grid.dot_spacing_mm } else { x_mm };
                GridMark {
                    t_us: (last / speed * 1e6).round() as i64,
                    two_columns: c.two_columns(),
                    speed_mm_s: Some(speed),
                }
            })
            .collect()
    }

    #[test]
    fn a_cell_moves_across_row_for_row() {
        // ⠇ (dots 1-2-3) in the right column is ⠸ (4-5-6); ⠄ (dot 3) is ⠠ (dot 6)
        assert_eq!(Column::Right.holding(Cell(0b000_111)), Cell(0b111_000));
        assert_eq!(Column::Left.holding(Cell(0b100_000)), Cell(0b000_100));
        assert_eq!(Column::Left.holding(Cell(0b000_100)), Cell(0b000_100));
        // cells of both columns stay
        assert_eq!(Column::Left.holding(Cell(0b001_001)), Cell(0b001_001));
        assert_eq!(Column::of(Cell(0b010_000)), Some(Column::Right));
        assert_eq!(Column::of(Cell(0b011_011)), None);
        assert_eq!(Column::of(Cell(0)), None);
        // probabilities: ⠈ (class 7) onto ⠁ (class 0), ⠸ (55) onto ⠇ (6); the sum kept
        let mut p = vec![0.0f32; 63];
        (p[7], p[0], p[55], p[6], p[10]) = (0.5, 0.2, 0.1, 0.05, 0.15);
        Column::Left.place_probs(&mut p);
        assert_eq!((p[0], p[7], p[6], p[55], p[10]), (0.7, 0.0, 0.15, 0.0, 0.15));
        Column::Right.place_probs(&mut p);
        assert_eq!((p[0], p[7], p[6], p[55]), (0.0, 0.7, 0.0, 0.15));
    }

    #[test]
    fn a_lone_column_takes_the_column_its_neighbours_grid_gives() {
        let g = CellGrid::default();
        let p = g.cell_spacing_mm;
        // ⠉ (1, 4), then ⠈ (4 alone), a blank, ⠁ (1 alone), ⠛ (1, 2, 4, 5)
        let row =
            [(0.0, Cell(0b001_001)), (p, Cell(0b001_000)), (3.0 * p, Cell(0b000_001)), (4.0 * p, Cell(0b011_011))];
        for speed in [8.0, 32.0] {
            let m = marks(&row, speed, &g);
            assert_eq!(g.columns(&m), vec![None, Some(Column::Right), Some(Column::Left), None]);
            // read as its twin, each is put back
            let read = [row[0].1, Cell(0b000_001), Cell(0b001_000), row[3].1];
            let truth: Vec<Cell> = row.iter().map(|r| r.1).collect();
            assert_eq!(g.place(&read, &m), truth);
        }
        // a 5% error in the speed still places them
        let mut m = marks(&row, 16.0, &g);
        m.iter_mut().for_each(|m| m.speed_mm_s = Some(16.0 * 1.05));
        assert_eq!(g.columns(&m)[1..3], [Some(Column::Right), Some(Column::Left)]);
    }

    #[test]
    fn without_neighbours_or_speed_the_grid_says_nothing() {
        let g = CellGrid::default();
        let alone = marks(&[(0.0, Cell(0b000_001))], 8.0, &g);
        assert_eq!(g.columns(&alone), vec![None]);
        // the only two-column neighbour out of reach
        let far = marks(&[(0.0, Cell(0b001_001)), (10.0 * g.cell_spacing_mm, Cell(0b000_001))], 8.0, &g);
        assert_eq!(g.columns(&far), vec![None, None]);
        let mut unknown = marks(&[(0.0, Cell(0b001_001)), (g.cell_spacing_mm, Cell(0b000_001))], 8.0, &g);
        unknown[1].speed_mm_s = None;
        assert_eq!(g.columns(&unknown), vec![None, None]);
    }
}
