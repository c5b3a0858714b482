//! One sample's forward pass: each layer's events fanned out into its currents, the membranes
//! stepped densely, and what the backward pass needs kept on the tape.

use super::*;

impl SparseSnn {
    /// One sample forward (internal input layout, [`Self::input_events`]); with `tape`, what
    /// the backward pass needs is kept.
    pub fn forward(&self, params: &Params, input: &StepEvents, masks: &[Option<Vec<f32>>], tape: bool) -> SampleOutput {
        self.forward_into(params, input, masks, tape, Vec::new())
    }

    /// [`Self::forward`] into the buffers of `spare`, a previous sample's tape.
    pub(super) fn forward_into(
        &self,
        params: &Params,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        tape: bool,
        spare: Vec<LayerTape>,
    ) -> SampleOutput {
        #[cfg(target_arch = "x86_64")]
        if snn::engine::avx2() {
            // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
            return unsafe { self.forward_avx2(params, input, masks, tape, spare) };
        }
        self.forward_with::<false>(params, input, masks, tape, spare)
    }

    /// [`Self::forward`] compiled for AVX2: the same operations (nothing fused or reordered), in
    /// wider registers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    pub(super) fn forward_avx2(
        &self,
        params: &Params,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        tape: bool,
        spare: Vec<LayerTape>,
    ) -> SampleOutput {
        self.forward_with::<true>(params, input, masks, tape, spare)
    }

    #[inline(always)]
    pub(super) fn forward_with<const AVX: bool>(
        &self,
        params: &Params,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        tape: bool,
        spare: Vec<LayerTape>,
    ) -> SampleOutput {
        let steps = input.steps();
        let last = self.plans.len() - 1;
        let mut spare = spare.into_iter();
        // exact: every neuron keeps its surrogate, stored densely (`LayerTape::surr_all`)
        let all = tape && self.x_cut == f32::INFINITY;
        let mut layers: Vec<LayerTape> = Vec::with_capacity(self.plans.len());
        let mut v_max = Vec::new();
        for (k, plan) in self.plans.iter().enumerate() {
            let x = if k == 0 { input } else { &layers[k - 1].out };
            let w = &params.layers[k];
            let n = plan.n_out;
            let mask = masks.get(k).and_then(Option::as_deref);
            let mut lt = spare.next().map_or_else(LayerTape::default, LayerTape::cleared);
            if all {
                lt.surr_all.reserve(steps * n);
            }
            let (mut u, mut v, mut cur) = (vec![0f32; n], vec![0f32; n], vec![0f32; n]);
            let (mut near_buf, mut dist) = (Vec::new(), Vec::new());
            let li = plan.neurons.is_some_and(|p| p.kind == NeuronKind::Li);
            if li {
                v_max = vec![f32::NEG_INFINITY; n];
                lt.argmax = vec![0; n];
            }
            // whether `u` is all zeros already (the spiking layers' update empties it with AVX2)
            let mut emptied = true;
            for t in 0..steps {
                if plan.bias_len > 0 {
                    for (o, u) in u.iter_mut().enumerate() {
                        *u = w.bias[o % plan.bias_len];
                    }
                } else if !emptied {
                    u.fill(0.0);
                }
                emptied = false;
                let (xi, xv) = x.at(t);
                for (&i, &xv) in xi.iter().zip(xv) {
                    scatter(plan, &w.weight, i as usize, xv, &mut u);
                }
                if plan.recurrent && t > 0 {
                    let (ji, jv) = lt.spikes.at(t - 1);
                    for (&j, &s) in ji.iter().zip(jv) {
                        axpy(&mut u, &w.recurrent[j as usize * n..][..n], s);
                    }
                }
                match plan.neurons {
                    None => {
                        for (o, &u) in u.iter().enumerate() {
                            if u != 0.0 {
                                lt.out.push(o as u32, u);
                            }
                        }
                    }
                    Some(np) if li => {
                        let leak = np.leak_term();
                        for o in 0..n {
                            let vp = v[o] * np.beta + leak + u[o];
                            v[o] = vp;
                            if vp > v_max[o] {
                                v_max[o] = vp;
                                lt.argmax[o] = t as u32;
                            }
                            if k < last && vp != 0.0 {
                                lt.out.push(o as u32, vp);
                            }
                        }
                    }
                    Some(np) => {
                        // dense and branch-free first (it vectorises), then the few near threshold
                        let leak = np.leak_term();
                        if np.kind == NeuronKind::CubaLif {
                            for (c, u) in cur.iter_mut().zip(u.iter_mut()) {
                                *c = *c * np.alpha + *u;
                                *u = *c;
                            }
                        }
                        // the membranes updated and those above `low` listed (with AVX2 in one
                        // pass, which also empties `u`); exact: every neuron's derivative,
                        // densely (it vectorises); else those of the neurons near threshold, below
                        let low = if tape && !all { np.v_th - self.x_cut } else { np.v_th };
                        let found = update_above::<AVX>(&mut v, &mut u, np.beta, leak, low, &mut near_buf);
                        emptied = AVX;
                        if all {
                            let start = lt.surr_all.len();
                            lt.surr_all.extend(v.iter().map(|&v| v - np.v_th));
                            derivatives_in_place(self.surrogate, &mut lt.surr_all[start..]);
                        }
                        let near = &near_buf[..found];
                        // their distances to threshold
                        dist.clear();
                        dist.extend(near.iter().map(|&o| v[o as usize] - np.v_th));
                        // those within the truncation keep a surrogate, listed without a branch,
                        // their derivatives then taken all at once (it vectorises)
                        if tape && !all {
                            let kept = lt.surr.idx.len();
                            let within = Keep::Within(self.x_cut);
                            pick::<AVX>(within, near, &dist, &mut lt.surr.idx, Some(&mut lt.surr.val));
                            derivatives_in_place(self.surrogate, &mut lt.surr.val[kept..]);
                        }
                        // the spiking neurons among them, also listed without a branch
                        let fired = lt.spikes.idx.len();
                        pick::<AVX>(Keep::Fired, near, &dist, &mut lt.spikes.idx, None);
                        lt.spikes.val.resize(lt.spikes.idx.len(), 1.0);
                        if mask.is_none() {
                            // what the next layer receives: the spikes themselves
                            lt.out.idx.extend_from_slice(&lt.spikes.idx[fired..]);
                            lt.out.val.resize(lt.out.idx.len(), 1.0);
                        }
                        for &o in &lt.spikes.idx[fired..] {
                            let o = o as usize;
                            if let Some(m) = mask
                                && m[o] != 0.0
                            {
                                lt.out.push(o as u32, m[o]);
                            }
                            let v = &mut v[o];
                            *v = match np.reset {
                                Reset::Subtract => *v - np.v_th,
                                Reset::Zero => np.v_reset,
                            };
                        }
                    }
                }
                lt.out.end_step();
                lt.spikes.end_step();
                lt.surr.end_step();
            }
            lt.n_spikes = lt.spikes.len();
            layers.push(lt);
        }
        self.output(layers, v_max, steps, tape, false)
    }

    /// The forward pass's result from its layers' tapes and the readout's highest membranes.
    pub(super) fn output(
        &self,
        layers: Vec<LayerTape>,
        v_max: Vec<f32>,
        steps: usize,
        tape: bool,
        delayed: bool,
    ) -> SampleOutput {
        let last = self.plans.len() - 1;
        let out = &self.plans[last];
        let mut counts = vec![0f32; out.n_out];
        let (oi, ov) = (&layers[last].spikes.idx, &layers[last].spikes.val);
        for (&o, &s) in oi.iter().zip(ov) {
            counts[o as usize] += s;
        }
        let logits = (0..out.n_out)
            .map(|c| {
                let o = out.output.internal(c);
                match self.readout {
                    Readout::SpikeCount => counts[o],
                    Readout::MaxMembrane if steps == 0 => 0.0,
                    Readout::MaxMembrane => v_max[o].max(0.0),
                }
            })
            .collect();
        let spikes = self
            .plans
            .iter()
            .zip(&layers)
            .filter(|(p, _)| p.neurons.is_some_and(|n| n.kind != NeuronKind::Li))
            .map(|(_, l)| l.n_spikes)
            .collect();
        SampleOutput { logits, spikes, tape: if tape { layers } else { Vec::new() }, v_max, delayed }
    }
}
