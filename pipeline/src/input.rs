//! How a window becomes a network's input, as the model file records it: the crop of the
//! labeler's pooled grid, its pooling, the paper's preparation (for the ResNet) or the events as
//! input spikes (for the SNN). Training windows ([`crate::labeling::window_heatmap`]) and the
//! reader's streaming windows ([`crate::reader::Window`]) give the same input.

use crate::augment::{AugmentConfig, Preprocess, prepare};
use crate::error::{Error, Result};
use crate::labeling::LabelerConfig;
use encoders::heatmap::Heatmap;
use encoders::spike_train::SpikeTrain;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// How windows become network input, as the model file records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CharInput {
    pub labeler: LabelerConfig,
    /// Pooled rows and columns kept (the labeler masks columns outside 20-100 anyway).
    pub rows: Range<usize>,
    pub cols: Range<usize>,
    /// Sum-pooling of the crop (rows and columns); 1 keeps the labeler's grid.
    #[serde(default = "one")]
    pub pool: usize,
    pub preprocess: Preprocess,
    pub augment: AugmentConfig,
}

/// The `lite` crop (pooled rows and columns): the dots of one Braille row fill the middle of
/// the image. The ResNet lite and the SNN see it.
pub const LITE_ROWS: Range<usize> = 28..92;
pub const LITE_COLS: Range<usize> = 20..100;

fn one() -> usize {
    1
}

impl CharInput {
    pub fn shape(&self) -> [usize; 3] {
        let p = self.pool.max(1);
        [self.labeler.frames * 2, self.rows.len() / p, self.cols.len() / p]
    }

    /// The window's counts, cropped and pooled, as a heat map of the crop.
    pub fn crop(&self, map: &Heatmap) -> Result<Heatmap> {
        if self.rows.end > map.height || self.cols.end > map.width || map.bins != self.labeler.frames {
            return Err(Error::WindowShape {
                bins: map.bins,
                height: map.height,
                width: map.width,
                rows: self.rows.clone(),
                cols: self.cols.clone(),
                frames: self.labeler.frames,
            });
        }
        let [_, h, w] = self.shape();
        let p = self.pool.max(1);
        let mut counts = vec![0f32; map.bins * 2 * h * w];
        for plane in 0..map.bins * 2 {
            for (i, r) in self.rows.clone().take(h * p).enumerate() {
                let at = (plane * map.height + r) * map.width + self.cols.start;
                let out = (plane * h + i / p) * w;
                for (j, &v) in map.counts[at..at + w * p].iter().enumerate() {
                    counts[out + j / p] += v;
                }
            }
        }
        Ok(Heatmap { t_start_us: map.t_start_us, bin_us: map.bin_us, bins: map.bins, height: h, width: w, counts })
    }

    /// The crop of a streaming window (the reader's sparse bins on the labeler's pooled grid), as
    /// [`crop`](Self::crop) gives it for a labelled window.
    pub fn crop_window(&self, w: &crate::reader::Window) -> Result<Vec<f32>> {
        self.check_window(w)?;
        let [planes, h, wd] = self.shape();
        let mut out = vec![0f32; planes * h * wd];
        for (b, bin) in w.bins().enumerate() {
            for c in bin {
                if let Some(j) = self.crop_cell(c.input, w.height, w.width) {
                    out[b * 2 * h * wd + j] += c.count;
                }
            }
        }
        Ok(out)
    }

    /// An error unless `w` has the crop's bins and holds its rows and columns.
    pub fn check_window(&self, w: &crate::reader::Window) -> Result<()> {
        let [planes, ..] = self.shape();
        if w.n_bins() * 2 != planes || self.rows.end > w.height || self.cols.end > w.width {
            return Err(Error::WindowShape {
                bins: w.n_bins(),
                height: w.height,
                width: w.width,
                rows: self.rows.clone(),
                cols: self.cols.clone(),
                frames: self.labeler.frames,
            });
        }
        Ok(())
    }

    /// Where a reader's cell (input `polarity * cells + row * width + col` of a `height` x `width`
    /// grid) falls in one frame of the crop (`(polarity * rows + row) * cols + col`, pooled), or
    /// `None` outside the crop.
    #[inline]
    pub fn crop_cell(&self, input: u32, height: usize, width: usize) -> Option<usize> {
        let [_, h, w] = self.shape();
        let p = self.pool.max(1);
        let i = input as usize;
        let (pol, r, col) = (i / (height * width), (i % (height * width)) / width, i % width);
        if !self.rows.contains(&r) || !self.cols.contains(&col) {
            return None;
        }
        let (r, col) = ((r - self.rows.start) / p, (col - self.cols.start) / p);
        (r < h && col < w).then_some((pol * h + r) * w + col)
    }

    /// The cropped counts of an image as a heat map again.
    fn as_map(&self, counts: Vec<f32>) -> Heatmap {
        let [_, height, width] = self.shape();
        Heatmap { t_start_us: 0, bin_us: 1, bins: self.labeler.frames, height, width, counts }
    }

    /// An SNN's input from a cropped image: the window's events as input spikes, one step per
    /// frame (`dt_us` each), input `(polarity * height + row) * width + col`. Of the paper's
    /// preparation only the vertical centring applies (when configured: `norm`, `normaug`), as a
    /// whole-row shift that keeps every event; counts are events, so nothing is normalised.
    pub fn spikes(&self, image: &[f32], dt_us: i64) -> SpikeTrain {
        let mut map = self.as_map(image.to_vec());
        if self.preprocess.normalises() {
            crate::augment::center_vertically(&mut map);
        }
        SpikeTrain::from_dense(0, dt_us, 2 * map.height * map.width, &map.counts)
    }

    /// Network input of a cropped image: centred and normalised as configured; augmented when
    /// `rng` is given.
    pub fn prepare(&self, image: &[f32], rng: Option<&mut rand_chacha::ChaCha8Rng>) -> Vec<f32> {
        match rng {
            None => self.prepared(image.to_vec()),
            Some(r) => {
                prepare(&self.as_map(image.to_vec()), self.preprocess, &self.augment, Some(r as &mut dyn rand::RngCore))
                    .counts
            }
        }
    }

    /// [`prepare`](Self::prepare) without augmentation, in place: the reader's path, which owns
    /// the crop (the same numbers, without copying the image).
    pub fn prepared(&self, image: Vec<f32>) -> Vec<f32> {
        let mut map = self.as_map(image);
        crate::augment::center_and_normalise(&mut map, self.preprocess);
        map.counts
    }
}
