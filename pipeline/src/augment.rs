//! The paper's input preparation for the character classifiers: vertical centring, the
//! normalisation, and training-time augmentation (NormAug and its ablations).
//!
//! The paper calls its normalisation custom and does not define it. Ours: each count `c` becomes
//! `ln(1 + c)`, divided by the sample's largest such value, so every sample spans [0, 1]. Events
//! per dot grow by up to 91% from 0.2 mm to 1.5 mm of depth; after this normalisation a shallow
//! and a deep press of the same letter look alike, which is the point of normalising for depth,
//! and the logarithm keeps the many weak pixels of a shallow press from vanishing under a few
//! strong ones.

use encoders::heatmap::Heatmap;
use rand::Rng;
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

/// Training-time augmentation, the paper's values.
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

/// The same rotation, scaling and shift for every frame and channel, sampled bilinearly about
/// the centre; what falls outside is zero.
pub fn affine(map: &Heatmap, rotation_deg: f64, scale: f64, shift_x: f64, shift_y: f64) -> Heatmap {
    let (h, w) = (map.height, map.width);
    let (cy, cx) = ((h as f64 - 1.0) / 2.0, (w as f64 - 1.0) / 2.0);
    let (s, c) = rotation_deg.to_radians().sin_cos();
    let mut out = map.clone();
    for (src, dst) in map.counts.chunks_exact(h * w).zip(out.counts.chunks_exact_mut(h * w)) {
        for y in 0..h {
            for x in 0..w {
                // inverse map: output pixel -> input position
                let (dx, dy) = ((x as f64 - cx - shift_x) / scale, (y as f64 - cy - shift_y) / scale);
                let (sx, sy) = (c * dx + s * dy + cx, -s * dx + c * dy + cy);
                dst[y * w + x] = bilinear(src, w, h, sx, sy);
            }
        }
    }
    out
}

fn bilinear(p: &[f32], w: usize, h: usize, x: f64, y: f64) -> f32 {
    if x < 0.0 || y < 0.0 || x > (w - 1) as f64 || y > (h - 1) as f64 {
        return 0.0;
    }
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (tx, ty) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let top = p[y0 * w + x0] * (1.0 - tx) + p[y0 * w + x1] * tx;
    let bottom = p[y1 * w + x0] * (1.0 - tx) + p[y1 * w + x1] * tx;
    top * (1.0 - ty) + bottom * ty
}

/// Training-time augmentation: with `p_affine` a random rotation, scaling and shift; with
/// `p_salt_pepper` each cell toggled (empty to the sample's maximum, else to empty) at
/// `salt_pepper_rate`.
pub fn augment(map: &Heatmap, cfg: &AugmentConfig, rng: &mut impl Rng) -> Heatmap {
    let mut out = if rng.random_bool(cfg.p_affine) {
        let rot = rng.random_range(-cfg.rotation_deg..=cfg.rotation_deg);
        let scale = rng.random_range(cfg.scale_min..=cfg.scale_max);
        let tx = rng.random_range(-cfg.translation..=cfg.translation) * map.width as f64;
        let ty = rng.random_range(-cfg.translation..=cfg.translation) * map.height as f64;
        affine(map, rot, scale, tx, ty)
    } else {
        map.clone()
    };
    if rng.random_bool(cfg.p_salt_pepper) && cfg.salt_pepper_rate > 0.0 {
        let high = out.counts.iter().cloned().fold(0.0f32, f32::max).max(1.0);
        // Toggled cells are drawn by geometric gaps, so the cost follows the toggles, not the cells.
        let n = out.counts.len();
        let ln_q = (1.0 - cfg.salt_pepper_rate).ln();
        let mut i = 0usize;
        loop {
            let u: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
            i += (u.ln() / ln_q).floor() as usize;
            if i >= n {
                break;
            }
            out.counts[i] = if out.counts[i] > 0.0 { 0.0 } else { high };
            i += 1;
        }
    }
    out
}

/// Prepares one sample: centring and normalisation for `Norm`/`NormAug`, then (in training, when
/// `rng` is given) augmentation for `Aug`/`NormAug`.
pub fn prepare(map: &Heatmap, mode: Preprocess, cfg: &AugmentConfig, rng: Option<&mut dyn rand::RngCore>) -> Heatmap {
    prepare_centred(map, mode, mode.normalises(), cfg, rng)
}

/// [`prepare`] with the vertical centring as `centre` says, whatever `mode` says of it: `false`
/// for a crop the band has centred already ([`crate::input::CharInput::band`]).
pub fn prepare_centred(
    map: &Heatmap,
    mode: Preprocess,
    centre: bool,
    cfg: &AugmentConfig,
    rng: Option<&mut dyn rand::RngCore>,
) -> Heatmap {
    let mut m = map.clone();
    centre_and_scale(&mut m, mode, centre);
    match (mode.augments(), rng) {
        (true, Some(rng)) => augment(&m, cfg, &mut RngRef(rng)),
        _ => m,
    }
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

/// Lends a `dyn RngCore` as an `Rng`.
struct RngRef<'a>(&'a mut dyn rand::RngCore);

impl rand::RngCore for RngRef<'_> {
    fn next_u32(&mut self) -> u32 {
        self.0.next_u32()
    }
    fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    fn fill_bytes(&mut self, dst: &mut [u8]) {
        self.0.fill_bytes(dst)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use encoders::Resolution;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

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
    fn identity_affine_changes_nothing_and_rotation_keeps_mass() {
        let m = blob(13, 18);
        assert_eq!(affine(&m, 0.0, 1.0, 0.0, 0.0), m);
        let r = affine(&m, 10.0, 1.0, 0.0, 0.0);
        assert!((r.total() - m.total()).abs() / m.total() < 0.1, "{} vs {}", r.total(), m.total());
        let shifted = affine(&m, 0.0, 1.0, 3.0, 0.0);
        assert_eq!(shifted.get(1, 1, 14, 22), m.get(1, 1, 14, 19));
    }

    #[test]
    fn augmentation_is_seeded_and_salt_and_pepper_follows_its_rate() {
        let m = blob(13, 18);
        let cfg = AugmentConfig::default();
        let a = augment(&m, &cfg, &mut ChaCha8Rng::seed_from_u64(3));
        let b = augment(&m, &cfg, &mut ChaCha8Rng::seed_from_u64(3));
        assert_eq!(a, b);
        let noisy = AugmentConfig { p_affine: 0.0, p_salt_pepper: 1.0, salt_pepper_rate: 0.01, ..cfg };
        let big = Heatmap::zeros(0, 1, 20, Resolution::new(160, 120));
        let n = augment(&big, &noisy, &mut ChaCha8Rng::seed_from_u64(1)).counts.iter().filter(|&&v| v > 0.0).count();
        let expected = 0.01 * big.counts.len() as f64;
        assert!((n as f64 / expected - 1.0).abs() < 0.1, "{n} toggles, expected {expected}");
    }

    #[test]
    fn evaluation_never_augments() {
        let m = blob(3, 10);
        let p = prepare(&m, Preprocess::NormAug, &AugmentConfig::default(), None);
        let mut expected = m.clone();
        center_vertically(&mut expected);
        normalise(&mut expected);
        assert_eq!(p, expected);
        assert_eq!(prepare(&m, Preprocess::Raw, &AugmentConfig::default(), None), m);
    }
}
