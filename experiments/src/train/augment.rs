//! Training-time augmentation of the character classifiers' windows (the paper's NormAug and its
//! ablations): a random rotation, scaling and shift, and salt-and-pepper noise, after the
//! preparation a reader does too ([`pipeline::preprocess`]). Readers never augment.

use encoders::heatmap::Heatmap;
use pipeline::input::CharInput;
use pipeline::preprocess::{AugmentConfig, centre_and_scale};
use rand::Rng;

/// A training window of `input`'s crop, prepared as a reader prepares it (centred and normalised
/// as configured), then augmented when the input's preprocess augments (`aug`, `normaug`,
/// `scaleaug`).
pub fn prepare_augmented(input: &CharInput, image: &[f32], rng: &mut impl Rng) -> Vec<f32> {
    let mut map = input.as_map(image.to_vec());
    centre_and_scale(&mut map, input.preprocess, input.centres_after_crop());
    if input.preprocess.augments() { augment(&map, &input.augment, rng).counts } else { map.counts }
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

#[cfg(test)]
mod tests {
    use super::*;
    use encoders::Resolution;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

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
}
