//! The paper's character classifier: a ResNet over the window's heat map (frames x ON/OFF as
//! input channels): a 7x7 stride-2 convolution with batch norm and ReLU, 3x3 stride-2 max pooling,
//! residual stages of basic blocks, adaptive average pooling, then fully connected layers with
//! ReLU and dropout. `paper` is ResNet-34's stages (3, 4, 6, 3 blocks of 64 to 512 channels);
//! `lite` is narrower and shallower for two CPU cores.

mod direct;
pub mod folded;

#[cfg(feature = "train")]
mod dense;

#[cfg(feature = "train")]
pub use dense::*;
use serde::{Deserialize, Serialize};

/// The architecture, as a model file records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResnetConfig {
    /// Input `[channels, height, width]`.
    pub input: [usize; 3],
    pub stem_channels: usize,
    /// Per stage: (channels, basic blocks). Every stage after the first halves the resolution.
    pub stages: Vec<(usize, usize)>,
    /// Hidden fully connected widths (the last layer to `classes` comes after them).
    pub hidden: Vec<usize>,
    pub dropout: f64,
    pub classes: usize,
}

impl ResnetConfig {
    /// The paper's network: ResNet-34 stages, three fully connected layers.
    pub fn paper(input: [usize; 3], classes: usize) -> Self {
        Self {
            input,
            stem_channels: 64,
            stages: vec![(64, 3), (128, 4), (256, 6), (512, 3)],
            hidden: vec![256, 128],
            dropout: 0.5,
            classes,
        }
    }

    /// Fewer, narrower blocks: trains on two CPU cores.
    pub fn lite(input: [usize; 3], classes: usize) -> Self {
        Self { input, stem_channels: 16, stages: vec![(16, 1), (32, 1)], hidden: vec![64, 32], dropout: 0.3, classes }
    }

    /// The smallest: one narrow block per stage and one hidden layer; for the segmentation
    /// network, which runs on every frame of a stream.
    pub fn tiny(input: [usize; 3], classes: usize) -> Self {
        Self { input, stem_channels: 8, stages: vec![(8, 1), (16, 1)], hidden: vec![16], dropout: 0.2, classes }
    }

    /// Multiply-accumulates of one inference (convolutions and fully connected layers; batch
    /// norm, pooling and additions left out), for energy comparisons with an SNN's SynOps.
    pub fn macs(&self) -> u64 {
        let out = |n: usize, k: usize, s: usize, p: usize| (n + 2 * p - k) / s + 1;
        let [c_in, mut h, mut w] = self.input;
        let mut macs = 0u64;
        let mut conv = |h: &mut usize, w: &mut usize, ci: usize, co: usize, k: usize, s: usize, p: usize| {
            *h = out(*h, k, s, p);
            *w = out(*w, k, s, p);
            macs += (*h * *w * ci * co * k * k) as u64;
        };
        conv(&mut h, &mut w, c_in, self.stem_channels, 7, 2, 3);
        let (mut h, mut w) = (out(h, 3, 2, 1), out(w, 3, 2, 1));
        let mut c = self.stem_channels;
        for (k, &(o, n)) in self.stages.iter().enumerate() {
            for b in 0..n {
                let stride = if k > 0 && b == 0 { 2 } else { 1 };
                let (h0, w0) = (h, w);
                conv(&mut h, &mut w, c, o, 3, stride, 1);
                let (h1, w1) = (h, w);
                conv(&mut h, &mut w, o, o, 3, 1, 1);
                if stride != 1 || c != o {
                    let (mut hd, mut wd) = (h0, w0);
                    conv(&mut hd, &mut wd, c, o, 1, stride, 0);
                }
                (h, w) = (h1, w1);
                c = o;
            }
        }
        let mut n = c;
        for &f in self.hidden.iter().chain(std::iter::once(&self.classes)) {
            macs += (n * f) as u64;
            n = f;
        }
        macs
    }
}

/// The tests' reference convolution, summed plainly in f64: output `(oy, ox)` of one output
/// channel over `x` (`[c_in, h, w]`) with a kernel `k`, stride `s` and zero padding `p`, where
/// `weight(ci, ky, kx)` is that channel's weight; returns the sum and the sum of its terms'
/// magnitudes (for a tolerance).
#[cfg(test)]
fn plain_conv_at(
    x: &[f32],
    (c_in, h, w): (usize, usize, usize),
    (k, s, p): (usize, usize, usize),
    (oy, ox): (usize, usize),
    weight: impl Fn(usize, usize, usize) -> f32,
) -> (f64, f64) {
    let (mut sum, mut magnitude) = (0f64, 0f64);
    for ci in 0..c_in {
        for ky in 0..k {
            for kx in 0..k {
                let (iy, ix) = ((oy * s + ky) as isize - p as isize, (ox * s + kx) as isize - p as isize);
                if iy < 0 || ix < 0 || iy >= h as isize || ix >= w as isize {
                    continue;
                }
                let term = x[(ci * h + iy as usize) * w + ix as usize] as f64 * weight(ci, ky, kx) as f64;
                sum += term;
                magnitude += term.abs();
            }
        }
    }
    (sum, magnitude)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn macs_count_by_hand() {
        // stem 7x7 s2 p3 on 2x8x8 -> 4x4x4: 16*2*4*49 = 6272; pool -> 2x2; one block of 4
        // channels: two 3x3 convs on 2x2: 2 * 4*4*4*9 = 1152; fc 4 -> 3: 12
        let cfg = ResnetConfig {
            input: [2, 8, 8],
            stem_channels: 4,
            stages: vec![(4, 1)],
            hidden: vec![],
            dropout: 0.0,
            classes: 3,
        };
        assert_eq!(cfg.macs(), 6272 + 1152 + 12);
        // a second stage halves the resolution and adds a 1x1 projection: 2x2 -> 1x1 with 8 channels
        let cfg2 = ResnetConfig { stages: vec![(4, 1), (8, 1)], ..cfg };
        assert_eq!(cfg2.macs(), 6272 + 1152 + (4 * 8 * 9) + (8 * 8 * 9) + (4 * 8) + 8 * 3);
    }
}

/// Images with labels: `data[k]` is one `[channels, height, width]` image, C order.
#[derive(Debug, Clone, Default)]
pub struct ImageSet {
    pub shape: [usize; 3],
    pub data: Vec<Vec<f32>>,
    pub labels: Vec<usize>,
}

impl ImageSet {
    pub fn len(&self) -> usize {
        self.labels.len()
    }
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }
}
