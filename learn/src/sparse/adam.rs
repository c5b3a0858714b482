//! The optimiser.

use super::*;

/// Adam (AdamW with a weight decay), with each tensor's gradient norm clipped, as burn's
/// `AdamConfig` / `AdamWConfig` with their defaults (betas 0.9 and 0.999, epsilon 1e-5).
#[derive(Debug, Clone)]
pub struct Adam {
    pub weight_decay: f32,
    /// 0: no clipping.
    pub clip_norm: f32,
    /// L2-SP (Li et al., ICML 2018, "Explicit inductive bias for transfer learning with
    /// convolutional networks"), decoupled as AdamW decouples its decay: every step pulls each
    /// weight toward its value in these starting weights by `lr * strength * (w - w0)`.
    pub anchor: Option<(Params, f32)>,
    /// Layers whose tensors stay as they started (true: frozen), by layer index.
    pub frozen: Vec<bool>,
    pub(super) m: Params,
    pub(super) v: Params,
    pub(super) time: i32,
}

impl Adam {
    pub fn new(params: &Params, weight_decay: f32, clip_norm: f32) -> Adam {
        Adam {
            weight_decay,
            clip_norm,
            anchor: None,
            frozen: Vec::new(),
            m: params.zeros_like(),
            v: params.zeros_like(),
            time: 0,
        }
    }

    /// Pulls the weights toward `start` with `strength` per unit of learning rate (L2-SP; 0: off).
    pub fn with_anchor(mut self, start: &Params, strength: f32) -> Adam {
        self.anchor = (strength > 0.0).then(|| (start.clone(), strength));
        self
    }

    /// Keeps the layers marked true as they are.
    pub fn with_frozen(mut self, frozen: Vec<bool>) -> Adam {
        self.frozen = frozen;
        self
    }

    /// Forgets the moments, as a new optimiser would (the anchor and frozen layers kept).
    pub fn restart(&mut self) {
        self.m = self.m.zeros_like();
        self.v = self.v.zeros_like();
        self.time = 0;
    }

    /// One step of `lr` along `grads`.
    pub fn step(&mut self, params: &mut Params, grads: &Params, lr: f64) {
        const B1: f32 = 0.9;
        const B2: f32 = 0.999;
        const EPS: f32 = 1e-5;
        self.time += 1;
        let bc2 = (1.0 - B2.powi(self.time)).sqrt();
        let factor = bc2 / (1.0 - B1.powi(self.time));
        let decay = 1.0 - (lr * self.weight_decay as f64) as f32;
        // at most all the way back (a larger pull would overshoot the start)
        let pull = self.anchor.as_ref().map(|(_, s)| ((lr * *s as f64) as f32).min(1.0));
        let lr = lr as f32;
        for (l, (((layer, g), m), v)) in
            params.layers.iter_mut().zip(&grads.layers).zip(&mut self.m.layers).zip(&mut self.v.layers).enumerate()
        {
            if self.frozen.get(l).copied().unwrap_or(false) {
                continue;
            }
            let anchor = self.anchor.as_ref().map(|(a, _)| a.layers[l].all());
            for (k, (((p, g), m), v)) in
                layer.all_mut().into_iter().zip(g.all()).zip(m.all_mut()).zip(v.all_mut()).enumerate()
            {
                let clip = if self.clip_norm > 0.0 {
                    let norm = g.iter().map(|g| g * g).sum::<f32>().sqrt();
                    (self.clip_norm / (norm + f32::MIN_POSITIVE)).min(1.0)
                } else {
                    1.0
                };
                for (((p, &g), m), v) in p.iter_mut().zip(g).zip(m.iter_mut()).zip(v.iter_mut()) {
                    let g = g * clip;
                    *m = *m * B1 + g * (1.0 - B1);
                    *v = *v * B2 + g * g * (1.0 - B2);
                    let delta = *m * factor / (v.sqrt() + EPS * bc2);
                    if self.weight_decay > 0.0 {
                        *p *= decay;
                    }
                    *p -= lr * delta;
                }
                if let (Some(pull), Some(a)) = (pull, &anchor) {
                    p.iter_mut().zip(a[k]).for_each(|(p, &a)| *p = a + (1.0 - pull) * (*p - a));
                }
            }
        }
    }
}
