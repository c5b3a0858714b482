//! Training an SNN from a recipe ([`crate::train::recipe::SnnRecipe`]): on a tactile dataset folder
//! (real recordings) or on the SIMULATED character windows. The best checkpoint (or the averaged
//! weights) leaves as a model file for the event-driven engine, its recipe in the provenance.

use crate::Progress;
use crate::error::{Error, Result};
use crate::eval::tactile::snn_accuracy;
use crate::train::recipe::{NeuronChoice, ReadoutGradient, SnnRecipe};
use corpus::windows::training_windows;
use encoders::dataset::{Dataset, Split};
use encoders::sigma_delta::SigmaDeltaConfig;
use learn::data::{SpikeSet, TactileEncoding};
use learn::snn::SnnTwin;
use learn::train::{EpochReport, Observer, Outcome, TrainConfig};
use pipeline::input::{CharInput, LITE_COLS};
use serde::Serialize;
use snn::engine::Mode;
use snn::model_file::{Readout, SnnConfig, SnnModel};
use snn::network::PoolKind;
use snn::neuron::{Discretisation, LifConfig, NeuronKind};
use snn::spec::{LayerSpec, NetworkSpec, OpSpec};
use std::path::Path;

/// The recipe's network for an input of `input_shape` (`[n]`, or `[polarity, row, column]` for
/// simulated windows, which convolutional layers need) and `n_classes` classes.
pub fn network_spec(r: &SnnRecipe, input_shape: &[usize], n_classes: usize) -> Result<NetworkSpec> {
    let dt = r.dt_us as f64;
    let hidden = match r.neuron {
        NeuronChoice::Lif => LifConfig::lif(r.tau_mem_us),
        NeuronChoice::CubaLif => LifConfig::cuba_lif(r.tau_mem_us, r.tau_syn_us),
        NeuronChoice::If => LifConfig::integrate_and_fire(),
    }
    .with_reset(r.reset)
    .discretise(dt, Discretisation::Exact);
    if (r.hidden.is_empty() && r.conv.is_empty()) || r.hidden.contains(&0) {
        return Err(Error::Setting {
            name: "hidden",
            value: format!("{:?}", r.hidden),
            expected: "positive layer sizes (or the recipe's convolutional layers)",
        });
    }
    if r.recurrent_init_gain.is_some() && !r.recurrent {
        return Err(Error::Setting {
            name: "--recurrent-init-gain",
            value: r.recurrent_init_gain.unwrap_or_default().to_string(),
            expected: "--recurrent with it (a recurrent scale needs recurrent layers)",
        });
    }
    if !r.conv.is_empty() && input_shape.len() != 3 {
        return Err(Error::Setting {
            name: "input shape",
            value: format!("{input_shape:?}"),
            expected: "[channels, rows, columns] for convolutional layers",
        });
    }
    let mut layers: Vec<LayerSpec> = Vec::new();
    for c in &r.conv {
        if c.channels == 0 || c.kernel == 0 || c.stride == 0 || c.pool == 0 {
            return Err(Error::Setting {
                name: "convolutional layer",
                value: format!("{c:?}"),
                expected: "positive channels, kernel and stride",
            });
        }
        layers.push(LayerSpec {
            op: OpSpec::Conv2d {
                out_channels: c.channels,
                kernel: [c.kernel; 2],
                stride: [c.stride; 2],
                padding: c.padding,
            },
            neurons: Some(hidden),
            recurrent: false,
            bias: r.bias,
            recurrent_bias: false,
        });
        if c.pool > 1 {
            layers.push(LayerSpec {
                op: OpSpec::Pool { kind: PoolKind::Sum, kernel: [c.pool; 2], stride: [c.pool; 2] },
                neurons: None,
                recurrent: false,
                bias: false,
                recurrent_bias: false,
            });
        }
    }
    layers.extend(r.hidden.iter().map(|&n| LayerSpec {
        op: OpSpec::Dense { n_out: n },
        neurons: Some(hidden),
        recurrent: r.recurrent,
        bias: r.bias,
        recurrent_bias: false,
    }));
    let out = match r.readout {
        Readout::MaxMembrane => {
            let mut p = LifConfig::lif(r.tau_out_us).discretise(dt, Discretisation::Exact);
            p.kind = NeuronKind::Li;
            p
        }
        Readout::SpikeCount => hidden,
    };
    layers.push(LayerSpec {
        op: OpSpec::Dense { n_out: n_classes },
        neurons: Some(out),
        recurrent: false,
        bias: false,
        recurrent_bias: false,
    });
    if let Some(chip) = r.chip {
        for l in &mut layers {
            l.neurons = l.neurons.map(|p| chip.neurons(p));
        }
    }
    let spec = NetworkSpec { input_shape: input_shape.to_vec(), layers };
    spec.shapes()?;
    Ok(spec)
}

/// Whether a model of network `model` fine-tunes into the recipe's `spec`: the same network, or
/// the same but for how its neurons reset (a subtracting model fine-tuned into its twin that
/// resets to zero, the reset NIR expresses: `--reset zero`), or for a chip
/// ([`SnnRecipe::chip`]) the same layers and sizes (its neurons become the chip's).
fn fine_tunes(model: &NetworkSpec, spec: &NetworkSpec, r: &SnnRecipe) -> bool {
    if r.chip.is_none() {
        let mut as_reset = model.clone();
        for (l, s) in as_reset.layers.iter_mut().zip(&spec.layers) {
            if let (Some(p), Some(q)) = (l.neurons.as_mut(), s.neurons) {
                (p.reset, p.v_reset) = (q.reset, q.v_reset);
            }
        }
        return model == spec || as_reset == *spec;
    }
    let shape = |s: &NetworkSpec| {
        let layers: Vec<_> = s.layers.iter().map(|l| (l.op, l.neurons.map(|p| p.kind), l.recurrent, l.bias)).collect();
        (s.input_shape.clone(), layers)
    };
    shape(model) == shape(spec)
}

/// What the data gave to train on.
#[derive(Debug, Clone, Serialize)]
pub struct DataSummary {
    /// The dataset folder's name, or what the simulated windows were.
    pub data: String,
    pub classes: usize,
    pub inputs: usize,
    pub steps: usize,
    pub dt_us: i64,
    pub train: usize,
    pub validation: usize,
    /// Tactile datasets: the test split's size (it is not scored by training).
    pub test: Option<usize>,
    pub input_events_per_sample: f64,
    /// Simulated windows: scans simulated, and those skipped (window count off).
    pub scans: Option<usize>,
    pub skipped_scans: Option<usize>,
}

/// A trained SNN with how it went.
pub struct TrainedSnn {
    pub model: SnnModel,
    pub history: Vec<EpochReport>,
    pub best_epoch: usize,
    pub best_val_accuracy: f64,
    /// The averaged weights' validation accuracy and whether they were chosen.
    pub average: Option<(f64, bool)>,
    /// Over how many last epochs the weights were averaged.
    pub averaged_epochs: usize,
    pub data: DataSummary,
    /// Accuracy on the event-driven engine: tactile datasets, the test split, only when asked
    /// ([`EvalTest`]); simulated windows, the validation windows.
    pub engine_accuracy: Option<f64>,
    pub engine_n: usize,
    /// Seconds of training (without loading and scoring).
    pub seconds: f64,
}

fn events_per_sample(s: &SpikeSet) -> f64 {
    s.trains.iter().map(|t| t.total()).sum::<u64>() as f64 / s.len().max(1) as f64
}

/// Whether training scores the test split. Test hygiene: nothing is chosen on it, and it is
/// looked at only when asked (`braille train --eval-test`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EvalTest {
    No,
    Yes,
}

/// A tactile dataset folder encoded by a recipe: the training split, the folder's own
/// validation split if it has one, and the test split (kept aside).
#[derive(Clone)]
pub struct TactileData {
    pub dir: std::path::PathBuf,
    pub classes: Vec<String>,
    pub encoding: TactileEncoding,
    pub train: SpikeSet,
    /// The folder's own validation split (`split.csv` rows marked `val`), if any.
    pub validation: Option<SpikeSet>,
    pub test: SpikeSet,
}

impl TactileData {
    /// Loads and encodes `data_dir` with the recipe's sampling period, sigma-delta threshold and
    /// step.
    pub fn load(data_dir: &Path, r: &SnnRecipe) -> Result<TactileData> {
        let data = Dataset::load(data_dir, r.period_us)?;
        TactileData::encode(&data, r)
    }

    /// Encodes a loaded dataset with the recipe's sigma-delta threshold and step.
    pub fn encode(data: &Dataset, r: &SnnRecipe) -> Result<TactileData> {
        let sd = SigmaDeltaConfig { threshold: r.sigma_delta, interpolate: r.interpolate };
        let encoding = TactileEncoding {
            merge_polarities: r.merge_polarities,
            binary: r.binary_input,
            classes: r.classes.clone(),
            channel_pool: r.channel_pool,
            ..TactileEncoding::fit(data, sd, r.dt_us)?
        };
        let validation = encoding.encode(data, Some(Split::Validation))?;
        Ok(TactileData {
            dir: data.dir.clone(),
            classes: encoding.select(data)?.classes.clone(),
            train: encoding.encode(data, Some(Split::Train))?,
            validation: (!validation.is_empty()).then_some(validation),
            test: encoding.encode(data, Some(Split::Test))?,
            encoding,
        })
    }

    /// The recipe's training and validation sets: the folder's validation split if it has one
    /// (and the recipe validates at all), else a stratified hold-out of `val_fraction` of the
    /// training split with `val_seed`.
    pub fn train_val(&self, r: &SnnRecipe) -> (SpikeSet, SpikeSet) {
        split_as(&self.train, self.validation.as_ref(), r)
    }

    /// The SNN search's hold-out (`val_fraction` of the training split, stratified, drawn with
    /// `val_seed`; or the folder's own validation split) as (training, validation), for the
    /// models compared with it; an error if either side is empty.
    pub fn hold_out(&self, val_fraction: f64, val_seed: u64) -> Result<(SpikeSet, SpikeSet)> {
        let hold = SnnRecipe { val_fraction, val_seed: Some(val_seed), ..Default::default() };
        let (train, val) = self.train_val(&hold);
        if train.is_empty() || val.is_empty() {
            return Err(Error::Data { path: self.dir.clone(), what: "needs training and validation samples".into() });
        }
        Ok((train, val))
    }
}

/// [`TactileData::train_val`] of a training split `train` encoded in any way (the samples chosen
/// depend on the labels alone, so two encodings of one split give the same samples).
fn split_as(train: &SpikeSet, validation: Option<&SpikeSet>, r: &SnnRecipe) -> (SpikeSet, SpikeSet) {
    match validation {
        _ if r.val_fraction <= 0.0 => (train.clone(), train.subset(&[])),
        Some(v) => (train.clone(), v.clone()),
        None => train.stratified_split(r.val_fraction, r.val_seed.unwrap_or(r.seed)),
    }
}

/// Knowledge distillation from trained SNNs (the recipe's `distill`): the model files and
/// the mix of losses ([`learn::sparse::Distill`]). Several teachers teach as an ensemble: their
/// softened distributions averaged (Hinton et al. 2015), as the logits `T ln(mean_k softmax(z_k /
/// T))`, whose softmax at `T` is that mean.
#[derive(Debug, Clone, PartialEq)]
pub struct DistillFrom {
    pub paths: Vec<std::path::PathBuf>,
    pub distill: learn::sparse::Distill,
}

impl DistillFrom {
    /// The recipe's distillation, if it names teachers.
    pub fn of(r: &SnnRecipe) -> Option<DistillFrom> {
        let d = r.distill.as_ref().filter(|d| !d.from.is_empty())?;
        Some(DistillFrom {
            paths: d.from.clone(),
            distill: learn::sparse::Distill { weight: d.weight, temperature: d.temperature },
        })
    }
}

/// The logits whose softmax at `temperature` is the mean of the members' softmaxes at it.
fn ensemble_logits(members: &[&[f32]], temperature: f32) -> Vec<f32> {
    let n = members.first().map_or(0, |z| z.len());
    let mut mean = vec![0.0f64; n];
    for z in members {
        let p = learn::sparse::softmax_at(z, temperature);
        mean.iter_mut().zip(&p).for_each(|(a, p)| *a += p / members.len() as f64);
    }
    mean.into_iter().map(|p| (temperature as f64 * p.ln()) as f32).collect()
}

/// The teachers' logits for each sample of `train` (the recipe's training set of `data`; several
/// teachers as [`DistillFrom`] says), and their mean accuracy on them.
fn teacher_logits(
    t: &DistillFrom,
    data: &TactileData,
    r: &SnnRecipe,
    train: &SpikeSet,
) -> Result<(Vec<Vec<f32>>, f64)> {
    let mut each: Vec<(Vec<Vec<f32>>, f64)> =
        t.paths.iter().map(|p| one_teacher(p, data, r, train)).collect::<Result<_>>()?;
    if each.len() == 1 {
        return Ok(each.remove(0));
    }
    let accuracy = each.iter().map(|e| e.1).sum::<f64>() / each.len().max(1) as f64;
    let logits = (0..train.len())
        .map(|s| {
            let members: Vec<&[f32]> = each.iter().map(|e| e.0[s].as_slice()).collect();
            ensemble_logits(&members, t.distill.temperature)
        })
        .collect();
    Ok((logits, accuracy))
}

/// One teacher's logits for each sample of `train` and its accuracy on them: the teacher runs on
/// the event-driven engine, each sample encoded as the teacher was trained (its own step and
/// encoding), and must know the same classes.
fn one_teacher(path: &Path, data: &TactileData, r: &SnnRecipe, train: &SpikeSet) -> Result<(Vec<Vec<f32>>, f64)> {
    let m = pipeline::models::load_snn(path)?;
    let bad = |what: String| Error::Model { path: path.to_path_buf(), what };
    if m.classes != data.classes {
        return Err(bad(format!("a teacher of classes {:?}, the data's are {:?}", m.classes, data.classes)));
    }
    let encoding = crate::eval::tactile::encoding_of(&m, path)?;
    let dataset = Dataset::load(&data.dir, encoding.period_us)?;
    let theirs = encoding.encode(&dataset, Some(Split::Train))?;
    let validation = encoding.encode(&dataset, Some(Split::Validation))?;
    let (theirs, _) = split_as(&theirs, (!validation.is_empty()).then_some(&validation), r);
    if theirs.labels != train.labels {
        return Err(bad(format!(
            "its encoding of {} gives other training samples than the recipe's ({} against {})",
            data.dir.display(),
            theirs.len(),
            train.len()
        )));
    }
    let scored = snn_accuracy(&m.network, &m.config, &theirs, Mode::Stepped)?;
    Ok((scored.predictions.into_iter().map(|(_, logits)| logits).collect(), scored.accuracy))
}

/// Trains the recipe on a tactile dataset folder (iCub layout: any channel and class count).
pub fn train_tactile(
    r: &SnnRecipe,
    data_dir: &Path,
    eval_test: EvalTest,
    observer: &mut dyn Observer,
) -> Result<TrainedSnn> {
    train_on(r, &TactileData::load(data_dir, r)?, eval_test, None, None, observer)
}

/// Trains the recipe on an encoded tactile dataset (its encoding must be the recipe's). With
/// `init`, training starts from that model's weights (fine-tuning): its layers and sizes must be
/// the recipe's and its input this encoding; its neurons may differ (a float model fine-tuned
/// for a chip takes the chip's decays and reset, [`SnnRecipe::chip`]). With `distill`, each
/// training sample learns from its label and from a trained model's logits on it
/// ([`learn::train::train_distilled`]).
pub fn train_on(
    r: &SnnRecipe,
    data: &TactileData,
    eval_test: EvalTest,
    init: Option<&Path>,
    distill: Option<&DistillFrom>,
    observer: &mut dyn Observer,
) -> Result<TrainedSnn> {
    if data.encoding.dt_us != r.dt_us {
        return Err(Error::Data {
            path: data.dir.clone(),
            what: format!("encoded with {} us steps, the recipe steps {} us", data.encoding.dt_us, r.dt_us),
        });
    }
    let (train, val) = data.train_val(r);
    let summary = DataSummary {
        data: data.dir.display().to_string(),
        classes: data.classes.len(),
        inputs: data.encoding.n_inputs(),
        steps: data.encoding.steps,
        dt_us: data.encoding.dt_us,
        train: train.len(),
        validation: val.len(),
        test: Some(data.test.len()),
        input_events_per_sample: events_per_sample(&data.train),
        scans: None,
        skipped_scans: None,
    };
    let spec = network_spec(r, &[data.encoding.n_inputs()], data.classes.len())?;
    let start = match init {
        Some(path) => {
            let m = pipeline::models::load_snn(path)?;
            let bad = |what: &str| Error::Model { path: path.to_path_buf(), what: what.to_string() };
            if !fine_tunes(&m.config.network, &spec, r) {
                return Err(bad(
                    "its network (layers, sizes or neurons) is not the recipe's: fine-tuning keeps the network",
                ));
            }
            // read as an encoding, so that a model written before a field existed (its default)
            // still matches
            let theirs: Option<TactileEncoding> = serde_json::from_value(m.preprocess.clone()).ok();
            if theirs.as_ref() != Some(&data.encoding) || m.classes != data.classes || m.config.dt_us != r.dt_us {
                return Err(bad("its input (encoding, classes or step) is not this data's by the recipe"));
            }
            Some(m.network.weights())
        }
        None => None,
    };
    let teacher = match distill {
        Some(d) => {
            let (logits, accuracy) = teacher_logits(d, data, r, &train)?;
            Some((learn::train::Teacher { logits, distill: d.distill }, accuracy))
        }
        None => None,
    };
    let fit = fit(r, spec, &train, &val, start, teacher.as_ref().map(|t| &t.0), observer)?;
    let scored = match eval_test {
        EvalTest::Yes => Some(snn_accuracy(&fit.network, &fit.config, &data.test, Mode::Stepped)?),
        EvalTest::No => None,
    };
    let mut extra = serde_json::json!({
        "data": data.dir.file_name().map(|n| n.to_string_lossy().into_owned()),
    });
    if let Some(s) = &scored {
        extra["test_accuracy"] = s.accuracy.into();
    }
    if let Some(v) = r.val_seed {
        extra["val_seed"] = v.into();
    }
    if let Some(p) = init {
        extra["init"] = p.display().to_string().into();
    }
    if let (Some(d), Some((_, accuracy))) = (distill, &teacher) {
        let teachers: Vec<String> = d.paths.iter().map(|p| p.display().to_string()).collect();
        extra["distill"] = serde_json::json!({
            "teacher": teachers.join(", "),
            "weight": d.distill.weight,
            "temperature": d.distill.temperature,
            "teacher_train_accuracy": accuracy,
        });
    }
    let model = SnnModel {
        preprocess: serde_json::to_value(&data.encoding).map_err(|source| Error::Json { path: out_name(), source })?,
        classes: data.classes.clone(),
        provenance: provenance(r, &fit, extra),
        config: fit.config.clone(),
        network: fit.network.clone(),
        operating_point: None,
    };
    let n = scored.as_ref().map_or(0, |s| s.n);
    Ok(fit.into_trained(model, summary, scored.map(|s| s.accuracy), n))
}

/// Trains the recipe on the SIMULATED character windows (SAB and UN, 8 mm/s, 1.5 mm, the same
/// scans and validation split as the ResNet with the same trials and seed), the windows' events
/// fed as input spikes, one step per 10 ms frame.
///
/// With `recordings`, the windows come from a lab's recordings folder instead
/// ([`corpus::windows::recorded_training_windows`]: its `train` scans, its `val` scans for
/// checkpoints; the recipe's scans, seed and word rows do not apply). With `init`, training
/// starts from that model's weights (fine-tuning; it must have the recipe's network and input).
pub fn train_windows(
    r: &SnnRecipe,
    recordings: Option<&corpus::recordings::Recordings>,
    init: Option<&Path>,
    observer: &mut dyn Observer,
    progress: &dyn Progress,
) -> Result<TrainedSnn> {
    let rows = crate::train::resnet::crop_rows(r.crop_rows)?;
    let pool = crate::train::resnet::check_pool(r.pool, &rows)?;
    match (r.val_builds, recordings) {
        (Some(builds), Some(_)) => {
            return Err(Error::Setting {
                name: "val_builds",
                value: format!("{builds:?}").to_lowercase(),
                expected: "none with a recordings folder (its `val` scans choose the checkpoints)",
            });
        }
        (Some(corpus::world::SensorBuilds::Test), None) => {
            return Err(Error::Setting {
                name: "val_builds",
                value: "test".into(),
                expected: "training or validation: the test builds never choose anything",
            });
        }
        _ => {}
    }
    if let (Some(builds), Some(_)) = (&r.train_builds, recordings) {
        return Err(Error::Setting {
            name: "train_builds",
            value: format!("{builds:?}"),
            expected: "none with a recordings folder (its `train` scans are the training windows)",
        });
    }
    let input = CharInput {
        labeler: pipeline::labeling::LabelerConfig::default(),
        rows,
        cols: LITE_COLS,
        pool,
        preprocess: if r.center {
            pipeline::preprocess::Preprocess::Norm
        } else {
            pipeline::preprocess::Preprocess::Raw
        },
        augment: pipeline::preprocess::AugmentConfig::default(),
        band: r.band_rows.map(|[first, end]| first..end),
        denoise: r.denoise,
    };
    input.check_band()?;
    let world = r.training_world()?;
    let (tw, data) = match recordings {
        Some(rec) => (
            corpus::windows::recorded_training_windows(rec, &input, r.task, r.jitter_ms, r.blank_cells, progress)?,
            format!(
                "recorded scans of {} (docs/recordings.md): its `train` scans, its `val` scans for checkpoints",
                rec.dir.display()
            ),
        ),
        None => (
            training_windows(&r.training_scans(), &input, r.task, r.jitter_ms, r.blank_cells, &world, progress)?,
            format!(
                "SIMULATED training windows ({} realism, sensor builds {:?}): {}, at {}",
                r.realism,
                world.sensors,
                r.training_scans().boards(),
                conditions(&r.training_scans())
            ),
        ),
    };
    let (scans, skipped_scans) = (tw.scans, tw.skipped_scans);
    let (train, mut val) = corpus::windows::snn_sets(&input, tw, r.dt_us, r.task);
    let mut data = data;
    if let Some(builds) = r.val_builds {
        val = validation_board_set(r, &input, builds, progress)?;
        data = format!(
            "{data}; checkpoints chosen on VAL scanned by the {} sensor builds {:?} ({} windows)",
            format!("{builds:?}").to_lowercase(),
            corpus::world::World::of(r.realism, builds).sensors,
            val.len()
        );
    }
    let summary = DataSummary {
        data: data.clone(),
        classes: train.classes.len(),
        inputs: train.n_inputs,
        steps: train.steps,
        dt_us: r.dt_us,
        train: train.len(),
        validation: val.len(),
        test: None,
        input_events_per_sample: events_per_sample(&train),
        scans: Some(scans),
        skipped_scans: Some(skipped_scans),
    };
    let [_, h, w] = input.shape();
    let shape = if r.conv.is_empty() { vec![train.n_inputs] } else { vec![2, h, w] };
    let spec = network_spec(r, &shape, train.classes.len())?;
    let start = match init {
        Some(path) => {
            let m = pipeline::models::load_snn(path)?;
            let bad = |what: String| Error::Model { path: path.to_path_buf(), what };
            if !fine_tunes(&m.config.network, &spec, r) {
                return Err(bad(
                    "its network (layers, sizes or neurons) is not the recipe's: fine-tuning keeps the network".into(),
                ));
            }
            let want = serde_json::to_value(&input).map_err(|source| Error::Json { path: out_name(), source })?;
            // the labeler that cut the model's training windows is not its input: a model from
            // an earlier labeler (a `clean` model, say) fine-tunes on windows cut by this one,
            // which the new model records
            let without_labeler = |v: &serde_json::Value| {
                let mut v = v.clone();
                if let Some(o) = v.as_object_mut() {
                    o.remove("labeler");
                }
                v
            };
            if without_labeler(&m.preprocess) != without_labeler(&want) || m.config.dt_us != r.dt_us {
                return Err(bad("its input (crop, pooling, centring, step) is not the recipe's".into()));
            }
            Some(m.network.weights())
        }
        None => None,
    };
    let fit = fit(r, spec, &train, &val, start, None, observer)?;
    let scored = snn_accuracy(&fit.network, &fit.config, &val, Mode::Stepped)?;
    let model = SnnModel {
        preprocess: serde_json::to_value(&input).map_err(|source| Error::Json { path: out_name(), source })?,
        classes: r.task.classes(),
        provenance: provenance(
            r,
            &fit,
            serde_json::json!({
                "data": if recordings.is_some() {
                    data
                } else {
                    format!(
                        "simulated (virtual Evetac): {}, {}",
                        r.training_scans().boards(),
                        conditions(&r.training_scans())
                    )
                },
                "sweep": r.training_scans().sweep,
                "init": init.map(|p| p.display().to_string()),
                "task": r.task,
                "jitter_ms": r.jitter_ms,
                "blank_cells": r.blank_cells,
                "word_rows": r.word_rows,
                "letter_rows": r.letter_rows,
                "pair_rows": r.pair_rows,
                "scans": scans,
                "train_windows": train.len(),
                "val_windows": val.len(),
            }),
        ),
        config: fit.config.clone(),
        network: fit.network.clone(),
        // set by `braille calibrate-reader` on the validation words, for a segmentation network
        operating_point: None,
    };
    Ok(fit.into_trained(model, summary, Some(scored.accuracy), scored.n))
}

/// The windows of the validation board (VAL, the validation seed) at the training scans'
/// conditions (their sweep, or 8 mm/s and 1.5 mm), `trials` scans a row, scanned by `builds`.
fn validation_board_set(
    r: &SnnRecipe,
    input: &CharInput,
    builds: corpus::world::SensorBuilds,
    progress: &dyn Progress,
) -> Result<SpikeSet> {
    let scans = r.training_scans();
    let spec = corpus::windows::CharSetSpec {
        boards: vec![sim::BoardKind::Val],
        speed_mm_s: 8.0,
        depth_mm: 1.5,
        trials: r.trials,
        seed: corpus::world::VALIDATION_SEED,
        task: r.task,
        jitter_ms: r.jitter_ms,
        world: corpus::world::World::of(r.realism, builds),
        blank_cells: r.blank_cells,
        sweep: scans.sweep.clone(),
    };
    let (raw, _) = corpus::windows::build(&spec, input, progress)?;
    Ok(corpus::windows::snn_set(input, &raw, &(0..raw.len()).collect::<Vec<_>>(), r.dt_us, r.task))
}

/// A finished fit: the chosen weights as an engine network.
struct Fit {
    outcome: Outcome,
    network: snn::network::Network,
    config: SnnConfig,
    train: TrainConfig,
    seconds: f64,
}

impl Fit {
    fn into_trained(
        self,
        model: SnnModel,
        data: DataSummary,
        engine_accuracy: Option<f64>,
        engine_n: usize,
    ) -> TrainedSnn {
        TrainedSnn {
            seconds: self.seconds,
            model,
            best_epoch: self.outcome.best_epoch,
            best_val_accuracy: self.outcome.best_val_accuracy,
            average: self.outcome.average,
            averaged_epochs: self.train.average_epochs,
            history: self.outcome.history,
            data,
            engine_accuracy,
            engine_n,
        }
    }
}

/// Trains `spec` from the recipe's seeded initialisation.
/// Trains `spec` by the recipe from seeded initial weights, or from `start` (fine-tuning).
fn fit(
    r: &SnnRecipe,
    spec: NetworkSpec,
    train: &SpikeSet,
    val: &SpikeSet,
    start: Option<Vec<snn::spec::LayerWeights>>,
    teacher: Option<&learn::train::Teacher>,
    observer: &mut dyn Observer,
) -> Result<Fit> {
    let cfg = r.train_config();
    let mut twin = SnnTwin::new(spec.clone(), r.surrogate(), r.readout)?;
    twin.clamped_readout_gradient = r.readout_gradient == ReadoutGradient::Clamped;
    let init = match start {
        Some(w) => w,
        None => spec.init_with_recurrent_gain(r.seed, r.init_gain, r.recurrent_init_gain.unwrap_or(r.init_gain))?,
    };
    let started = std::time::Instant::now();
    let outcome = match teacher {
        Some(t) => learn::train::train_distilled(&twin, &init, train, val, &cfg, t, observer)?,
        None => learn::train::train(&twin, &init, train, val, &cfg, observer)?,
    };
    let seconds = started.elapsed().as_secs_f64();
    let network = spec.build(outcome.weights.clone())?;
    Ok(Fit {
        outcome,
        network,
        config: SnnConfig { network: spec, dt_us: r.dt_us, readout: r.readout },
        train: cfg,
        seconds,
    })
}

/// How a model was trained, with `extra` (an object) merged in; the recipe in full.
fn provenance(r: &SnnRecipe, fit: &Fit, extra: serde_json::Value) -> serde_json::Value {
    let mut p = serde_json::json!({
        "recipe": r,
        "train": fit.train,
        "surrogate": format!("{:?}", r.surrogate()),
        "readout_gradient": format!("{:?}", r.readout_gradient),
        "init_gain": r.init_gain,
        "recurrent_init_gain": r.recurrent_init_gain.unwrap_or(r.init_gain),
        "best_epoch": fit.outcome.best_epoch,
        "val_accuracy": fit.outcome.best_val_accuracy,
        "train_seconds": fit.seconds,
        "peak_rss_mb": crate::peak_rss_mb(),
    });
    if let (Some(p), serde_json::Value::Object(extra)) = (p.as_object_mut(), extra) {
        p.extend(extra);
    }
    p
}

/// Writes an SNN model file, creating its folder; an existing file is kept unless `force`.
pub fn save_model(model: &SnnModel, out: &Path, force: bool) -> Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
    }
    Ok(model.save(out, force)?)
}

/// Trained SNNs of one architecture merged into one network (`braille ensemble`): the members
/// side by side, their readouts summed, which the engine runs and NIR exports like any other. All
/// must share the architecture, step, readout, input encoding and classes; the provenance lists
/// each member's file and provenance.
pub fn ensemble(paths: &[std::path::PathBuf]) -> Result<SnnModel> {
    if paths.len() < 2 {
        return Err(Error::Setting {
            name: "ensemble members",
            value: paths.len().to_string(),
            expected: "two or more",
        });
    }
    let members: Vec<SnnModel> = paths.iter().map(|p| SnnModel::load(p)).collect::<snn::Result<_>>()?;
    let first = &members[0];
    for (path, m) in paths.iter().zip(&members).skip(1) {
        let differs = [
            (m.config.network != first.config.network, "architecture"),
            (m.config.dt_us != first.config.dt_us, "step"),
            (m.config.readout != first.config.readout, "readout"),
            (m.preprocess != first.preprocess, "input encoding"),
            (m.classes != first.classes, "classes"),
        ];
        if let Some((_, what)) = differs.iter().find(|(d, _)| *d) {
            return Err(Error::EnsembleMember { path: path.clone(), first: paths[0].clone(), what });
        }
    }
    let weights: Vec<_> = members.iter().map(|m| m.network.weights()).collect();
    let (spec, merged) = snn::spec::ensemble(&first.config.network, &weights)?;
    let network = spec.build(merged)?;
    let provenance = serde_json::json!({
        "ensemble": paths.iter().zip(&members).map(|(p, m)| serde_json::json!({
            "file": p.file_name().map(|n| n.to_string_lossy().into_owned()),
            "provenance": m.provenance,
        })).collect::<Vec<_>>(),
    });
    Ok(SnnModel {
        config: snn::model_file::SnnConfig { network: spec, dt_us: first.config.dt_us, readout: first.config.readout },
        network,
        preprocess: first.preprocess.clone(),
        classes: first.classes.clone(),
        provenance,
        // a segmentation network's operating point was calibrated for one member, not the sum
        operating_point: None,
    })
}

/// What a header that would not serialise is named by in its error (the model is not written yet).
fn out_name() -> std::path::PathBuf {
    "the model's `preprocess` header".into()
}

/// The summary `braille train` prints: the data, the chosen weights, and the engine's accuracy
/// (the test split only when it was asked for).
impl std::fmt::Display for TrainedSnn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let d = &self.data;
        writeln!(
            f,
            "{}: {} classes, {} inputs, {} steps of {} us; train {} / validation {}{} samples, {:.1} input events per sample{}",
            d.data,
            d.classes,
            d.inputs,
            d.steps,
            d.dt_us,
            d.train,
            d.validation,
            d.test.map_or(String::new(), |t| format!(" / test {t}")),
            d.input_events_per_sample,
            d.scans.map_or(String::new(), |s| format!(
                "; {s} scans ({} skipped: window count off)",
                d.skipped_scans.unwrap_or(0)
            ))
        )?;
        if let Some((accuracy, chosen)) = self.average {
            let verdict = if chosen { "chosen" } else { "not chosen" };
            writeln!(
                f,
                "weights averaged over the last {} epochs: validation {:.1}%, {verdict}",
                self.averaged_epochs,
                100.0 * accuracy
            )?;
        }
        let kept = if d.validation == 0 {
            format!("kept epoch {} (no validation set)", self.best_epoch)
        } else {
            format!("best epoch {} (validation {:.1}%)", self.best_epoch, 100.0 * self.best_val_accuracy)
        };
        match (d.test, self.engine_accuracy) {
            (Some(_), Some(a)) => {
                writeln!(f, "{kept}; test accuracy on the event-driven engine: {:.2}% of {}", 100.0 * a, self.engine_n)
            }
            (Some(_), None) => writeln!(f, "{kept}; the test split was not looked at (--eval-test scores it)"),
            (None, a) => writeln!(
                f,
                "{kept}: {:.1}% of the validation windows on the event-driven engine (SIMULATED)",
                100.0 * a.unwrap_or(f64::NAN)
            ),
        }
    }
}

/// The speeds and depths of training scans, as a summary names them.
pub fn conditions(scans: &corpus::windows::TrainingScans) -> String {
    match &scans.sweep {
        None => "8 mm/s, 1.5 mm".to_string(),
        Some(s) if s.levels.is_empty() => {
            format!("{:?} mm/s x {:?} mm, one pairing per trial", s.speeds_mm_s, s.depths_mm)
        }
        Some(s) => format!(
            "{:?} mm/s x {:?} mm x nuisance levels {:?} (nominal 0 to harsh 1), one per trial",
            s.speeds_mm_s, s.depths_mm, s.levels
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use snn::neuron::Reset;

    #[test]
    fn an_ensembles_logits_soften_to_the_mean_of_its_members_distributions() {
        let soft = |z: &[f32], t: f64| -> Vec<f64> {
            let e: Vec<f64> = z.iter().map(|&l| (l as f64 / t).exp()).collect();
            let s: f64 = e.iter().sum();
            e.into_iter().map(|e| e / s).collect()
        };
        let members: [&[f32]; 3] = [&[1.0, 5.0, -2.0], &[4.0, 0.5, 0.0], &[-1.0, 2.0, 3.0]];
        for t in [1.0f32, 4.0] {
            let z = super::ensemble_logits(&members, t);
            let want: Vec<f64> =
                (0..3).map(|c| members.iter().map(|m| soft(m, t as f64)[c]).sum::<f64>() / 3.0).collect();
            for (got, want) in soft(&z, t as f64).iter().zip(&want) {
                assert!((got - want).abs() < 1e-6, "T {t}: {got} against {want}");
            }
        }
        // one member is itself, up to a constant
        let z = super::ensemble_logits(&members[..1], 2.0);
        assert!((z[1] - z[0] - 4.0).abs() < 1e-5 && (z[1] - z[2] - 7.0).abs() < 1e-5, "{z:?}");
    }

    #[test]
    fn a_model_fine_tunes_into_its_twin_that_resets_to_zero_and_into_nothing_else() {
        let sub = SnnRecipe { reset: Reset::Subtract, ..SnnRecipe::preset("raw1350").expect("a preset") };
        let spec = |r: &SnnRecipe| network_spec(r, &[24], 27).expect("a network");
        let zero = SnnRecipe { reset: Reset::Zero, ..sub.clone() };
        assert!(fine_tunes(&spec(&sub), &spec(&sub), &sub));
        assert!(fine_tunes(&spec(&sub), &spec(&zero), &zero), "the reset alone differs");
        let wider = SnnRecipe { hidden: vec![sub.hidden[0] * 2], ..zero.clone() };
        assert!(!fine_tunes(&spec(&sub), &spec(&wider), &wider), "the layers differ");
        let slower = SnnRecipe { tau_mem_us: sub.tau_mem_us * 2.0, ..zero.clone() };
        assert!(!fine_tunes(&spec(&sub), &spec(&slower), &slower), "the neurons' decay differs");
    }
}
