//! The losses a batch's gradient starts from: cross-entropy and knowledge distillation.

use super::*;

/// Cross-entropy of `logits` against `label`: the loss, its gradient by the logits, and whether
/// the highest logit (the first of ties) is the label.
pub fn cross_entropy(logits: &[f32], label: usize) -> (f64, Vec<f32>, bool) {
    let m = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let e: Vec<f64> = logits.iter().map(|&l| ((l - m) as f64).exp()).collect();
    let s: f64 = e.iter().sum();
    let loss = -((logits[label] - m) as f64 - s.ln());
    let g = e.iter().enumerate().map(|(c, &e)| (e / s) as f32 - (c == label) as u32 as f32).collect();
    let best = logits.iter().enumerate().fold(0, |b, (c, &l)| if l > logits[b] { c } else { b });
    (loss, g, best == label)
}

/// Knowledge distillation's mix of losses (Hinton, Vinyals and Dean 2015): `1 - weight` of the
/// cross-entropy against the label and `weight` of `temperature^2` times the Kullback-Leibler
/// divergence of the student's softened distribution (`softmax(logits / T)`) from the teacher's
/// (`softmax(teacher / T)`); `T^2` keeps the soft term's gradient at the hard term's scale.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Distill {
    /// The soft term's share, in [0, 1].
    pub weight: f32,
    /// `T`, above 0.
    pub temperature: f32,
}

/// [`Distill`]'s loss of `logits` against `label` and the teacher's logits: the loss, its
/// gradient by the logits, and whether the highest logit (the first of ties) is the label.
pub fn distillation(logits: &[f32], label: usize, teacher: &[f32], d: Distill) -> (f64, Vec<f32>, bool) {
    let (hard, g_hard, hit) = cross_entropy(logits, label);
    let t = d.temperature as f64;
    let (q, p) = (softmax_at(logits, d.temperature), softmax_at(teacher, d.temperature));
    let kl: f64 = p.iter().zip(&q).filter(|(p, _)| **p > 0.0).map(|(p, q)| p * (p.ln() - q.ln())).sum();
    let w = d.weight as f64;
    let loss = (1.0 - w) * hard + w * t * t * kl;
    // d(T^2 KL)/dz = T (q - p)
    let g = g_hard
        .iter()
        .zip(q.iter().zip(&p))
        .map(|(&h, (q, p))| ((1.0 - w) * h as f64 + w * t * (q - p)) as f32)
        .collect();
    (loss, g, hit)
}

/// `softmax(z / temperature)`, in f64 (the distributions [`distillation`] compares).
pub fn softmax_at(z: &[f32], temperature: f32) -> Vec<f64> {
    let (m, t) = (z.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64, temperature as f64);
    let e: Vec<f64> = z.iter().map(|&l| ((l as f64 - m) / t).exp()).collect();
    let s: f64 = e.iter().sum();
    e.into_iter().map(|e| e / s).collect()
}
