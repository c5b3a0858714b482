//! A window of binned events as the networks read it, and the trait every network reads it through.

use crate::error::Result;

/// Events summed in one pooled cell of one bin: input `polarity * cells + row * width + col`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    pub input: u32,
    pub count: f32,
}

/// One frame's input: the last `frames` bins, oldest first, each a sparse list of cells.
pub struct Window<'a> {
    /// The end of the newest bin.
    pub t_end_us: i64,
    /// The newest bin's length (a reader that follows its speed estimate may have changed it
    /// within the window: [`bin_ends_us`](Self::bin_ends_us) has every bin's end).
    pub bin_us: i64,
    /// The pooled grid.
    pub height: usize,
    pub width: usize,
    pub(super) bins: [&'a [Vec<Cell>]; 2],
    pub(super) ends_us: [&'a [i64]; 2],
}

impl Window<'_> {
    /// The bins, oldest first.
    pub fn bins(&self) -> impl Iterator<Item = &[Cell]> {
        self.bins[0].iter().chain(self.bins[1]).map(Vec::as_slice)
    }

    /// The end of each bin, oldest first.
    pub fn bin_ends_us(&self) -> impl Iterator<Item = i64> + '_ {
        self.ends_us[0].iter().chain(self.ends_us[1]).copied()
    }

    pub fn n_bins(&self) -> usize {
        self.bins[0].len() + self.bins[1].len()
    }

    /// The window as a dense heat map of the pooled grid (`[bin][polarity][row][col]`).
    pub fn heatmap(&self) -> encoders::heatmap::Heatmap {
        let plane = 2 * self.height * self.width;
        let mut counts = vec![0f32; self.n_bins() * plane];
        for (b, cells) in self.bins().enumerate() {
            for c in cells {
                counts[b * plane + c.input as usize] += c.count;
            }
        }
        encoders::heatmap::Heatmap {
            t_start_us: self.t_end_us - self.bin_us * self.n_bins() as i64,
            bin_us: self.bin_us,
            bins: self.n_bins(),
            height: self.height,
            width: self.width,
            counts,
        }
    }
}

/// A network that reads a window: class probabilities (they sum to 1). The segmentation network
/// gives `[background, character]`, a character classifier the 26 letters A..Z or the 63 cells
/// ([`crate::words::Alphabet`]).
///
/// The network is shared (`&self`): whatever a stream keeps between windows (neuron state,
/// caches, counters) lives in its own [`WindowClassifier::State`], so one loaded model serves
/// any number of streams at once.
pub trait WindowClassifier {
    type State;

    /// The state of a new stream.
    fn new_state(&self) -> Self::State;

    fn classify(&self, state: &mut Self::State, window: &Window) -> Result<Vec<f32>>;
}
