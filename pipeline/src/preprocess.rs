//! The paper's input preparation for the character classifiers: vertical centring and the
//! normalisation, and the record of the training-time augmentation a model was trained with
//! ([`AugmentConfig`]; the augmentation itself is training's, `experiments::train::augment`).
//!
//! The paper calls its normalisation custom and does not define it. Ours: each count `c` becomes
//! `ln(1 + c)`, divided by the sample's largest such value, so every sample spans [0, 1]. Events
//! per dot grow by up to 91% from 0.2 mm to 1.5 mm of depth; after this normalisation a shallow
//! and a deep press of the same letter look alike, which is the point of normalising for depth,
//! and the logarithm keeps the many weak pixels of a shallow press from vanishing under a few
//! strong ones.

use encoders::heatmap::Heatmap;
use serde::{Deserialize, Serialize};

/// The paper's four input configurations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Preprocess {
    /// Counts as they are.
    Raw,
    /// Vertical centring and normalisation.
    Norm,
    /// Augmentation only (in training).
    Aug,
    /// Centring, normalisation and augmentation (in training).
    #[default]
    #[cfg_attr(feature = "clap", value(name = "normaug"))]
    NormAug,
    /// Normalisation and augmentation without the vertical centring: for the cell classifiers,
    /// which tell dot 1 from dot 2 and dot 3 by its height in the row.
    #[cfg_attr(feature = "clap", value(name = "scaleaug"))]
    ScaleAug,
}

impl Preprocess {
    /// Whether windows are centred vertically (and, for the ResNet, normalised).
    pub fn normalises(self) -> bool {
        matches!(self, Preprocess::Norm | Preprocess::NormAug)
    }
    /// Whether counts are normalised (`ln(1 + c)`, the largest 1).
    pub fn scales(self) -> bool {
        matches!(self, Preprocess::Norm | Preprocess::NormAug | Preprocess::ScaleAug)
    }
    pub fn augments(self) -> bool {
        matches!(self, Preprocess::Aug | Preprocess::NormAug | Preprocess::ScaleAug)
    }
}

/// Training-time augmentation, the paper's values, as a model file records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AugmentConfig {
    /// Probability of the spatial transform, and its ranges.
    pub p_affine: f64,
    pub rotation_deg: f64,
    /// Largest shift as a share of the width and height.
    pub translation: f64,
    pub scale_min: f64,
    pub scale_max: f64,
    /// Probability of salt-and-pepper noise, and the share of cells it toggles.
    pub p_salt_pepper: f64,
    pub salt_pepper_rate: f64,
}

impl Default for AugmentConfig {
    fn default() -> Self {
        Self {
            p_affine: 0.5,
            rotation_deg: 10.0,
            translation: 0.1,
            scale_min: 0.8,
            scale_max: 1.2,
            p_salt_pepper: 0.5,
            salt_pepper_rate: 1e-5,
        }
    }
}

/// Moves the rows so that the centre of mass of all events sits on the middle row (zero fill).
pub fn center_vertically(map: &mut Heatmap) {
    let (h, w) = (map.height, map.width);
    let shift = centring_shift(&map.counts, h, w, h);
    if shift == 0 {
        return;
    }
    // every row moves by `shift` (what leaves the plane is dropped), rows left empty are zero
    let k = (shift.unsigned_abs() as usize).min(h) * w;
    for plane in map.counts.chunks_exact_mut(h * w) {
        if shift > 0 {
            plane.copy_within(..h * w - k, k);
            plane[..k].fill(0.0);
        } else {
            plane.copy_within(k.., 0);
            plane[h * w - k..].fill(0.0);
        }
    }
}

/// The rows to move planes of `h` rows of `w` (`counts`, plane after plane) so that the centre
/// of mass of all events sits on the middle row of `h_out` rows: `round((h_out - 1) / 2 - mean
/// row)`, 0 for no events.
pub fn centring_shift(counts: &[f32], h: usize, w: usize, h_out: usize) -> i64 {
    let (mut mass, mut moment) = (0.0f64, 0.0f64);
    for plane in counts.chunks_exact(h * w) {
        for (r, row) in plane.chunks_exact(w).enumerate() {
            // the cells that are +0.0 add nothing (a window's heat map is mostly empty)
            let s: f64 = row.iter().filter(|v| v.to_bits() != 0).map(|&v| v as f64).sum();
            mass += s;
            moment += s * r as f64;
        }
    }
    shift_of(mass, moment, h_out)
}

/// [`centring_shift`] from the events' count and their sum of rows.
pub fn shift_of(mass: f64, moment: f64, h_out: usize) -> i64 {
    if mass > 0.0 { ((h_out as f64 - 1.0) / 2.0 - moment / mass).round() as i64 } else { 0 }
}

/// `ln(1 + c)` scaled so the sample's largest value is 1 (an empty sample stays zero). Cells at
/// +0.0 stay +0.0, as the formula leaves them, without computing it (a window is mostly empty).
pub fn normalise(map: &mut Heatmap) {
    let nonzero = |c: &f32| c.to_bits() != 0;
    let table = ln_1p_table();
    let ln_1p = |c: f32| ln_1p_count(c.max(0.0), table);
    let max = map.counts.iter().filter(|c| nonzero(c)).map(|&c| ln_1p(c)).fold(0.0f32, f32::max);
    if max > 0.0 {
        map.counts.iter_mut().filter(|c| nonzero(c)).for_each(|c| *c = ln_1p(*c) / max);
    }
}

/// `ln(1 + c)` of the whole counts below 256, made once: a window's cells count events, so the
/// reader's maps hold whole numbers, and looking them up is cheaper than the logarithm.
fn ln_1p_table() -> &'static [f32; 256] {
    static LN_1P_COUNTS: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    LN_1P_COUNTS.get_or_init(|| std::array::from_fn(|i| (i as f32).ln_1p()))
}

/// `c.ln_1p()`, looked up in `table` for the whole numbers 1-255 (the same floats: the table holds
/// that function's values), computed for the rest (zeros keep their sign, NaN stays NaN).
#[inline]
fn ln_1p_count(c: f32, table: &[f32; 256]) -> f32 {
    let i = c as usize;
    if (1..256).contains(&i) && i as f32 == c { table[i] } else { c.ln_1p() }
}

/// The preparation without augmentation, in place: centring as `centre` says (what `mode` says,
/// unless a band has centred the crop already), normalisation as `mode` says.
pub fn centre_and_scale(map: &mut Heatmap, mode: Preprocess, centre: bool) {
    if centre {
        center_vertically(map);
    }
    if mode.scales() {
        normalise(map);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use encoders::Resolution;

    /// The looked-up logarithm is the computed one to the bit: whole counts, fractions, both
    /// zeros, NaN, the table's edges and beyond.
    #[test]
    fn a_counts_logarithm_is_the_computed_one() {
        let table = ln_1p_table();
        let mut values = vec![0.0, -0.0, 0.5, 1.0, 1.5, 254.5, 255.0, 256.0, 300.0, 1e9, f32::NAN, f32::INFINITY];
        values.extend((0..600).map(|i| i as f32 * 0.5));
        for c in values {
            assert_eq!(ln_1p_count(c, table).to_bits(), c.ln_1p().to_bits(), "{c}");
        }
    }

    fn blob(row: usize, col: usize) -> Heatmap {
        let mut m = Heatmap::zeros(0, 10_000, 2, Resolution::new(40, 30));
        for dr in 0..3 {
            for dc in 0..3 {
                let i = m.index(1, 1, row + dr, col + dc);
                m.counts[i] = 4.0;
            }
        }
        m
    }

    #[test]
    fn centring_puts_the_centre_of_mass_on_the_midline() {
        let mut m = blob(3, 10);
        center_vertically(&mut m);
        let rows: Vec<usize> = (0..30).filter(|&r| m.get(1, 1, r, 11) > 0.0).collect();
        assert_eq!(rows, vec![14, 15, 16]);
        assert_eq!(m.total(), 36.0);
    }

    #[test]
    fn normalisation_spans_zero_to_one_and_keeps_order() {
        let mut m = blob(3, 10);
        m.counts[0] = 1.0;
        normalise(&mut m);
        let max = m.counts.iter().cloned().fold(0.0f32, f32::max);
        assert!((max - 1.0).abs() < 1e-6);
        assert!(m.counts[0] > 0.0 && m.counts[0] < 1.0);
    }

    #[test]
    fn evaluation_centres_and_normalises_as_configured() {
        let m = blob(3, 10);
        let mut p = m.clone();
        centre_and_scale(&mut p, Preprocess::NormAug, true);
        let mut expected = m.clone();
        center_vertically(&mut expected);
        normalise(&mut expected);
        assert_eq!(p, expected);
        let mut raw = m.clone();
        centre_and_scale(&mut raw, Preprocess::Raw, false);
        assert_eq!(raw, m);
    }
}
