//! The ResNet as a burn module: built from its configuration, trained, evaluated, and its
//! tensors written and read by their names (the model file's).

use crate::error::{Error, Result};
use burn::module::Module;
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig, MaxPool2d, MaxPool2dConfig};
use burn::nn::{BatchNorm, BatchNormConfig, Dropout, DropoutConfig, Linear, LinearConfig, PaddingConfig2d};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};

use super::{ImageSet, ResnetConfig};

impl ResnetConfig {
    pub fn init(&self, device: &Device) -> Resnet {
        let conv = |i: usize, o: usize, k: usize, s: usize, p: usize| {
            Conv2dConfig::new([i, o], [k, k])
                .with_stride([s, s])
                .with_padding(PaddingConfig2d::Explicit(p, p, p, p))
                .with_bias(false)
                .init(device)
        };
        let mut blocks = Vec::new();
        let mut c = self.stem_channels;
        for (k, &(out, n)) in self.stages.iter().enumerate() {
            for b in 0..n {
                let stride = if k > 0 && b == 0 { 2 } else { 1 };
                let down = (stride != 1 || c != out)
                    .then(|| (conv(c, out, 1, stride, 0), BatchNormConfig::new(out).init(device)));
                blocks.push(BasicBlock {
                    conv1: conv(c, out, 3, stride, 1),
                    bn1: BatchNormConfig::new(out).init(device),
                    conv2: conv(out, out, 3, 1, 1),
                    bn2: BatchNormConfig::new(out).init(device),
                    down_conv: down.as_ref().map(|d| d.0.clone()),
                    down_bn: down.map(|d| d.1),
                });
                c = out;
            }
        }
        let mut fc = Vec::new();
        let mut n = c;
        for &h in &self.hidden {
            fc.push(LinearConfig::new(n, h).init(device));
            n = h;
        }
        fc.push(LinearConfig::new(n, self.classes).init(device));
        Resnet {
            stem: conv(self.input[0], self.stem_channels, 7, 2, 3),
            stem_bn: BatchNormConfig::new(self.stem_channels).init(device),
            pool: MaxPool2dConfig::new([3, 3])
                .with_strides([2, 2])
                .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                .init(),
            blocks,
            avg: AdaptiveAvgPool2dConfig::new([1, 1]).init(),
            fc,
            dropout: DropoutConfig::new(self.dropout).init(),
        }
    }
}

#[derive(Module, Debug)]
pub struct BasicBlock {
    conv1: Conv2d,
    bn1: BatchNorm,
    conv2: Conv2d,
    bn2: BatchNorm,
    down_conv: Option<Conv2d>,
    down_bn: Option<BatchNorm>,
}

impl BasicBlock {
    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let y = relu(self.bn1.forward(self.conv1.forward(x.clone())));
        let y = self.bn2.forward(self.conv2.forward(y));
        let skip = match (&self.down_conv, &self.down_bn) {
            (Some(c), Some(b)) => b.forward(c.forward(x)),
            _ => x,
        };
        relu(y + skip)
    }
}

#[derive(Module, Debug)]
pub struct Resnet {
    stem: Conv2d,
    stem_bn: BatchNorm,
    pool: MaxPool2d,
    blocks: Vec<BasicBlock>,
    avg: AdaptiveAvgPool2d,
    fc: Vec<Linear>,
    dropout: Dropout,
}

impl Resnet {
    /// Logits `[batch, classes]` of input `[batch, channels, height, width]`.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        let mut x = self.pool.forward(relu(self.stem_bn.forward(self.stem.forward(x))));
        for b in &self.blocks {
            x = b.forward(x);
        }
        let [n, c, _, _] = x.dims();
        let mut h: Tensor<2> = self.avg.forward(x).reshape([n, c]);
        let last = self.fc.len() - 1;
        for (k, l) in self.fc.iter().enumerate() {
            h = l.forward(h);
            if k < last {
                h = self.dropout.forward(relu(h));
            }
        }
        h
    }
}

fn batch(set: &ImageSet, idx: &[usize], device: &Device, mut map: impl FnMut(&[f32]) -> Vec<f32>) -> Tensor<4> {
    let [c, h, w] = set.shape;
    let mut flat = Vec::with_capacity(idx.len() * c * h * w);
    for &i in idx {
        flat.extend(map(&set.data[i]));
    }
    Tensor::<4>::from_data(burn::tensor::TensorData::new(flat, [idx.len(), c, h, w]), device)
}

/// burn's logits of each image (`[channels, height, width]` of `shape`, prepared as the model was
/// trained), in one batch: the reference for [`super::folded::FoldedResnet`], which the reader runs.
pub fn logits(model: &Resnet, shape: [usize; 3], images: &[&[f32]]) -> Vec<Vec<f32>> {
    let [c, h, w] = shape;
    let flat: Vec<f32> = images.iter().flat_map(|im| im.iter().copied()).collect();
    let x = Tensor::<4>::from_data(burn::tensor::TensorData::new(flat, [images.len(), c, h, w]), &Device::flex());
    let v = model.forward(x).into_data().convert::<f32>().try_into_vec::<f32>().expect("f32 logits");
    v.chunks(v.len() / images.len().max(1)).map(<[f32]>::to_vec).collect()
}

/// Loss, accuracy and the predictions of `model` (in evaluation mode) on `set`.
pub fn evaluate(model: &Resnet, set: &ImageSet, batch_size: usize) -> (f64, f64, Vec<usize>) {
    let device = Device::flex();
    let loss_fn = burn::nn::loss::CrossEntropyLossConfig::new().init(&device);
    let idx: Vec<usize> = (0..set.len()).collect();
    let (mut loss, mut preds) = (0.0, Vec::with_capacity(set.len()));
    for chunk in idx.chunks(batch_size.max(1)) {
        let logits = model.forward(batch(set, chunk, &device, <[f32]>::to_vec));
        let y: Vec<i64> = chunk.iter().map(|&i| set.labels[i] as i64).collect();
        let y = Tensor::<1, burn::tensor::Int>::from_data(burn::tensor::TensorData::new(y, [chunk.len()]), &device);
        preds.extend(crate::predicted_classes(&logits));
        loss += loss_fn.forward(logits, y).into_scalar::<f32>() as f64 * chunk.len() as f64;
    }
    let n = set.len().max(1) as f64;
    let hits = preds.iter().zip(&set.labels).filter(|(p, l)| p == l).count();
    (loss / n, hits as f64 / n, preds)
}

/// Trains a ResNet: Adam, seeded shuffling and initialisation (or the weights of `init`, a
/// trained model's tensors of the same `cfg`, to fine-tune it), `augment` applied to each
/// training image each time it is drawn, the best validation epoch kept (ties to the lower
/// validation loss).
pub fn train(
    cfg: &ResnetConfig,
    train_set: &ImageSet,
    val: &ImageSet,
    tc: &crate::train::TrainConfig,
    augment: &(dyn Fn(&[f32], &mut rand_chacha::ChaCha8Rng) -> Vec<f32> + Sync),
    init: Option<&[::snn::model_file::NamedTensor]>,
    observer: &mut dyn crate::train::Observer,
) -> Result<(Resnet, Vec<crate::train::EpochReport>)> {
    use burn::optim::{AdamConfig, GradientsParams};
    use rand::SeedableRng;
    crate::train::check_class_balance(tc.class_balance)?;
    let device = Device::flex().autodiff();
    device.seed(tc.seed);
    let mut model = cfg.init(&device);
    if let Some(tensors) = init {
        model = load_tensors(model, tensors)?;
    }
    let mut optim = AdamConfig::new().init();
    let loss_fn = burn::nn::loss::CrossEntropyLossConfig::new().init(&device);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(tc.seed);
    let mut order: Vec<usize> = (0..train_set.len()).collect();
    let mut turns = crate::train::ClassTurns::new(&train_set.labels, cfg.classes, tc.class_balance);
    let mut best: (Option<Resnet>, f64, f64) = (None, -1.0, f64::INFINITY);
    let mut history = Vec::new();
    for epoch in 1..=tc.epochs {
        let start = std::time::Instant::now();
        let lr = tc.lr_at(epoch);
        crate::train::epoch_order(&mut order, turns.as_mut(), &mut rng);
        let batches: Vec<&[usize]> = order.chunks(tc.batch_size.max(1)).collect();
        observer.epoch_begin(epoch, batches.len());
        let (mut loss_sum, mut hits) = (0.0, 0usize);
        for idx in batches {
            let x = batch(train_set, idx, &device, |img| augment(img, &mut rng));
            let logits = model.forward(x);
            let h = ::snn::scoring::hits(crate::predicted_classes(&logits), idx.iter().map(|&i| train_set.labels[i]));
            let y: Vec<i64> = idx.iter().map(|&i| train_set.labels[i] as i64).collect();
            let y = Tensor::<1, burn::tensor::Int>::from_data(burn::tensor::TensorData::new(y, [idx.len()]), &device);
            let loss = loss_fn.forward(logits, y);
            let l = loss.clone().into_scalar::<f32>() as f64;
            let grads = GradientsParams::from_grads(loss.backward(), &model);
            model = optim.step(lr, model, grads);
            loss_sum += l * idx.len() as f64;
            hits += h;
            observer.batch(l, h as f64 / idx.len() as f64);
        }
        let inference = model.valid();
        let (val_loss, val_accuracy, _) =
            if val.is_empty() { (f64::NAN, f64::NAN, Vec::new()) } else { evaluate(&inference, val, 32) };
        let report = crate::train::EpochReport::without_spikes(
            epoch,
            lr,
            (loss_sum, hits, train_set.len()),
            (val_loss, val_accuracy),
            start,
        );
        observer.epoch_end(&report);
        // the best validation accuracy, ties going to the lower validation loss (as the SNN
        // trainers choose; before 2026-11-29 the first of the tied epochs was kept); without a
        // validation set the last epoch
        let (score, loss) = if val.is_empty() { (epoch as f64, 0.0) } else { (val_accuracy, val_loss) };
        if score > best.1 || (score == best.1 && loss < best.2) {
            best = (Some(inference), score, loss);
        }
        history.push(report);
    }
    Ok((best.0.unwrap_or_else(|| model.valid()), history))
}

/// The model's tensors by their dotted field names (burn's safetensors naming).
pub fn to_tensors(model: &Resnet) -> Result<Vec<::snn::model_file::NamedTensor>> {
    use burn::store::{ModuleSnapshot, SafetensorsStore};
    let mut store = SafetensorsStore::from_bytes(None);
    model.save_into(&mut store).map_err(|e| Error::Store { step: "save", what: e.to_string() })?;
    let bytes = store.get_bytes().map_err(|e| Error::Store { step: "save", what: e.to_string() })?;
    let st = safetensors::SafeTensors::deserialize(&bytes)?;
    let mut out = Vec::new();
    for (name, view) in st.tensors() {
        if view.dtype() != safetensors::Dtype::F32 {
            return Err(Error::Tensors { tensor: Some(name), what: format!("{:?}, not F32", view.dtype()) });
        }
        let data = view.data().chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        out.push(::snn::model_file::NamedTensor { name, shape: view.shape().to_vec(), data });
    }
    out.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(out)
}

/// A model of `cfg` holding `tensors`; every tensor must be used and none missing.
pub fn from_tensors(cfg: &ResnetConfig, tensors: &[::snn::model_file::NamedTensor]) -> Result<Resnet> {
    Ok(load_tensors(cfg.init(&Device::flex()), tensors)?.valid())
}

/// `model` with its tensors replaced by `tensors` (on the model's device); every tensor must be
/// used and none missing.
pub fn load_tensors(mut model: Resnet, tensors: &[::snn::model_file::NamedTensor]) -> Result<Resnet> {
    use burn::store::{ModuleSnapshot, SafetensorsStore};
    let bytes: Vec<(String, Vec<u8>, Vec<usize>)> = tensors
        .iter()
        .map(|t| (t.name.clone(), t.data.iter().flat_map(|v| v.to_le_bytes()).collect(), t.shape.clone()))
        .collect();
    let views = bytes
        .iter()
        .map(|(n, b, s)| {
            safetensors::tensor::TensorView::new(safetensors::Dtype::F32, s.clone(), b).map(|v| (n.clone(), v))
        })
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let st = safetensors::serialize(views, None)?;
    let r = model
        .load_from(&mut SafetensorsStore::from_bytes(Some(st)))
        .map_err(|e| Error::Tensors { tensor: None, what: format!("tensors do not fit the config: {e}") })?;
    if !r.errors.is_empty() || !r.missing.is_empty() || !r.unused.is_empty() {
        return Err(Error::Tensors {
            tensor: None,
            what: format!(
                "tensors do not fit the config: {} errors ({}), missing {:?}, unused {:?}",
                r.errors.len(),
                r.errors.first().map_or(String::new(), |e| format!("{e:?}")),
                r.missing.iter().map(|m| &m.0).collect::<Vec<_>>(),
                r.unused
            ),
        });
    }
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_and_one_step_of_learning() {
        use burn::nn::loss::CrossEntropyLossConfig;
        use burn::optim::{AdamConfig, GradientsParams};
        use burn::tensor::{Int, TensorData};
        let device = Device::flex().autodiff();
        device.seed(1);
        let cfg = ResnetConfig::lite([4, 24, 32], 3);
        let mut model = cfg.init(&device);
        // three classes: the mean level of the input
        let x: Vec<f32> = (0..6 * 4 * 24 * 32)
            .map(|i| ((i / (4 * 24 * 32)) % 3) as f32 * 0.5 + ((i * 7919) % 13) as f32 * 0.01)
            .collect();
        let x = Tensor::<4>::from_data(TensorData::new(x, [6, 4, 24, 32]), &device);
        let y = Tensor::<1, Int>::from_data(TensorData::new(vec![0i64, 1, 2, 0, 1, 2], [6]), &device);
        let loss_fn = CrossEntropyLossConfig::new().init(&device);
        let mut optim = AdamConfig::new().init();
        let mut losses = Vec::new();
        for _ in 0..8 {
            let logits = model.forward(x.clone());
            assert_eq!(logits.dims(), [6, 3]);
            let loss = loss_fn.forward(logits, y.clone());
            losses.push(loss.clone().into_scalar::<f32>());
            let grads = GradientsParams::from_grads(loss.backward(), &model);
            model = optim.step(1e-2, model, grads);
        }
        assert!(losses[7] < losses[0], "training must lower the loss: {losses:?}");
        // the tensors leave and come back exactly; another config refuses them
        let trained = model.valid();
        let tensors = to_tensors(&trained).unwrap();
        assert!(tensors.iter().any(|t| t.name.contains("running_var")), "batch-norm statistics are kept");
        let again = from_tensors(&cfg, &tensors).unwrap();
        let probe = Tensor::<4>::ones([1, 4, 24, 32], &Device::flex());
        let (a, b) = (trained.forward(probe.clone()).into_data(), again.forward(probe).into_data());
        assert_eq!(a, b);
        let other = ResnetConfig { stem_channels: 8, ..cfg.clone() };
        let e = from_tensors(&other, &tensors).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("do not fit"), "{e}");
        // the paper's configuration builds and runs too
        let paper = ResnetConfig::paper([4, 24, 32], 26).init(&Device::flex());
        let x = Tensor::<4>::zeros([1, 4, 24, 32], &Device::flex());
        assert_eq!(paper.valid().forward(x).dims(), [1, 26]);
    }
}
