//! How a window becomes a network's input, as the model file records it: the crop of the
//! labeler's pooled grid, its pooling, the paper's preparation (for the ResNet) or the events as
//! input spikes (for the SNN). Training windows ([`crate::labeling::window_heatmap`]) and the
//! reader's streaming windows ([`crate::reader::Window`]) give the same input.

use crate::error::{Error, Result};
use crate::labeling::LabelerConfig;
use crate::preprocess::{AugmentConfig, Preprocess};
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
    /// Pooled rows the vertical centring looks in, wider than `rows` (`None`: `rows` alone). The
    /// window's events in the band are centred on the middle of `rows.len()` rows, so that a
    /// Braille row the board's yaw moves up or down past `rows` (at a row's start, far from the
    /// slide's middle) is moved back whole, where a fixed crop would cut its top or bottom dots.
    /// Only with a centring preprocess (`norm`, `normaug`); the crop is centred once, there.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band: Option<Range<usize>>,
    /// A background-activity filter every event passes before windowing, in training as in
    /// reading (`encoders::denoise`; `None`: the events as they come, as every model before the
    /// filter). A reader of this model filters the same way unless told otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub denoise: Option<encoders::denoise::NoiseFilterSettings>,
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

    /// The rows cropped from the labeler's grid: the band when there is one, else `rows`.
    pub fn source_rows(&self) -> Range<usize> {
        self.band.clone().unwrap_or_else(|| self.rows.clone())
    }

    /// The shape of what is cropped from the grid, before a band is centred into [`shape`](Self::shape).
    pub fn source_shape(&self) -> [usize; 3] {
        let [planes, _, w] = self.shape();
        [planes, self.source_rows().len() / self.pool.max(1), w]
    }

    /// Whether the crop is centred again after it is made (the preprocess centres, and no band
    /// has centred it).
    pub fn centres_after_crop(&self) -> bool {
        self.preprocess.normalises() && self.band.is_none()
    }

    /// An error unless the band (if any) holds `rows`, pools into whole rows and comes with a
    /// centring preprocess.
    pub fn check_band(&self) -> Result<()> {
        let Some(band) = &self.band else { return Ok(()) };
        let p = self.pool.max(1);
        let reason = if !self.preprocess.normalises() {
            Some("a band needs a centring preprocess (norm or normaug)")
        } else if band.start > self.rows.start || band.end < self.rows.end {
            Some("the band must hold the crop's rows")
        } else if band.len() % p != 0 {
            Some("the band's height must be a multiple of the pooling")
        } else {
            None
        };
        match reason {
            Some(reason) => Err(Error::Band { band: band.clone(), rows: self.rows.clone(), reason }),
            None => Ok(()),
        }
    }

    /// The band's pooled counts (planes of [`source_shape`](Self::source_shape)) centred into
    /// the crop's rows: every row moved by the centring shift of the band's events, what falls
    /// outside dropped. Without a band, the counts as they are.
    pub(crate) fn centre_band(&self, source: Vec<f32>) -> Vec<f32> {
        if self.band.is_none() {
            return source;
        }
        let [_, hb, w] = self.source_shape();
        let [planes, h, _] = self.shape();
        let shift = crate::preprocess::centring_shift(&source, hb, w, h);
        let mut out = vec![0f32; planes * h * w];
        for (plane, src) in out.chunks_exact_mut(h * w).zip(source.chunks_exact(hb * w)) {
            for (r, row) in src.chunks_exact(w).enumerate() {
                let to = r as i64 + shift;
                if (0..h as i64).contains(&to) {
                    plane[to as usize * w..(to as usize + 1) * w].copy_from_slice(row);
                }
            }
        }
        out
    }

    /// The window's counts, cropped and pooled, as a heat map of the crop.
    pub fn crop(&self, map: &Heatmap) -> Result<Heatmap> {
        self.check_band()?;
        let rows = self.source_rows();
        if rows.end > map.height || self.cols.end > map.width || map.bins != self.labeler.frames {
            return Err(Error::WindowShape {
                bins: map.bins,
                height: map.height,
                width: map.width,
                rows: rows.clone(),
                cols: self.cols.clone(),
                frames: self.labeler.frames,
            });
        }
        let [_, hb, w] = self.source_shape();
        let p = self.pool.max(1);
        let mut counts = vec![0f32; map.bins * 2 * hb * w];
        for plane in 0..map.bins * 2 {
            for (i, r) in rows.clone().take(hb * p).enumerate() {
                let at = (plane * map.height + r) * map.width + self.cols.start;
                let out = (plane * hb + i / p) * w;
                for (j, &v) in map.counts[at..at + w * p].iter().enumerate() {
                    counts[out + j / p] += v;
                }
            }
        }
        let [_, h, _] = self.shape();
        let counts = self.centre_band(counts);
        Ok(Heatmap { t_start_us: map.t_start_us, bin_us: map.bin_us, bins: map.bins, height: h, width: w, counts })
    }

    /// The crop of a streaming window (the reader's sparse bins on the labeler's pooled grid), as
    /// [`crop`](Self::crop) gives it for a labelled window.
    pub fn crop_window(&self, w: &crate::reader::Window) -> Result<Vec<f32>> {
        self.check_window(w)?;
        let [planes, hb, wd] = self.source_shape();
        let mut out = vec![0f32; planes * hb * wd];
        for (b, bin) in w.bins().enumerate() {
            for c in bin {
                if let Some(j) = self.crop_cell(c.input, w.height, w.width) {
                    out[b * 2 * hb * wd + j] += c.count;
                }
            }
        }
        Ok(self.centre_band(out))
    }

    /// An error unless `w` has the crop's bins and holds its rows and columns.
    pub fn check_window(&self, w: &crate::reader::Window) -> Result<()> {
        self.check_band()?;
        let [planes, ..] = self.shape();
        if w.n_bins() * 2 != planes || self.source_rows().end > w.height || self.cols.end > w.width {
            return Err(Error::WindowShape {
                bins: w.n_bins(),
                height: w.height,
                width: w.width,
                rows: self.source_rows(),
                cols: self.cols.clone(),
                frames: self.labeler.frames,
            });
        }
        Ok(())
    }

    /// Where a reader's cell (input `polarity * cells + row * width + col` of a `height` x `width`
    /// grid) falls in one frame of the crop (`(polarity * rows + row) * cols + col`, pooled; with
    /// a band, of the band's rows, before it is centred), or `None` outside it.
    #[inline]
    pub fn crop_cell(&self, input: u32, height: usize, width: usize) -> Option<usize> {
        let [_, h, w] = self.source_shape();
        let rows = self.source_rows();
        let p = self.pool.max(1);
        let i = input as usize;
        let (pol, r, col) = (i / (height * width), (i % (height * width)) / width, i % width);
        if !rows.contains(&r) || !self.cols.contains(&col) {
            return None;
        }
        let (r, col) = ((r - rows.start) / p, (col - self.cols.start) / p);
        (r < h && col < w).then_some((pol * h + r) * w + col)
    }

    /// The cropped counts of an image as a heat map again.
    pub fn as_map(&self, counts: Vec<f32>) -> Heatmap {
        let [_, height, width] = self.shape();
        Heatmap { t_start_us: 0, bin_us: 1, bins: self.labeler.frames, height, width, counts }
    }

    /// An SNN's input from a cropped image: the window's events as input spikes, one step per
    /// frame (`dt_us` each), input `(polarity * height + row) * width + col`. Of the paper's
    /// preparation only the vertical centring applies (when configured: `norm`, `normaug`, and
    /// not done by a band already), as a whole-row shift; counts are events, so nothing is
    /// normalised.
    pub fn spikes(&self, image: &[f32], dt_us: i64) -> SpikeTrain {
        let mut map = self.as_map(image.to_vec());
        if self.centres_after_crop() {
            crate::preprocess::center_vertically(&mut map);
        }
        SpikeTrain::from_dense(0, dt_us, 2 * map.height * map.width, &map.counts)
    }

    /// Network input of a cropped image: centred and normalised as configured (training's
    /// augmentation is `experiments::train::augment`).
    pub fn prepare(&self, image: &[f32]) -> Vec<f32> {
        self.prepared(image.to_vec())
    }

    /// [`prepare`](Self::prepare) without augmentation, in place: the reader's path, which owns
    /// the crop (the same numbers, without copying the image).
    pub fn prepared(&self, image: Vec<f32>) -> Vec<f32> {
        let mut map = self.as_map(image);
        crate::preprocess::centre_and_scale(&mut map, self.preprocess, self.centres_after_crop());
        map.counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SNN reader's input: pooled rows 20..100 and columns 20..100 of the labeler's 120 x 160
    /// grid, pooled by 2, centred.
    fn input(band: Option<Range<usize>>) -> CharInput {
        CharInput {
            labeler: LabelerConfig::default(),
            rows: 20..100,
            cols: 20..100,
            pool: 2,
            preprocess: Preprocess::Norm,
            augment: AugmentConfig::default(),
            band,
            denoise: None,
        }
    }

    /// A window of the labeler's grid with `dots` (row, column) holding events in a few frames.
    fn window(dots: &[(usize, usize)]) -> Heatmap {
        let frames = LabelerConfig::default().frames;
        let (h, w) = (120, 160);
        let mut counts = vec![0f32; frames * 2 * h * w];
        for (k, &(r, c)) in dots.iter().enumerate() {
            for f in [3, 7, 8, 12] {
                let plane = 2 * f + k % 2;
                counts[(plane * h + r) * w + c] += 1.0 + (k % 3) as f32;
            }
        }
        Heatmap { t_start_us: 0, bin_us: 10_000, bins: frames, height: h, width: w, counts }
    }

    /// A cell's six dots (two columns, three rows 21 pooled rows apart: 2.5 mm) from `top`.
    fn cell(top: usize) -> Vec<(usize, usize)> {
        (0..3).flat_map(|r| [(top + 21 * r, 50), (top + 21 * r, 71)]).collect()
    }

    #[test]
    fn a_band_of_the_crops_own_rows_changes_nothing() {
        let map = window(&cell(31));
        let (plain, band) = (input(None), input(Some(20..100)));
        let (a, b) = (plain.crop(&map).unwrap(), band.crop(&map).unwrap());
        assert_eq!(plain.spikes(&a.counts, 10_000), band.spikes(&b.counts, 10_000));
        assert_eq!(plain.prepared(a.counts.clone()), band.prepared(b.counts.clone()));
    }

    #[test]
    fn a_band_takes_back_a_row_the_crop_would_cut() {
        // the cell 24 pooled rows above the middle (a row's start under the board's yaw): its top
        // dots fall above the crop's rows 20..100, inside the band 4..116
        let (middle, high) = (window(&cell(39)), window(&cell(15)));
        let (plain, band) = (input(None), input(Some(4..116)));
        let total = |m: &Heatmap| m.counts.iter().sum::<f32>();
        let cut = plain.crop(&high).unwrap();
        assert!(total(&cut) < total(&high), "the fixed crop cuts the top dots");
        let whole = band.crop(&high).unwrap();
        assert_eq!(total(&whole), total(&high), "the band keeps every event");
        // centred, the moved cell gives the input the centred cell gives
        let reference = plain.crop(&middle).unwrap();
        assert_eq!(band.spikes(&whole.counts, 10_000), plain.spikes(&reference.counts, 10_000));
        assert_eq!(band.prepared(whole.counts), plain.prepared(reference.counts.clone()));
        assert_ne!(plain.spikes(&cut.counts, 10_000), plain.spikes(&reference.counts, 10_000));
    }

    #[test]
    fn a_band_that_cannot_centre_the_crop_is_refused() {
        let bad = |i: CharInput| matches!(i.check_band(), Err(Error::Band { .. }));
        assert!(input(None).check_band().is_ok() && input(Some(4..116)).check_band().is_ok());
        assert!(bad(CharInput { preprocess: Preprocess::Raw, ..input(Some(4..116)) }));
        assert!(bad(input(Some(30..116))), "the band must hold the crop's rows");
        assert!(bad(input(Some(4..115))), "whole pooled rows");
        let raw = CharInput { preprocess: Preprocess::Raw, ..input(Some(4..116)) };
        assert!(matches!(raw.crop(&window(&cell(39))), Err(Error::Band { .. })), "crop checks the band");
    }
}
