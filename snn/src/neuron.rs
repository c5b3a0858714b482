//! Neuron models and their parameters, apart from their state (which the caller owns).
//!
//! Continuous-time configurations ([`LifConfig`]) carry units in their names; the engine runs
//! their discrete form ([`NeuronParams`]) for a time step `dt`. The discrete update, per step `t`
//! with summed input `u[t]` (the NIR convention with `r * dt / tau = 1`, as snnTorch and Norse):
//!
//! ```text
//! CubaLIF:  i[t] = alpha * i[t-1] + u[t];   v'[t] = beta * v[t-1] + (1 - beta) * v_leak + i[t]
//! LIF:      v'[t] = beta * v[t-1] + (1 - beta) * v_leak + u[t]
//! IF:       v'[t] = v[t-1] + u[t]
//! spike:    z[t] = v'[t] > v_th
//! reset:    Zero: v[t] = v_reset if z[t];  Subtract: v[t] = v'[t] - v_th if z[t]
//! ```

use serde::{Deserialize, Serialize};

/// What a neuron does after it spikes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Reset {
    /// Back to `v_reset`.
    Zero,
    /// Down by `v_th`, keeping what exceeded it.
    Subtract,
}

/// The derivative used in place of the spike's in training.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Surrogate {
    /// `x / (1 + slope |x|)`, derivative `1 / (1 + slope |x|)^2` (SuperSpike, snnTorch's default).
    FastSigmoid { slope: f32 },
    /// `atan(pi alpha x / 2) / pi`, derivative `alpha / 2 / (1 + (pi alpha x / 2)^2)`.
    Arctan { alpha: f32 },
    /// Derivative `max(0, 1 - |x| / width) / width`.
    Triangle { width: f32 },
}

impl Surrogate {
    /// The surrogate derivative at `x = v - v_th`.
    #[inline]
    pub fn derivative(self, x: f32) -> f32 {
        match self {
            Surrogate::FastSigmoid { slope } => 1.0 / (1.0 + slope * x.abs()).powi(2),
            Surrogate::Arctan { alpha } => {
                let a = std::f32::consts::PI * alpha * x / 2.0;
                alpha / 2.0 / (1.0 + a * a)
            }
            Surrogate::Triangle { width } => (1.0 - x.abs() / width).max(0.0) / width,
        }
    }
}

/// The neuron model of a layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum NeuronKind {
    Lif,
    CubaLif,
    If,
    /// Leaky integrator: a LIF membrane that never fires (NIR's `LI`), the readout of
    /// max-membrane classifiers.
    Li,
}

/// How continuous time constants become per-step factors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Discretisation {
    /// `beta = exp(-dt / tau)`: exact for the decay, so halving dt keeps the dynamics.
    Exact,
    /// `beta = 1 - dt / tau`: forward Euler, NIR's reference and snnTorch's export.
    Euler,
}

/// A neuron in continuous time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LifConfig {
    pub kind: NeuronKind,
    pub tau_mem_us: f64,
    /// CubaLIF only.
    pub tau_syn_us: f64,
    pub v_th: f32,
    pub v_reset: f32,
    pub v_leak: f32,
    pub reset: Reset,
}

impl LifConfig {
    pub fn lif(tau_mem_us: f64) -> Self {
        Self {
            kind: NeuronKind::Lif,
            tau_mem_us,
            tau_syn_us: 0.0,
            v_th: 1.0,
            v_reset: 0.0,
            v_leak: 0.0,
            reset: Reset::Zero,
        }
    }

    pub fn cuba_lif(tau_mem_us: f64, tau_syn_us: f64) -> Self {
        Self { kind: NeuronKind::CubaLif, tau_syn_us, ..Self::lif(tau_mem_us) }
    }

    pub fn integrate_and_fire() -> Self {
        Self { kind: NeuronKind::If, tau_mem_us: f64::INFINITY, ..Self::lif(1.0) }
    }

    pub fn with_reset(mut self, reset: Reset) -> Self {
        self.reset = reset;
        self
    }

    pub fn with_v_th(mut self, v_th: f32) -> Self {
        self.v_th = v_th;
        self
    }

    /// The per-step parameters for a step of `dt_us`.
    pub fn discretise(&self, dt_us: f64, how: Discretisation) -> NeuronParams {
        let factor = |tau: f64| match (self.kind, how) {
            (NeuronKind::If, _) => 1.0,
            (_, Discretisation::Exact) => (-dt_us / tau).exp(),
            (_, Discretisation::Euler) => 1.0 - dt_us / tau,
        };
        NeuronParams {
            kind: self.kind,
            alpha: if self.kind == NeuronKind::CubaLif { factor(self.tau_syn_us) as f32 } else { 0.0 },
            beta: factor(self.tau_mem_us) as f32,
            v_th: self.v_th,
            v_reset: self.v_reset,
            v_leak: self.v_leak,
            reset: self.reset,
        }
    }
}

/// A neuron per time step: what the engines run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NeuronParams {
    pub kind: NeuronKind,
    /// Synaptic current decay per step (CubaLIF).
    pub alpha: f32,
    /// Membrane decay per step (1 for IF).
    pub beta: f32,
    pub v_th: f32,
    pub v_reset: f32,
    pub v_leak: f32,
    pub reset: Reset,
}

impl NeuronParams {
    /// The snnTorch-style LIF: `v <- beta v + u`, threshold 1, reset to zero.
    pub fn lif(beta: f32) -> Self {
        Self { kind: NeuronKind::Lif, alpha: 0.0, beta, v_th: 1.0, v_reset: 0.0, v_leak: 0.0, reset: Reset::Zero }
    }

    pub fn cuba_lif(alpha: f32, beta: f32) -> Self {
        Self { kind: NeuronKind::CubaLif, alpha, ..Self::lif(beta) }
    }

    pub fn integrate_and_fire() -> Self {
        Self { kind: NeuronKind::If, beta: 1.0, ..Self::lif(1.0) }
    }

    pub fn with_reset(mut self, reset: Reset) -> Self {
        self.reset = reset;
        self
    }

    /// The level above which the membrane fires: `v_th`, or infinity for a leaky integrator.
    #[inline]
    pub fn threshold(&self) -> f32 {
        if self.kind == NeuronKind::Li { f32::INFINITY } else { self.v_th }
    }

    /// A leaky integrator (never fires) with decay `beta`.
    pub fn leaky_integrator(beta: f32) -> Self {
        Self { kind: NeuronKind::Li, ..Self::lif(beta) }
    }

    /// `(1 - beta) * v_leak`, the constant pull towards the resting level per step.
    #[inline]
    pub fn leak_term(&self) -> f32 {
        (1.0 - self.beta) * self.v_leak
    }

    /// One step of one neuron: updates `(i, v)` with input `u`, returns whether it spiked.
    #[inline]
    pub fn step(&self, i: &mut f32, v: &mut f32, u: f32) -> bool {
        let drive = match self.kind {
            NeuronKind::CubaLif => {
                *i = self.alpha * *i + u;
                *i
            }
            _ => u,
        };
        *v = self.beta * *v + self.leak_term() + drive;
        let spike = *v > self.threshold();
        if spike {
            *v = match self.reset {
                Reset::Zero => self.v_reset,
                Reset::Subtract => *v - self.v_th,
            };
        }
        spike
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_lif_trajectory() {
        // beta 0.9, threshold 1, reset to zero; input 0.5 at steps 0, 1, 2 and nothing after.
        // v: 0.5, 0.95, 1.355 -> spike, reset 0; then 0, 0.
        let p = NeuronParams::lif(0.9);
        let (mut i, mut v) = (0.0, 0.0);
        let mut trace = Vec::new();
        for u in [0.5, 0.5, 0.5, 0.0, 0.0] {
            let z = p.step(&mut i, &mut v, u);
            trace.push((v, z));
        }
        assert_eq!(trace, vec![(0.5, false), (0.95, false), (0.0, true), (0.0, false), (0.0, false)]);
        // with subtraction the excess stays: 1.355 - 1 = 0.355, then 0.3195
        let p = p.with_reset(Reset::Subtract);
        let (mut i, mut v) = (0.0, 0.0);
        for u in [0.5, 0.5, 0.5] {
            p.step(&mut i, &mut v, u);
        }
        assert!((v - 0.355).abs() < 1e-6);
        p.step(&mut i, &mut v, 0.0);
        assert!((v - 0.3195).abs() < 1e-6);
    }

    #[test]
    fn cuba_lif_uses_the_new_current() {
        // alpha 0.5, beta 0.8: i = 1, v = 1 (no spike at threshold 1: strictly greater);
        // i = 0.5, v = 0.8 + 0.5 = 1.3 -> spike
        let p = NeuronParams::cuba_lif(0.5, 0.8);
        let (mut i, mut v) = (0.0f32, 0.0f32);
        assert!(!p.step(&mut i, &mut v, 1.0));
        assert_eq!((i, v), (1.0, 1.0));
        assert!(p.step(&mut i, &mut v, 0.0));
        assert_eq!(i, 0.5);
    }

    #[test]
    fn exact_discretisation_composes_over_halved_steps() {
        let c = LifConfig::lif(10_000.0);
        let full = c.discretise(1_000.0, Discretisation::Exact).beta as f64;
        let half = c.discretise(500.0, Discretisation::Exact).beta as f64;
        assert!((half * half - full).abs() < 1e-7);
        let euler = c.discretise(1_000.0, Discretisation::Euler).beta;
        assert!((euler - 0.9).abs() < 1e-7);
    }

    #[test]
    fn surrogates_peak_at_threshold() {
        for s in [
            Surrogate::FastSigmoid { slope: 25.0 },
            Surrogate::Arctan { alpha: 2.0 },
            Surrogate::Triangle { width: 1.0 },
        ] {
            assert!(s.derivative(0.0) > s.derivative(0.5));
            assert!(s.derivative(0.3) == s.derivative(-0.3));
        }
    }
}
