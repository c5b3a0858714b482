//! One sample's backward pass through time, layer by layer from the top (the equations in the
//! module's documentation).

use super::*;

impl SparseSnn {
    /// One sample backward: adds the gradient of the loss, given `g_logits` (its gradient by the
    /// logits, in class order), into `grads`.
    pub fn backward(
        &self,
        params: &Params,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        out: &SampleOutput,
        g_logits: &[f32],
        grads: &mut Params,
    ) {
        let by_input = self.weights_by_input(params);
        let mut work = Workspace { params, by_input: &by_input, pool: &mut Vec::new() };
        self.backward_by(&mut work, input, masks, out, g_logits, grads)
    }

    /// Each layer's weights laid out for gathering the gradient of all its inputs at once (none
    /// for the first layer): made once per batch.
    pub(super) fn weights_by_input(&self, params: &Params) -> Vec<Option<ByInput>> {
        self.plans
            .iter()
            .zip(&params.layers)
            .enumerate()
            .map(|(k, (plan, w))| if k == 0 { None } else { weights_by_input(plan, &w.weight) })
            .collect()
    }

    /// [`Self::backward`] in a worker's [`Workspace`].
    pub(super) fn backward_by(
        &self,
        work: &mut Workspace,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        out: &SampleOutput,
        g_logits: &[f32],
        grads: &mut Params,
    ) {
        #[cfg(target_arch = "x86_64")]
        if snn::engine::avx2() {
            // SAFETY: this CPU has AVX2, popcnt and BMI1 (just checked).
            return unsafe { self.backward_avx2(work, input, masks, out, g_logits, grads) };
        }
        self.backward_with(work, input, masks, out, g_logits, grads)
    }

    /// [`Self::backward`] compiled for AVX2 (the same operations, as [`Self::forward_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,popcnt")]
    pub(super) fn backward_avx2(
        &self,
        work: &mut Workspace,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        out: &SampleOutput,
        g_logits: &[f32],
        grads: &mut Params,
    ) {
        self.backward_with(work, input, masks, out, g_logits, grads)
    }

    #[inline(always)]
    pub(super) fn backward_with(
        &self,
        work: &mut Workspace,
        input: &StepEvents,
        masks: &[Option<Vec<f32>>],
        out: &SampleOutput,
        g_logits: &[f32],
        grads: &mut Params,
    ) {
        let steps = input.steps();
        let last = self.plans.len() - 1;
        let tape = &out.tape;
        assert_eq!(tape.len(), self.plans.len(), "backward needs a forward pass with its tape");
        let top = &self.plans[last];
        // the readout's gradient by internal index
        let mut g_read = vec![0f32; top.n_out];
        for (c, &g) in g_logits.iter().enumerate() {
            let o = top.output.internal(c);
            let clamped = self.readout == Readout::MaxMembrane && self.clamped_readout_gradient && out.v_max[o] < 0.0;
            g_read[o] = if clamped { 0.0 } else { g };
        }
        // (pool buffers: as many taken as given back)
        let (params, pool) = (work.params, &mut *work.pool);
        let mut g_out = pool.pop().unwrap_or_default();
        g_out.clear();
        match self.readout {
            Readout::SpikeCount => (0..steps).for_each(|_| g_out.extend_from_slice(&g_read)),
            Readout::MaxMembrane => g_out.resize(steps * top.n_out, 0.0),
        }
        for k in (0..=last).rev() {
            let plan = &self.plans[k];
            let (w, gw, lt) = (&params.layers[k], &mut grads.layers[k], &tape[k]);
            let x = if k == 0 { input } else { &tape[k - 1].out };
            // the step of the layer below whose output this layer takes at step t
            let delay = usize::from(out.delayed && k > 0);
            let n = plan.n_out;
            let mask = masks.get(k).and_then(Option::as_deref);
            let below = k.checked_sub(1).map(|b| (&self.plans[b], &tape[b]));
            let nb = below.map_or(0, |(b, _)| b.n_out);
            // The layer below reads at each step only what is written into this buffer at that
            // step below: the gradient of its inputs that keep a surrogate (it reads only theirs),
            // or of all of them. So the buffer is not zeroed (zeroing a sample's worth was a
            // few percent of a step), but for the last `delay` steps, which no step writes.
            let mut g_below = pool.pop().unwrap_or_default();
            g_below.resize(steps * nb, 0.0);
            g_below[steps.saturating_sub(delay) * nb..].fill(0.0);
            // the weights laid out by input, for the steps where every input keeps a surrogate
            // (the exact gradient): eight inputs gathered at once
            let by_input = work.by_input[k].as_ref();
            let (mut g_u, mut carry_v, mut carry_i, mut g_rec) =
                (vec![0f32; n], vec![0f32; n], vec![0f32; n], vec![0f32; n]);
            for t in (0..steps).rev() {
                let go = &g_out[t * n..][..n];
                match plan.neurons {
                    None => g_u.copy_from_slice(go),
                    Some(np) => {
                        if np.kind == NeuronKind::Li {
                            std::mem::swap(&mut g_u, &mut carry_v); // carry_v is rewritten below
                            if k == last {
                                for (o, g) in g_u.iter_mut().enumerate() {
                                    if lt.argmax[o] as usize == t {
                                        *g += g_read[o];
                                    }
                                }
                            } else {
                                g_u.iter_mut().zip(go).for_each(|(g, d)| *g += d);
                            }
                        } else {
                            if np.reset == Reset::Zero {
                                for &j in lt.spikes.at(t).0 {
                                    carry_v[j as usize] = 0.0;
                                }
                            }
                            std::mem::swap(&mut g_u, &mut carry_v); // carry_v is rewritten below
                            match lt.kept(t, n) {
                                Kept::All(sv) => match mask {
                                    None => surrogate_all(&mut g_u, sv, go, &g_rec),
                                    Some(m) => {
                                        for ((((g, &s), &go), &gr), &m) in
                                            g_u.iter_mut().zip(sv).zip(go).zip(&g_rec).zip(m)
                                        {
                                            *g += (go * m + gr) * s;
                                        }
                                    }
                                },
                                Kept::Listed(si, sv) => {
                                    for (&o, &s) in si.iter().zip(sv) {
                                        let o = o as usize;
                                        let gz = go[o] * mask.map_or(1.0, |m| m[o]) + g_rec[o];
                                        g_u[o] += gz * s;
                                    }
                                }
                            }
                        }
                        for (c, g) in carry_v.iter_mut().zip(&g_u) {
                            *c = np.beta * g;
                        }
                        if np.kind == NeuronKind::CubaLif {
                            for (g, c) in g_u.iter_mut().zip(carry_i.iter_mut()) {
                                *g += np.alpha * *c;
                                *c = *g;
                            }
                        }
                    }
                }
                if plan.bias_len > 0 {
                    for (o, g) in g_u.iter().enumerate() {
                        gw.bias[o % plan.bias_len] += g;
                    }
                }
                let src = t.checked_sub(delay);
                if let Some(ts) = src {
                    let (xi, xv) = x.at(ts);
                    for (&i, &xv) in xi.iter().zip(xv) {
                        weight_grad(plan, &mut gw.weight, i as usize, xv, &g_u);
                    }
                }
                if plan.recurrent {
                    g_rec.fill(0.0);
                    if t > 0 {
                        let (ji, jv) = lt.spikes.at(t - 1);
                        for (&j, &s) in ji.iter().zip(jv) {
                            axpy(&mut gw.recurrent[j as usize * n..][..n], &g_u, s);
                        }
                        match lt.kept(t - 1, n) {
                            Kept::All(_) => {
                                for (j, g) in g_rec.iter_mut().enumerate() {
                                    *g = dot(&w.recurrent[j * n..][..n], &g_u);
                                }
                            }
                            Kept::Listed(ji, _) => {
                                for &j in ji {
                                    g_rec[j as usize] = dot(&w.recurrent[j as usize * n..][..n], &g_u);
                                }
                            }
                        }
                    }
                }
                if let (Some((b, bt)), Some(ts)) = (below, src) {
                    let gb = &mut g_below[ts * nb..][..nb];
                    // the inputs whose gradient is needed: those keeping a surrogate, or all
                    let kept = match b.neurons {
                        Some(bn) if bn.kind != NeuronKind::Li => match bt.kept(ts, nb) {
                            Kept::Listed(kept, _) if kept.len() < nb => Some(kept),
                            _ => None,
                        },
                        _ => None,
                    };
                    match (kept, by_input) {
                        (None, Some(ByInput::Conv(wt))) => gather_all_conv(plan, wt, &g_u, gb),
                        (None, Some(ByInput::Dense(wt))) => gather_all_dense(wt, n, &g_u, gb),
                        (Some(kept), _) => {
                            for &i in kept {
                                gb[i as usize] = gather(plan, &w.weight, i as usize, &g_u);
                            }
                        }
                        (None, None) => {
                            for (i, g) in gb.iter_mut().enumerate() {
                                *g = gather(plan, &w.weight, i, &g_u);
                            }
                        }
                    }
                }
            }
            pool.push(std::mem::replace(&mut g_out, g_below));
        }
        pool.push(g_out);
    }
}
