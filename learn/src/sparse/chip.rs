//! Quantisation-aware training: the forward pass as a chip computes it, the backward pass the
//! float network's, straight through.
//!
//! Each training step maps the current float weights into the chip's formats exactly as
//! `braille eval --chip` maps a model file ([`snn::chip::xylo::map`]: decays to bit shifts,
//! Rockpool's 8-bit quantiser, the weight shift) and runs every sample there
//! ([`snn::chip::xylo::Xylo`], the arithmetic that agrees spike for spike with XyloSim): integer
//! weights, 16-bit saturating state, decays by shifts, several spikes per step with the threshold
//! subtracted once per spike, at most 15 input events per channel and step, hidden spikes passed
//! on one step later. The loss is taken on the chip's readout (its highest output membrane, or its
//! output spikes), in float units (a chip state over its neuron's [`StateScales`]).
//!
//! Backward, the float network's equations as [`super::SparseSnn::backward`] runs them, on what
//! the chip did: the spikes it sent (counts, not just 0 or 1), each layer's input one step late,
//! and a surrogate derivative at the chip's membrane before the reset, `sigma'(d / scale)` with
//! `d` the distance to the nearest threshold crossing (below the first, `v - th`; above it, to the
//! nearest multiple of `th`, since each further multiple is one spike more). Rounding, the
//! shifts' floor and the saturation pass their gradients straight through (taken as identities),
//! and the gradient reaches the float weights as if it were the quantised ones'. The float
//! network's decays should be the chip's (`1 - 2^-dash`), as the recipes that train for a chip
//! set them, so that the backward pass and the chip leak alike.

use super::{LayerTape, Params, SampleOutput, SparseSnn, StepEvents};
use serde::{Deserialize, Serialize};
use snn::chip::Chip;
use snn::chip::xylo::{self, Quantisation, Run, StateScales, Xylo};
use snn::model_file::Readout;

/// What quantisation-aware training trains for: a chip and its quantiser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ChipTarget {
    pub chip: Chip,
    pub quantisation: Quantisation,
}

/// A network mapped into a chip for one training step (shared by the batch's samples).
#[derive(Debug, Clone)]
pub struct ChipForward {
    xylo: Xylo,
    scales: StateScales,
}

impl ChipForward {
    pub fn xylo(&self) -> &Xylo {
        &self.xylo
    }
}

impl SparseSnn {
    /// `params` mapped to `target` as a model file with these weights would be mapped (an error
    /// says why a network cannot be: a convolution, a bias, IF neurons...).
    pub fn chip_forward(&self, params: &Params, target: ChipTarget) -> snn::Result<ChipForward> {
        if target.chip != Chip::Xylo {
            return Err(snn::Error::Chip {
                chip: target.chip,
                layer: None,
                what: "quantisation-aware training runs Xylo's arithmetic only (docs/chips.md)".into(),
            });
        }
        let net = self.spec.build(self.weights(params)?)?;
        let mut mapped = xylo::map(&net, target.quantisation)?;
        mapped.spec.readout = self.readout.into();
        Ok(ChipForward { xylo: mapped.spec.compile()?, scales: mapped.scales })
    }

    /// One sample forward on the chip (internal input layout, which is the engine's for the
    /// dense networks a chip takes); with `tape`, what the backward pass needs.
    pub fn forward_on_chip(&self, chip: &ChipForward, input: &StepEvents, tape: bool) -> snn::Result<SampleOutput> {
        let spec = chip.xylo.spec();
        let last = self.plans.len() - 1;
        if spec.hidden_layers.len() != last || spec.n_out != self.plans[last].n_out {
            return Err(snn::Error::network("the chip's mapping does not have the trainer's layers"));
        }
        let steps = input.steps();
        let mut layers: Vec<LayerTape> = (0..=last).map(|_| LayerTape::default()).collect();
        let mut v_max = vec![f32::NEG_INFINITY; spec.n_out];
        layers[last].argmax = vec![0; spec.n_out];
        let mut st = chip.xylo.state();
        let (mut channels, mut events) = (Vec::<u32>::new(), Vec::<u16>::new());
        for t in 0..steps {
            // indices ascending; a repeated index adds up, as in the float forward
            let (xi, xv) = input.at(t);
            channels.clear();
            events.clear();
            for (&i, &v) in xi.iter().zip(xv) {
                let n = v.round().clamp(0.0, u16::MAX as f32) as u16;
                if n == 0 {
                    continue;
                }
                match channels.last() {
                    Some(&c) if c == i => {
                        let e = events.last_mut().expect("an event per channel");
                        *e = e.saturating_add(n);
                    }
                    _ => {
                        channels.push(i);
                        events.push(n);
                    }
                }
            }
            chip.xylo.step(&mut st, &channels, &events, Run::EventDriven)?;
            for (k, &(start, n)) in spec.hidden_layers.iter().enumerate() {
                let lt = &mut layers[k];
                for o in 0..n {
                    let j = start + o;
                    let s = st.spikes[j];
                    if s > 0 {
                        lt.spikes.push(o as u32, s as f32);
                        lt.out.push(o as u32, s as f32);
                    }
                    if tape {
                        let d = crossing_distance(st.v_mem[j], s, spec.threshold[j]) / chip.scales.hidden[j];
                        if d.abs() < self.x_cut {
                            lt.surr.push(o as u32, self.surrogate.derivative(d));
                        }
                    }
                }
            }
            let lt = &mut layers[last];
            match self.readout {
                Readout::MaxMembrane => {
                    for (o, vm) in v_max.iter_mut().enumerate() {
                        let v = st.v_mem_out[o] as f32 / chip.scales.out[o];
                        if v > *vm {
                            *vm = v;
                            lt.argmax[o] = t as u32;
                        }
                    }
                }
                Readout::SpikeCount => {
                    for (o, &s) in st.out_spikes.iter().enumerate() {
                        if s > 0 {
                            lt.spikes.push(o as u32, s as f32);
                        }
                        if tape {
                            let d = crossing_distance(st.v_mem_out[o], s, spec.threshold_out[o]) / chip.scales.out[o];
                            if d.abs() < self.x_cut {
                                lt.surr.push(o as u32, self.surrogate.derivative(d));
                            }
                        }
                    }
                }
            }
            for lt in &mut layers {
                lt.out.end_step();
                lt.spikes.end_step();
                lt.surr.end_step();
            }
        }
        for lt in &mut layers {
            lt.n_spikes = lt.spikes.val.iter().sum::<f32>() as usize;
        }
        Ok(self.output(layers, v_max, steps, tape, true))
    }

    /// Forward passes of `inputs` on `chip` in parallel (no tape): each one's logits and spikes
    /// per layer, as [`SparseSnn::infer`].
    pub fn infer_on_chip(
        &self,
        chip: &ChipForward,
        inputs: &[&StepEvents],
    ) -> snn::Result<Vec<(Vec<f32>, Vec<usize>)>> {
        use rayon::prelude::*;
        inputs.par_iter().map(|x| self.forward_on_chip(chip, x, false).map(|o| (o.logits, o.spikes))).collect()
    }

    /// The gradient of the mean cross-entropy over a batch, the forward pass on `chip`.
    pub fn chip_batch_gradient(
        &self,
        params: &Params,
        chip: &ChipForward,
        samples: &[(&StepEvents, usize)],
    ) -> snn::Result<super::BatchGradient> {
        self.gradient_with(
            params,
            samples,
            &[],
            |x, _, _| self.forward_on_chip(chip, x, true),
            |_, logits, label| super::cross_entropy(logits, label),
        )
    }
}

/// In chip units, a neuron's membrane before this step's `spikes` were subtracted, less the
/// nearest threshold crossing: below the first, `v - th` (negative); from there on the distance
/// to the nearest multiple of `th` (each one spike more), negative below it.
fn crossing_distance(v_after: i16, spikes: u8, threshold: i16) -> f32 {
    let th = threshold as f32;
    let v = v_after as f32 + spikes as f32 * th;
    if spikes == 0 {
        return v - th;
    }
    // the residue after the spikes, in [0, th) unless the spike cap bound
    let r = v - spikes as f32 * th;
    if r > th / 2.0 { r - th } else { r }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use snn::neuron::{NeuronParams, Reset, Surrogate};
    use snn::spec::{LayerSpec, NetworkSpec, OpSpec};

    fn xylo_net() -> (SparseSnn, Params) {
        let dash = |d: u8| xylo::decay_of(d);
        let hidden = NeuronParams::cuba_lif(dash(3), dash(4)).with_reset(Reset::Subtract);
        let spec = NetworkSpec {
            input_shape: vec![6],
            layers: vec![
                LayerSpec {
                    op: OpSpec::Dense { n_out: 20 },
                    neurons: Some(hidden),
                    recurrent: true,
                    bias: false,
                    recurrent_bias: false,
                },
                LayerSpec {
                    op: OpSpec::Dense { n_out: 3 },
                    neurons: Some(NeuronParams::leaky_integrator(dash(3))),
                    recurrent: false,
                    bias: false,
                    recurrent_bias: false,
                },
            ],
        };
        let w = spec.init_with_recurrent_gain(7, 3.0, 0.5).unwrap();
        let net = SparseSnn::new(spec, Surrogate::FastSigmoid { slope: 10.0 }, Readout::MaxMembrane, 0.0).unwrap();
        let p = net.params(&w).unwrap();
        (net, p)
    }

    fn input(seed: u64, steps: usize) -> StepEvents {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut e: Vec<(u32, u32, f32)> = (0..steps * 3)
            .map(|_| (rng.random_range(0..steps as u32), rng.random_range(0..6), rng.random_range(1..20) as f32))
            .collect();
        StepEvents::from_entries(steps, &mut e)
    }

    #[test]
    fn the_chip_forward_reads_out_what_the_chip_reads_out() {
        let (net, p) = xylo_net();
        let target = ChipTarget { chip: Chip::Xylo, quantisation: Quantisation::Global };
        let chip = net.chip_forward(&p, target).unwrap();
        for seed in 0..5 {
            let x = input(seed, 40);
            let out = net.forward_on_chip(&chip, &x, true).unwrap();
            // the chip itself, fed the same counts (repeats merged, capped by the chip)
            let mut steps = Vec::new();
            for t in 0..x.steps() {
                let (xi, xv) = x.at(t);
                let mut c: Vec<(u32, u16)> = Vec::new();
                for (&i, &v) in xi.iter().zip(xv) {
                    match c.last_mut() {
                        Some((j, n)) if *j == i => *n += v as u16,
                        _ => c.push((i, v as u16)),
                    }
                }
                steps.push(c);
            }
            let split: Vec<(Vec<u32>, Vec<u16>)> =
                steps.iter().map(|c| (c.iter().map(|e| e.0).collect(), c.iter().map(|e| e.1).collect())).collect();
            let (readout, stats) =
                chip.xylo.run_sample(split.iter().map(|(c, e)| (c.as_slice(), e.as_slice())), Run::Stepped).unwrap();
            for (o, r) in readout.iter().enumerate() {
                assert_eq!((out.logits[o] * chip.scales.out[o]).round(), *r, "seed {seed} output {o}");
            }
            assert_eq!(out.spikes[0] as u64, stats.hidden_spikes, "seed {seed}");
            assert!(stats.hidden_spikes > 0, "the test network spikes");
            // several spikes a step somewhere, so that counts are exercised
            assert!(out.tape[0].spikes.val.iter().any(|&s| s > 1.0) || seed > 0);
        }
    }

    /// As `gradients_read_nothing_left_in_the_kept_buffers` (the float forward's), on the chip's
    /// forward pass, whose layers take the output of the layer below one step late: the same
    /// gradient to the bit with every entry of the kept buffers made NaN before it.
    #[test]
    fn chip_gradients_read_nothing_left_in_the_kept_buffers() {
        let (net, p) = xylo_net();
        let target = ChipTarget { chip: Chip::Xylo, quantisation: Quantisation::Global };
        let chip = net.chip_forward(&p, target).unwrap();
        let xs: Vec<StepEvents> = (0..6).map(|s| input(200 + s, 40)).collect();
        let samples: Vec<(&StepEvents, usize)> = xs.iter().enumerate().map(|(j, x)| (x, j % 3)).collect();
        let bits =
            |g: &super::super::BatchGradient| g.grads.tensors().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        let first = net.chip_batch_gradient(&p, &chip, &samples).unwrap();
        assert!(first.grads.tensors().flatten().any(|g| *g != 0.0));
        assert!(net.poison_buffers() > 0, "buffers kept");
        let second = net.chip_batch_gradient(&p, &chip, &samples).unwrap();
        assert_eq!(bits(&first), bits(&second));
    }

    #[test]
    fn quantisation_aware_gradients_lower_the_chips_loss() {
        // a small step against the straight-through gradient lowers the loss the chip gives
        let (net, mut p) = xylo_net();
        let target = ChipTarget { chip: Chip::Xylo, quantisation: Quantisation::Global };
        let xs: Vec<StepEvents> = (0..16).map(|s| input(100 + s, 40)).collect();
        let samples: Vec<(&StepEvents, usize)> = xs.iter().enumerate().map(|(j, x)| (x, j % 3)).collect();
        let loss = |p: &Params| {
            let chip = net.chip_forward(p, target).unwrap();
            net.chip_batch_gradient(p, &chip, &samples).unwrap()
        };
        let first = loss(&p);
        assert!(first.grads.tensors().flatten().any(|g| *g != 0.0));
        let mut adam = super::super::Adam::new(&p, 0.0, 0.0);
        let mut last = first.loss_sum;
        for _ in 0..30 {
            let g = loss(&p);
            last = g.loss_sum;
            adam.step(&mut p, &g.grads, 0.01);
        }
        assert!(last < 0.8 * first.loss_sum, "chip loss {} -> {last}", first.loss_sum);
    }

    #[test]
    fn crossing_distances() {
        assert_eq!(crossing_distance(90, 0, 100), -10.0);
        // 250 before the reset: two spikes, 50 left, as far from 200 as from 300
        assert_eq!(crossing_distance(50, 2, 100), 50.0);
        assert_eq!(crossing_distance(10, 1, 100), 10.0);
        assert_eq!(crossing_distance(90, 1, 100), -10.0);
    }
}
