//! A batch's gradient: samples in parallel, in fixed chunks summed in a fixed order; and forward
//! passes alone for inference.

use super::*;

impl SparseSnn {
    /// The gradient of the mean cross-entropy over a batch of `(input events, label)`, with a
    /// dropout mask set per sample (`masks[j]`, or none).
    pub fn batch_gradient(
        &self,
        params: &Params,
        samples: &[(&StepEvents, usize)],
        masks: &[Vec<Option<Vec<f32>>>],
    ) -> BatchGradient {
        self.float_gradient(params, samples, masks, |_, logits, label| cross_entropy(logits, label))
    }

    /// [`Self::batch_gradient`] of the distillation loss ([`distillation`]): sample `j` learns
    /// from its label and from `teacher[j]`, a trained network's logits on the same sample.
    ///
    /// # Panics
    /// When `teacher` and `samples` differ in length (a caller's bug:
    /// [`crate::train::train_distilled`] checks its teacher before training).
    pub fn distilled_gradient(
        &self,
        params: &Params,
        samples: &[(&StepEvents, usize)],
        masks: &[Vec<Option<Vec<f32>>>],
        teacher: &[&[f32]],
        d: Distill,
    ) -> BatchGradient {
        assert_eq!(teacher.len(), samples.len(), "a teacher's logits for each sample");
        self.float_gradient(params, samples, masks, |j, logits, label| distillation(logits, label, teacher[j], d))
    }

    /// The float network's gradient of `loss` (of sample `j`'s logits and label).
    pub(super) fn float_gradient(
        &self,
        params: &Params,
        samples: &[(&StepEvents, usize)],
        masks: &[Vec<Option<Vec<f32>>>],
        loss: impl Fn(usize, &[f32], usize) -> (f64, Vec<f32>, bool) + Sync,
    ) -> BatchGradient {
        let forward = |x: &StepEvents, m: &[Option<Vec<f32>>], spare: Vec<LayerTape>| {
            Ok(self.forward_into(params, x, m, true, spare))
        };
        let Ok(g) = self.gradient_with::<std::convert::Infallible>(params, samples, masks, forward, loss);
        g
    }

    /// [`Self::batch_gradient`] with the forward pass `forward` (taped): the float network's, or
    /// a chip's ([`chip`]); `loss` of sample `j` (its index in `samples`), its logits and label.
    pub(super) fn gradient_with<E: Send>(
        &self,
        params: &Params,
        samples: &[(&StepEvents, usize)],
        masks: &[Vec<Option<Vec<f32>>>],
        forward: impl Fn(&StepEvents, &[Option<Vec<f32>>], Vec<LayerTape>) -> Result<SampleOutput, E> + Sync,
        loss: impl Fn(usize, &[f32], usize) -> (f64, Vec<f32>, bool) + Sync,
    ) -> Result<BatchGradient, E> {
        let b = samples.len().max(1);
        let chunk = b.div_ceil(CHUNKS);
        let empty = || BatchGradient {
            grads: self.scratch.zeros_like(params),
            loss_sum: 0.0,
            hits: 0,
            spikes: Vec::new(),
            kept_surrogates: 0,
        };
        let by_input = self.weights_by_input(params);
        let parts: Vec<BatchGradient> = samples
            .par_chunks(chunk)
            .enumerate()
            // each worker's buffers (a tape, the backward's step-by-step gradients) reused from
            // sample to sample and batch to batch: results do not depend on them
            .map_init(
                || WorkerBuffers::take(&self.scratch),
                |buffers, (c, part)| {
                    let WorkerBuffers { tape: spare, pool, .. } = buffers;
                    let mut work = Workspace { params, by_input: &by_input, pool };
                    let mut acc = empty();
                    for (j, &(input, label)) in part.iter().enumerate() {
                        let m: &[Option<Vec<f32>>] = masks.get(c * chunk + j).map_or(&[], Vec::as_slice);
                        let out = forward(input, m, std::mem::take(spare))?;
                        let (loss, mut g, hit) = loss(c * chunk + j, &out.logits, label);
                        g.iter_mut().for_each(|g| *g /= b as f32);
                        self.backward_by(&mut work, input, m, &out, &g, &mut acc.grads);
                        acc.loss_sum += loss;
                        acc.kept_surrogates += out.tape.iter().map(LayerTape::n_kept).sum::<usize>();
                        acc.hits += hit as usize;
                        add_spikes(&mut acc.spikes, out.spikes.iter().map(|&s| s as f64));
                        *spare = out.tape;
                    }
                    Ok(acc)
                },
            )
            .collect::<Result<_, E>>()?;
        let mut parts = parts.into_iter();
        let mut total = parts.next().unwrap_or_else(empty);
        for p in parts {
            total.grads.add(&p.grads);
            total.loss_sum += p.loss_sum;
            total.hits += p.hits;
            total.kept_surrogates += p.kept_surrogates;
            add_spikes(&mut total.spikes, p.spikes.iter().copied());
            self.scratch.keep_grads(p.grads);
        }
        Ok(total)
    }

    /// Forward passes of `inputs` in parallel (no tape): each one's logits and spikes per layer.
    pub fn infer(&self, params: &Params, inputs: &[&StepEvents]) -> Vec<(Vec<f32>, Vec<usize>)> {
        inputs
            .par_iter()
            .map(|x| {
                let out = self.forward(params, x, &[], false);
                (out.logits, out.spikes)
            })
            .collect()
    }
}

pub(super) fn add_spikes(acc: &mut Vec<f64>, s: impl ExactSizeIterator<Item = f64>) {
    acc.resize(s.len().max(acc.len()), 0.0);
    acc.iter_mut().zip(s).for_each(|(a, s)| *a += s);
}
