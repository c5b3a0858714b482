//! The burn twin computes what the engine's time-stepped reference computes, its gradients train,
//! and the same seed gives the same weights.

use burn::tensor::{Device, Tensor, TensorData};
use encoders::spike_train::SpikeTrain;
use learn::data::SpikeSet;
use learn::snn::{SnnParams, SnnTwin};
use learn::sparse::Distill;
use learn::train::{Silent, Teacher, TrainConfig, Trainer, train, train_distilled};
use snn::model_file::Readout;
use snn::network::{PoolKind, forward_dense, random_input};
use snn::neuron::{NeuronParams, Reset, Surrogate};
use snn::spec::{LayerSpec, NetworkSpec, OpSpec};

/// burn's `flex` device has one random generator for the whole process (`device.seed` resets
/// it), and the tests of this file run on parallel threads: each takes this lock for its whole
/// run, so that no other test draws from the generator between a test's seeding and its draws.
static BURN_RNG: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn burn_rng() -> std::sync::MutexGuard<'static, ()> {
    BURN_RNG.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn lif(beta: f32) -> Option<NeuronParams> {
    Some(NeuronParams::lif(beta).with_reset(Reset::Subtract))
}

fn spec(readout: Readout) -> NetworkSpec {
    let out = match readout {
        Readout::MaxMembrane => Some(NeuronParams::leaky_integrator(0.95)),
        Readout::SpikeCount => Some(NeuronParams::lif(0.9)),
    };
    let mut cuba = NeuronParams::cuba_lif(0.7, 0.9).with_reset(Reset::Subtract);
    cuba.v_th = 0.8;
    NetworkSpec {
        input_shape: vec![2, 6, 6],
        layers: vec![
            LayerSpec {
                op: OpSpec::Conv2d { out_channels: 4, kernel: [3, 3], stride: [1, 1], padding: [1, 1] },
                neurons: lif(0.8),
                recurrent: false,
                bias: true,
                recurrent_bias: false,
            },
            LayerSpec {
                op: OpSpec::Pool { kind: PoolKind::Sum, kernel: [2, 2], stride: [2, 2] },
                neurons: None,
                recurrent: false,
                bias: false,
                recurrent_bias: false,
            },
            LayerSpec {
                op: OpSpec::Dense { n_out: 12 },
                neurons: Some(cuba),
                recurrent: true,
                bias: false,
                recurrent_bias: false,
            },
            LayerSpec {
                op: OpSpec::Dense { n_out: 5 },
                neurons: out,
                recurrent: false,
                bias: false,
                recurrent_bias: false,
            },
        ],
    }
}

fn steps_of(input: &[f32], steps: usize, n: usize) -> Vec<Tensor<2>> {
    (0..steps)
        .map(|t| Tensor::<2>::from_data(TensorData::new(input[t * n..(t + 1) * n].to_vec(), [1, n]), &Device::flex()))
        .collect()
}

#[test]
fn twin_forward_matches_the_time_stepped_reference() {
    let _rng = burn_rng();
    for readout in [Readout::MaxMembrane, Readout::SpikeCount] {
        let spec = spec(readout);
        let weights = spec.init(7, 2.5).unwrap();
        let net = spec.build(weights.clone()).unwrap();
        let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, readout).unwrap();
        let params = SnnParams::from_weights(&spec, &weights, &Device::flex()).unwrap();
        // weights survive the trip into burn's layouts and back
        assert_eq!(params.weights(&spec).unwrap(), weights);
        let (steps, n) = (40, net.n_inputs());
        let mut active = 0;
        for seed in 0..4 {
            let input = random_input(seed, steps, n, 0.15);
            let reference = forward_dense(&net, &input, steps).unwrap();
            let out = twin.forward(&params, &steps_of(&input, steps, n));
            let logits = out.logits.to_data().convert::<f32>().try_to_vec::<f32>().unwrap();
            let want: Vec<f32> = match readout {
                Readout::MaxMembrane => reference.v_max.clone(),
                Readout::SpikeCount => reference.output_counts(5).iter().map(|&c| c as f32).collect(),
            };
            for (a, b) in logits.iter().zip(&want) {
                // sums in another order: float tolerance (a spike flipped at the threshold would
                // show as a large difference)
                assert!((a - b).abs() <= 1e-4 * (1.0 + b.abs()), "{readout:?}: {logits:?} vs {want:?}");
            }
            active += want.iter().filter(|&&v| v > 0.0).count();
        }
        assert!(active > 0, "the test needs output activity");
    }
}

/// Two classes: class c gets its input spikes on inputs of parity c.
fn toy_set(n: usize, seed: u64) -> SpikeSet {
    let (steps, n_in) = (20, 8);
    let mut trains = Vec::new();
    let mut labels = Vec::new();
    for s in 0..n {
        let label = s % 2;
        let noise = random_input(seed * 1000 + s as u64, steps, n_in, 0.2);
        let mut offsets = vec![0u32];
        let (mut inputs, mut counts) = (Vec::new(), Vec::new());
        for t in 0..steps {
            for i in 0..n_in {
                if noise[t * n_in + i] != 0.0 && i % 2 == label {
                    inputs.push(i as u32);
                    counts.push(1);
                }
            }
            offsets.push(inputs.len() as u32);
        }
        trains.push(SpikeTrain { t_start_us: 0, dt_us: 1_000, n_inputs: n_in, offsets, inputs, counts });
        labels.push(label);
    }
    SpikeSet {
        n_inputs: n_in,
        steps,
        dt_us: 1_000,
        classes: vec!["even".into(), "odd".into()],
        trains,
        labels,
        dropped_events: 0,
    }
}

#[test]
fn training_learns_and_repeats_exactly() {
    let _rng = burn_rng();
    for trainer in [Trainer::Sparse, Trainer::Dense] {
        learns_and_repeats_exactly(trainer);
    }
}

fn learns_and_repeats_exactly(trainer: Trainer) {
    let spec = small_spec(true);
    let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, Readout::MaxMembrane).unwrap();
    let cfg =
        TrainConfig { epochs: 6, batch_size: 8, lr: 1e-2, seed: 3, trainer, dropout: 0.1, ..TrainConfig::default() };
    let (train_set, val) = (toy_set(48, 1), toy_set(16, 2));
    let init = spec.init(3, 1.0).unwrap();
    let a = train(&twin, &init, &train_set, &val, &cfg, &mut Silent).unwrap();
    let first = a.history.first().unwrap();
    let last = a.history.last().unwrap();
    assert!(last.train_loss < first.train_loss, "loss must fall: {first:?} -> {last:?}");
    assert!(a.best_val_accuracy >= 0.9, "a separable task: {}", a.best_val_accuracy);
    let b = train(&twin, &init, &train_set, &val, &cfg, &mut Silent).unwrap();
    assert_eq!(a.weights, b.weights, "the same seed gives the same weights");
    assert_eq!(
        a.history.iter().map(|h| h.train_loss).collect::<Vec<_>>(),
        b.history.iter().map(|h| h.train_loss).collect::<Vec<_>>()
    );
}

#[test]
fn distillation_at_weight_zero_trains_as_the_cross_entropy_and_a_teacher_is_followed() {
    let spec = small_spec(false);
    let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, Readout::MaxMembrane).unwrap();
    let cfg = TrainConfig {
        epochs: 6,
        batch_size: 8,
        lr: 1e-2,
        seed: 3,
        trainer: Trainer::Sparse,
        dropout: 0.1,
        ..TrainConfig::default()
    };
    let (train_set, val) = (toy_set(48, 1), toy_set(16, 2));
    let init = spec.init(3, 1.0).unwrap();
    let plain = train(&twin, &init, &train_set, &val, &cfg, &mut Silent).unwrap();
    // a teacher that calls every sample the other class than its label
    let swapped: Vec<Vec<f32>> =
        train_set.labels.iter().map(|&l| if l == 0 { vec![0.0, 6.0] } else { vec![6.0, 0.0] }).collect();
    let teacher = |weight| Teacher { logits: swapped.clone(), distill: Distill { weight, temperature: 2.0 } };
    let zero = train_distilled(&twin, &init, &train_set, &val, &cfg, &teacher(0.0), &mut Silent).unwrap();
    assert_eq!(plain.weights, zero.weights, "weight 0 is the cross-entropy, step for step");
    // all soft: the student learns the teacher's labels, so it is wrong on validation
    let all = train_distilled(&twin, &init, &train_set, &val, &cfg, &teacher(1.0), &mut Silent).unwrap();
    let last = all.history.last().unwrap();
    assert!(plain.best_val_accuracy >= 0.9, "{}", plain.best_val_accuracy);
    assert!(last.val_accuracy <= 0.2, "taught the swapped classes: {}", last.val_accuracy);
    // refused: logits for another number of samples or outputs, a weight out of [0, 1], the dense trainer
    let short = Teacher { logits: swapped[1..].to_vec(), ..teacher(0.5) };
    let narrow = Teacher { logits: vec![vec![0.0]; swapped.len()], ..teacher(0.5) };
    for (t, c) in [
        (short, cfg.clone()),
        (narrow, cfg.clone()),
        (teacher(1.5), cfg.clone()),
        (teacher(0.5), TrainConfig { trainer: Trainer::Dense, ..cfg.clone() }),
    ] {
        assert!(train_distilled(&twin, &init, &train_set, &val, &c, &t, &mut Silent).is_err(), "{t:?}");
    }
}

#[test]
fn both_trainers_take_the_same_steps() {
    let _rng = burn_rng();
    // exact gradients, Adam with clipping and decoupled weight decay, augmentation drawn alike:
    // after two epochs of three steps the weights agree to float rounding
    let spec = small_spec(true);
    let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, Readout::MaxMembrane).unwrap();
    let (train_set, val) = (toy_set(48, 1), toy_set(16, 2));
    let init = spec.init(5, 2.0).unwrap();
    let cfg = TrainConfig {
        epochs: 2,
        batch_size: 16,
        lr: 1e-2,
        seed: 4,
        clip_norm: 0.5,
        weight_decay: 0.1,
        augment: learn::train::Augment { drop_events: 0.1, stretch: 0.1, event_jitter_us: 1_000 },
        gradient_cutoff: 0.0,
        ..TrainConfig::default()
    };
    let run =
        |trainer| train(&twin, &init, &train_set, &val, &TrainConfig { trainer, ..cfg.clone() }, &mut Silent).unwrap();
    let (sparse, dense) = (run(Trainer::Sparse), run(Trainer::Dense));
    let flat = |w: &[snn::spec::LayerWeights]| -> Vec<f32> {
        w.iter()
            .flat_map(|l| l.weight.iter().chain(l.recurrent.iter().flatten()).copied().collect::<Vec<_>>())
            .collect()
    };
    let (a, b, w0) = (flat(&sparse.weights), flat(&dense.weights), flat(&init));
    let moved = a.iter().zip(&w0).map(|(x, y)| (x - y).abs()).fold(0f32, f32::max);
    let apart = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0f32, f32::max);
    assert!(moved > 1e-2, "training moved the weights by {moved}");
    assert!(apart < 1e-4, "the trainers' weights differ by up to {apart} (moved {moved})");
    for (s, d) in sparse.history.iter().zip(&dense.history) {
        assert!((s.train_loss - d.train_loss).abs() < 1e-4 && (s.val_loss - d.val_loss).abs() < 1e-4, "{s:?} vs {d:?}");
    }
}

#[test]
fn the_truncation_check_measures_the_first_and_last_epochs_and_changes_nothing() {
    let _rng = burn_rng();
    let spec = small_spec(false);
    let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, Readout::MaxMembrane).unwrap();
    let (train_set, val) = (toy_set(48, 1), toy_set(16, 2));
    let init = spec.init(3, 1.0).unwrap();
    let base =
        TrainConfig { epochs: 3, batch_size: 16, lr: 1e-2, seed: 3, gradient_cutoff: 0.05, ..TrainConfig::default() };
    let plain = train(&twin, &init, &train_set, &val, &base, &mut Silent).unwrap();
    let checked =
        train(&twin, &init, &train_set, &val, &TrainConfig { check_truncation: true, ..base.clone() }, &mut Silent)
            .unwrap();
    assert_eq!(plain.weights, checked.weights, "the check computes the exact gradient beside, never applies it");
    let seen: Vec<Option<usize>> = checked.history.iter().map(|h| h.truncation.as_ref().map(|t| t.batches)).collect();
    // 48 samples in batches of 16: three batches in each checked epoch
    assert_eq!(seen, [Some(3), None, Some(3)]);
    let first = checked.history[0].truncation.as_ref().unwrap();
    assert!(first.cosine_min <= first.cosine_mean && first.cosine_mean <= 1.0 + 1e-9, "{first:?}");
    assert!(first.cosine_mean > 0.5 && first.relative_error_mean > 0.0, "truncated: close, not equal: {first:?}");
    assert!(plain.history.iter().all(|h| h.truncation.is_none()));
    // exact gradients have nothing to check against
    let exact = TrainConfig { check_truncation: true, gradient_cutoff: 0.0, ..base };
    let e = train(&twin, &init, &train_set, &val, &exact, &mut Silent).unwrap();
    assert!(e.history.iter().all(|h| h.truncation.is_none()));
}

#[test]
fn gradient_agreement_by_hand() {
    let _rng = burn_rng();
    use learn::sparse::Params;
    let p = |v: Vec<f32>| Params { layers: vec![learn::sparse::Tensors { weight: v, ..Default::default() }] };
    // (3, 4) against (4, 3): cosine 24/25; |(-1, 1)| / 5
    let (cos, rel) = learn::train::gradient_agreement(&p(vec![3.0, 4.0]), &p(vec![4.0, 3.0]));
    assert!((cos - 0.96).abs() < 1e-12 && (rel - 2f64.sqrt() / 5.0).abs() < 1e-12, "{cos} {rel}");
    let t = learn::train::TruncationCheck::of(&[(0.9, 0.2), (0.7, 0.4)]).unwrap();
    assert_eq!((t.batches, t.cosine_min), (2, 0.7));
    assert!((t.cosine_mean - 0.8).abs() < 1e-12 && (t.relative_error_mean - 0.3).abs() < 1e-12);
    assert!(learn::train::TruncationCheck::of(&[]).is_none());
}

/// 8 inputs -> 16 LIF (recurrent or not) -> 2 leaky integrators.
fn small_spec(recurrent: bool) -> NetworkSpec {
    NetworkSpec {
        input_shape: vec![8],
        layers: vec![
            LayerSpec {
                op: OpSpec::Dense { n_out: 16 },
                neurons: lif(0.9),
                recurrent,
                bias: false,
                recurrent_bias: false,
            },
            LayerSpec {
                op: OpSpec::Dense { n_out: 2 },
                neurons: Some(NeuronParams::leaky_integrator(0.9)),
                recurrent: false,
                bias: false,
                recurrent_bias: false,
            },
        ],
    }
}

fn values(t: Tensor<2>) -> Vec<f32> {
    t.to_data().convert::<f32>().try_to_vec::<f32>().unwrap()
}

#[test]
fn neuron_dropout_is_seeded_off_at_zero_and_silences_all_at_one() {
    let _rng = burn_rng();
    let spec = small_spec(false);
    let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, Readout::MaxMembrane).unwrap();
    let device = Device::flex();
    let params = SnnParams::from_weights(&spec, &spec.init(4, 3.0).unwrap(), &device).unwrap();
    let set = toy_set(8, 9);
    let input = learn::train::batch_input(&set, &(0..8).collect::<Vec<_>>(), &device);
    let plain = values(twin.forward(&params, &input).logits);
    assert!(plain.iter().any(|&v| v > 0.0), "the test needs readout activity: {plain:?}");
    assert_eq!(values(twin.forward_dropout(&params, &input, 0.0).logits), plain);
    let dropped = |seed: u64, p: f64| {
        device.seed(seed);
        values(twin.forward_dropout(&params, &input, p).logits)
    };
    assert_eq!(dropped(1, 0.5), dropped(1, 0.5), "the same seed silences the same neurons");
    assert_ne!(dropped(1, 0.5), plain, "half the hidden neurons silenced changes the readout");
    assert!(dropped(2, 1.0 - 1e-9).iter().all(|&v| v == 0.0), "no hidden neuron left, no readout input");
}

/// Whether the average of all four epochs validates better than each of them, with the seeds of
/// `weight_averaging_and_weight_decay` (measured; the test fails if it changes).
const AVERAGE_CHOSEN: bool = false;

#[test]
fn weight_averaging_and_weight_decay() {
    let _rng = burn_rng();
    let spec = small_spec(false);
    let twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, Readout::MaxMembrane).unwrap();
    let (train_set, val) = (toy_set(48, 1), toy_set(16, 2));
    let init = spec.init(3, 1.0).unwrap();
    let base = TrainConfig { epochs: 4, batch_size: 8, lr: 1e-2, seed: 3, ..TrainConfig::default() };
    let plain = train(&twin, &init, &train_set, &val, &base, &mut Silent).unwrap();
    assert_eq!(plain.average, None);
    // averaging watches training without changing it; over one epoch it is that epoch's weights
    let one = train(&twin, &init, &train_set, &val, &TrainConfig { average_epochs: 1, ..base.clone() }, &mut Silent);
    let one = one.unwrap();
    let losses = |h: &[learn::train::EpochReport]| h.iter().map(|e| (e.train_loss, e.val_loss)).collect::<Vec<_>>();
    assert_eq!(losses(&one.history), losses(&plain.history));
    let (accuracy, _) = one.average.unwrap();
    assert_eq!(accuracy, one.history.last().unwrap().val_accuracy);
    let all = train(&twin, &init, &train_set, &val, &TrainConfig { average_epochs: 4, ..base.clone() }, &mut Silent);
    let all = all.unwrap();
    let (accuracy, chosen) = all.average.unwrap();
    // both branches of the choice, each with what it implies (which one this run takes is fixed
    // by the seeds, and asserted last)
    if chosen {
        assert!(accuracy >= plain.best_val_accuracy, "{accuracy} < {}", plain.best_val_accuracy);
        assert_eq!((all.best_epoch, all.best_val_accuracy), (4, accuracy));
        assert_ne!(all.weights, plain.weights, "the average of four epochs is none of them");
    } else {
        assert!(accuracy <= plain.best_val_accuracy, "{accuracy} > {}", plain.best_val_accuracy);
        assert_eq!(
            (&all.weights, all.best_epoch),
            (&plain.weights, plain.best_epoch),
            "an average not chosen changes nothing"
        );
    }
    assert_eq!(losses(&all.history), losses(&plain.history));
    let n_val = val.len() as f64;
    assert_eq!((accuracy * n_val).round() / n_val, accuracy, "a share of the 16 validation samples");
    assert_eq!(
        chosen, AVERAGE_CHOSEN,
        "these seeds' outcome (accuracy {accuracy}, best epoch {})",
        plain.best_val_accuracy
    );
    // decoupled weight decay pulls the weights towards zero
    let norm = |w: &[snn::spec::LayerWeights]| w.iter().flat_map(|l| &l.weight).map(|x| x * x).sum::<f32>();
    let last = |cfg: TrainConfig| {
        let no_val = toy_set(0, 2);
        train(&twin, &init, &train_set, &no_val, &cfg, &mut Silent).unwrap().weights
    };
    let decayed = last(TrainConfig { weight_decay: 5.0, ..base.clone() });
    assert!(norm(&decayed) < 0.5 * norm(&last(base.clone())), "{} vs {}", norm(&decayed), norm(&last(base.clone())));
    // fine-tuning's restraints: a frozen layer keeps its weights, a full pull keeps them all
    let frozen = last(TrainConfig { frozen_layers: vec![0], ..base.clone() });
    assert_eq!(frozen[0], init[0]);
    assert_ne!(frozen[1], init[1], "the readout trains");
    assert_eq!(last(TrainConfig { anchor_decay: 1e6, ..base.clone() }), init);
    let pulled = last(TrainConfig { anchor_decay: 20.0, ..base.clone() });
    let moved = |w: &[snn::spec::LayerWeights]| {
        norm(
            &w.iter()
                .zip(&init)
                .map(|(a, b)| {
                    let mut d = a.clone();
                    d.weight.iter_mut().zip(&b.weight).for_each(|(x, y)| *x -= y);
                    d
                })
                .collect::<Vec<_>>(),
        )
    };
    assert!(moved(&pulled) < moved(&last(base.clone())), "{} vs {}", moved(&pulled), moved(&last(base.clone())));
    for bad in [
        TrainConfig { dropout: 1.0, ..base.clone() },
        TrainConfig { weight_decay: -1.0, ..base.clone() },
        TrainConfig { anchor_decay: -1.0, ..base.clone() },
        TrainConfig { frozen_layers: vec![2], ..base.clone() },
        TrainConfig { frozen_layers: vec![0, 1], ..base.clone() },
        TrainConfig { anchor_decay: 1.0, trainer: learn::train::Trainer::Dense, ..base.clone() },
        TrainConfig { class_balance: 1.5, ..base.clone() },
        TrainConfig { class_balance: -0.5, ..base.clone() },
    ] {
        assert!(train(&twin, &init, &train_set, &val, &bad, &mut Silent).is_err());
    }
}

/// Event counts per input and step (0 to `draws`): the sum of `draws` random spike trains of
/// density `p`, seeded `seed`, `seed + 1`, ...; `[step][input]`, flat.
fn event_counts(seed: u64, draws: u64, steps: usize, n: usize, p: f64) -> Vec<f32> {
    let d: Vec<Vec<f32>> = (0..draws).map(|j| random_input(seed + j, steps, n, p)).collect();
    (0..steps * n).map(|i| d.iter().map(|x| x[i]).sum()).collect()
}

/// `input` (`[step][input]` counts) as a chip takes it: per step, the inputs with events
/// (ascending) and their counts.
fn per_step_counts(input: &[f32], steps: usize, n: usize) -> Vec<(Vec<u32>, Vec<u16>)> {
    (0..steps)
        .map(|t| {
            let row = &input[t * n..(t + 1) * n];
            let ch: Vec<u32> = (0..n as u32).filter(|&i| row[i as usize] > 0.0).collect();
            let ev = ch.iter().map(|&i| row[i as usize] as u16).collect();
            (ch, ev)
        })
        .collect()
}

/// With `chip` Speck, the twin's forward pass is the chip's arithmetic (in float units): its
/// spike-count readout equals `snn::chip::speck`'s on the same integer input, sample by sample.
#[test]
fn speck_twin_reads_out_what_the_speck_chip_reads_out() {
    let _rng = burn_rng();
    let if_layer = |op, reset| LayerSpec {
        op,
        neurons: Some(NeuronParams::integrate_and_fire().with_reset(reset)),
        recurrent: false,
        bias: false,
        recurrent_bias: false,
    };
    for reset in [Reset::Zero, Reset::Subtract] {
        let spec = NetworkSpec {
            input_shape: vec![2, 8, 8],
            layers: vec![
                if_layer(OpSpec::Conv2d { out_channels: 4, kernel: [3, 3], stride: [1, 1], padding: [1, 1] }, reset),
                LayerSpec {
                    op: OpSpec::Pool { kind: PoolKind::Sum, kernel: [2, 2], stride: [2, 2] },
                    neurons: None,
                    recurrent: false,
                    bias: false,
                    recurrent_bias: false,
                },
                if_layer(OpSpec::Dense { n_out: 6 }, reset),
            ],
        };
        let weights = spec.init(3, 2.0).unwrap();
        let net = spec.build(weights.clone()).unwrap();
        let chip = snn::chip::speck::map(&net).unwrap().spec.compile().unwrap();
        let mut twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, Readout::SpikeCount).unwrap();
        twin.chip = Some(snn::chip::Chip::Speck);
        let params = SnnParams::from_weights(&spec, &weights, &Device::flex()).unwrap();
        let (steps, n) = (25, 2 * 8 * 8);
        let (mut spiking, mut agree) = (0, 0);
        for sample in 0..6u64 {
            // event counts per input and step (0 to 3)
            let input = event_counts(100 + 3 * sample, 3, steps, n, 0.15);
            let out = twin.forward(&params, &steps_of(&input, steps, n));
            let counts: Vec<f32> = out.logits.to_data().convert::<f32>().try_into_vec::<f32>().unwrap();
            let per_step = per_step_counts(&input, steps, n);
            let (readout, work) = chip
                .run_sample(
                    per_step.iter().map(|(c, e)| (c.as_slice(), e.as_slice())),
                    snn::chip::xylo::Run::EventDriven,
                )
                .unwrap();
            spiking += (work.output_spikes > 0) as usize;
            agree += (readout == counts) as usize;
            assert_eq!(readout, counts, "sample {sample}, {reset:?}");
        }
        assert!(spiking >= 3, "the test network's outputs spike ({spiking} of 6 samples)");
        assert_eq!(agree, 6);
    }
}

/// With `chip` Loihi 2, the twin's forward pass is Lava's fixed-point LIF in float units (the
/// weights on the chip's 8-bit grid, the integer threshold, 12-bit decays) up to the state's
/// rounding: its max-membrane readout matches `snn::chip::loihi2`'s (taken back to float units)
/// closely and picks the same class, sample by sample.
#[test]
fn loihi2_twin_reads_out_what_the_loihi2_chip_reads_out() {
    let _rng = burn_rng();
    let chip_neurons = |p: NeuronParams| Some(snn::chip::Chip::Loihi2.neurons(p));
    let spec = NetworkSpec {
        input_shape: vec![24],
        layers: vec![
            LayerSpec {
                op: OpSpec::Dense { n_out: 32 },
                neurons: chip_neurons(NeuronParams::cuba_lif(0.9, 0.95)),
                recurrent: true,
                bias: false,
                recurrent_bias: false,
            },
            LayerSpec {
                op: OpSpec::Dense { n_out: 5 },
                neurons: chip_neurons(NeuronParams::leaky_integrator(0.95)),
                recurrent: false,
                bias: false,
                recurrent_bias: false,
            },
        ],
    };
    let weights = spec.init(5, 2.0).unwrap();
    let net = spec.build(weights.clone()).unwrap();
    let mapped = snn::chip::ChipModel::map(
        &net,
        snn::chip::Chip::Loihi2,
        snn::chip::xylo::Quantisation::Global,
        Readout::MaxMembrane,
    )
    .unwrap();
    let chip = mapped.model;
    let mut twin = SnnTwin::new(spec.clone(), Surrogate::FastSigmoid { slope: 10.0 }, Readout::MaxMembrane).unwrap();
    twin.chip = Some(snn::chip::Chip::Loihi2);
    let params = SnnParams::from_weights(&spec, &weights, &Device::flex()).unwrap();
    let (steps, n) = (40, 24);
    let (mut spiking, mut same_class, mut worst) = (0, 0, 0f32);
    for sample in 0..8u64 {
        let input = event_counts(300 + 2 * sample, 2, steps, n, 0.3);
        let out = twin.forward(&params, &steps_of(&input, steps, n));
        let twin_v: Vec<f32> = out.logits.to_data().convert::<f32>().try_into_vec::<f32>().unwrap();
        let per_step = per_step_counts(&input, steps, n);
        let (readout, work) = chip
            .run_sample(per_step.iter().map(|(c, e)| (c.as_slice(), e.as_slice())), snn::chip::xylo::Run::EventDriven)
            .unwrap();
        let chip_v: Vec<f32> = readout.iter().map(|r| r / chip.readout_scale()).collect();
        spiking += (work.spikes_per_layer[0] > 0) as usize;
        let argmax = |v: &[f32]| (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap();
        same_class += (argmax(&twin_v) == argmax(&chip_v)) as usize;
        let range = chip_v.iter().fold(0f32, |m, x| m.max(x.abs())).max(1e-3);
        for (a, b) in twin_v.iter().zip(&chip_v) {
            worst = worst.max((a - b).abs() / range);
        }
    }
    assert!(spiking >= 6, "the hidden layer spikes ({spiking} of 8 samples)");
    assert_eq!(same_class, 8);
    assert!(worst < 0.02, "largest readout difference {worst} of the readout's range");
}
