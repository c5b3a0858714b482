//! The event-driven engine against the time-stepped reference, and its dynamics.

use snn::engine::{Engine, EngineState, Mode};
use snn::network::{Layer, Network, Op, PoolKind, Record, forward_dense, peers_conv, random_input};
use snn::neuron::{Discretisation, LifConfig, NeuronParams, Reset};

/// Hands `steps x n` dense input (1 ms steps) to a stream, input by input, and completes it.
fn feed(engine: &Engine, st: &mut EngineState, input: &[f32], n: usize, steps: usize) {
    for t in 0..steps {
        for i in 0..n {
            let x = input[t * n + i];
            if x != 0.0 {
                engine.push(st, t as i64 * 1_000 + 3, i as u32, x).unwrap();
            }
        }
    }
    engine.finish(st, steps as i64 * 1_000);
}

/// Runs `steps x n` dense input through the engine in stepped mode and returns per-layer spikes
/// per step, as the reference records them.
fn run_stepped(net: &Network, input: &[f32], steps: usize, dt_us: i64) -> (Vec<Vec<Vec<u32>>>, EngineState) {
    let engine = Engine::new(net, dt_us, Mode::Stepped).unwrap();
    let mut st = engine.state(0);
    feed(&engine, &mut st, input, net.n_inputs(), steps);
    // Only the output layer is recorded by the engine; rebuild per-step lists from it.
    let mut out = vec![Vec::new(); steps];
    for &(t_us, i) in &st.output {
        out[(t_us / dt_us) as usize].push(i);
    }
    (vec![out], st)
}

fn assert_same_output(net: &Network, input: &[f32], steps: usize) -> (Record, EngineState) {
    let reference = forward_dense(net, input, steps).unwrap();
    let (engine, st) = run_stepped(net, input, steps, 1_000);
    let last = reference.spikes.len() - 1;
    assert_eq!(engine[0], reference.spikes[last], "output spikes differ");
    for (k, spikes) in reference.spikes.iter().enumerate() {
        let total: usize = spikes.iter().map(Vec::len).sum();
        assert_eq!(st.stats.spikes[k], total as u64, "layer {k} spike count");
    }
    (reference, st)
}

#[test]
fn stepped_equals_dense_on_the_peer_conv_network() {
    let net = peers_conv(1, 5.0);
    for seed in 0..3 {
        let input = random_input(seed, 20, net.n_inputs(), 0.015);
        let (reference, st) = assert_same_output(&net, &input, 20);
        let hidden: usize = reference.spikes[0].iter().map(Vec::len).sum();
        assert!(hidden > 100, "the test needs activity: {hidden} spikes in layer 0");
        assert!(reference.output_counts(26).iter().sum::<u32>() > 0, "and output spikes");
        assert!(st.stats.synops > 0);
    }
}

fn layer(op: Op, p: Option<NeuronParams>) -> Layer {
    Layer { op, neurons: p, recurrent: None, recurrent_bias: None }
}

/// A dense layer without bias of random weights (`dense_w`) and neurons `p`.
fn dense_layer(n_in: usize, n_out: usize, seed: u64, scale: f32, p: NeuronParams) -> Layer {
    layer(Op::Dense { n_in, n_out, weight: dense_w(n_in, n_out, seed, scale), bias: None }, Some(p))
}

fn dense_w(n_in: usize, n_out: usize, seed: u64, scale: f32) -> Vec<f32> {
    random_input(seed, 1, n_in * n_out, 0.5)
        .iter()
        .enumerate()
        .map(|(k, &b)| scale * (b - 0.4) * ((k % 7) as f32 / 7.0 + 0.3))
        .collect()
}

#[test]
fn stepped_equals_dense_with_pooling_recurrence_cuba_if_subtract_and_bias() {
    let conv = Op::Conv2d {
        in_shape: [2, 12, 12],
        out_channels: 4,
        kernel: [3, 3],
        stride: [1, 1],
        padding: [1, 1],
        weight: dense_w(2 * 9, 4, 3, 1.5),
        bias: None,
    };
    let pool = Op::Pool { kind: PoolKind::Sum, in_shape: [4, 12, 12], kernel: [2, 2], stride: [2, 2] };
    let dense = Op::Dense { n_in: 4 * 6 * 6, n_out: 20, weight: dense_w(144, 20, 4, 0.6), bias: None };
    let mut recurrent = Layer {
        op: dense,
        neurons: Some(NeuronParams::cuba_lif(0.6, 0.85).with_reset(Reset::Subtract)),
        recurrent: Some(dense_w(20, 20, 5, 0.8)),
        recurrent_bias: Some((0..20).map(|i| (i as f32 - 9.0) * 0.02).collect()),
    };
    recurrent.neurons.as_mut().unwrap().v_th = 0.8;
    let out =
        Op::Dense { n_in: 20, n_out: 5, weight: dense_w(20, 5, 6, 1.2), bias: Some(vec![0.05, -0.02, 0.1, 0.0, 0.03]) };
    let net = Network::new(
        vec![2, 12, 12],
        vec![
            layer(conv, Some(NeuronParams::lif(0.8).with_reset(Reset::Subtract))),
            layer(pool, None),
            recurrent,
            layer(out, Some(NeuronParams::integrate_and_fire())),
        ],
    )
    .unwrap();
    for seed in 0..5 {
        let input = random_input(100 + seed, 40, net.n_inputs(), 0.08);
        let (reference, _) = assert_same_output(&net, &input, 40);
        let rec: usize = reference.spikes[2].iter().map(Vec::len).sum();
        assert!(rec > 0, "the recurrent layer must be active");
    }
}

#[test]
fn stepped_equals_dense_with_a_recurrent_convolution() {
    // the recurrent input of a convolution is C-order while its state is channel-last
    for (bias, lif) in
        [(None, NeuronParams::lif(0.85)), (Some(vec![0.05, -0.1, 0.02]), NeuronParams::cuba_lif(0.5, 0.8))]
    {
        let conv = Op::Conv2d {
            in_shape: [2, 7, 9],
            out_channels: 3,
            kernel: [3, 3],
            stride: [2, 2],
            padding: [1, 1],
            weight: dense_w(2 * 9, 3, 8, 1.8),
            bias,
        };
        let n = 3 * 4 * 5;
        let recurrent =
            Layer { op: conv, neurons: Some(lif), recurrent: Some(dense_w(n, n, 9, 0.9)), recurrent_bias: None };
        let out = Op::Dense { n_in: n, n_out: 4, weight: dense_w(n, 4, 10, 1.0), bias: None };
        let net = Network::new(vec![2, 7, 9], vec![recurrent, layer(out, Some(NeuronParams::lif(0.9)))]).unwrap();
        let mut without = net.clone();
        without.layers[0].recurrent = None;
        for seed in 0..4 {
            let input = random_input(200 + seed, 30, net.n_inputs(), 0.12);
            let (reference, _) = assert_same_output(&net, &input, 30);
            let plain = forward_dense(&without, &input, 30).unwrap();
            assert!(reference.spikes[0].iter().map(Vec::len).sum::<usize>() > 0, "the convolution must spike");
            assert_ne!(reference.spikes[0], plain.spikes[0], "the recurrence must matter");
        }
    }
}

#[test]
fn async_lif_decays_exactly_between_events() {
    let dense = Op::Dense { n_in: 1, n_out: 1, weight: vec![0.6], bias: None };
    let net = Network::new(vec![1], vec![layer(dense, Some(NeuronParams::lif(0.9)))]).unwrap();
    let engine = Engine::new(&net, 1_000, Mode::Async).unwrap();
    let mut st = engine.state(0);
    engine.push(&mut st, 0, 0, 1.0).unwrap();
    // after 1.5 steps: 0.6 * 0.9^1.5 + 0.6 = 1.1123 > 1: fires at once, at 1500 us
    engine.push(&mut st, 1_500, 0, 1.0).unwrap();
    assert_eq!(st.output, vec![(1_500, 0)]);
    let mut st = engine.state(0);
    engine.push(&mut st, 0, 0, 1.0).unwrap();
    // after 6 steps: 0.6 * 0.9^6 + 0.6 = 0.919: silent
    engine.push(&mut st, 6_000, 0, 1.0).unwrap();
    assert!(st.output.is_empty());
}

#[test]
fn halving_dt_with_matched_time_constants_keeps_the_dynamics() {
    // The same LIF in continuous time (tau 10 ms), run at dt = 1 ms and 0.5 ms on the same input
    // events (on the 1 ms grid): the membrane decays by the same factor per millisecond, so the
    // spikes come at the same times.
    let make = |dt_us: f64| {
        let p = LifConfig::lif(10_000.0).discretise(dt_us, Discretisation::Exact);
        let dense = Op::Dense { n_in: 8, n_out: 4, weight: dense_w(8, 4, 9, 1.0), bias: None };
        Network::new(vec![8], vec![layer(dense, Some(p))]).unwrap()
    };
    let input = random_input(7, 200, 8, 0.2);
    let times = |dt_us: i64| {
        let net = make(dt_us as f64);
        let engine = Engine::new(&net, dt_us, Mode::Stepped).unwrap();
        let mut st = engine.state(0);
        for t in 0..200 {
            for i in 0..8 {
                if input[t * 8 + i] != 0.0 {
                    engine.push(&mut st, t as i64 * 1_000, i as u32, 1.0).unwrap();
                }
            }
        }
        engine.finish(&mut st, 200_000);
        st.output
    };
    let (a, b) = (times(1_000), times(500));
    assert!(a.len() > 10, "{}", a.len());
    assert_eq!(a, b);
}

#[test]
fn streams_do_not_share_state_and_bad_events_are_refused() {
    let net = peers_conv(2, 5.0);
    let engine = Engine::new(&net, 1_000, Mode::Stepped).unwrap();
    let input = random_input(1, 20, net.n_inputs(), 0.015);
    let run = |st: &mut EngineState| feed(&engine, st, &input, net.n_inputs(), 20);
    let (mut a, mut b) = (engine.state(0), engine.state(0));
    run(&mut a);
    run(&mut b);
    assert_eq!(a.output, b.output);
    assert!(engine.push(&mut a, 5_000, 0, 1.0).is_err(), "time went backwards");
    assert!(engine.push(&mut b, 30_000, 99_999, 1.0).is_err(), "no such input");
}

#[test]
fn a_reset_stream_behaves_like_a_fresh_one() {
    let net = peers_conv(3, 7.5);
    let engine = Engine::new(&net, 1_000, Mode::Stepped).unwrap();
    let run = |st: &mut EngineState, seed: u64| {
        feed(&engine, st, &random_input(seed, 20, net.n_inputs(), 0.0075), net.n_inputs(), 20)
    };
    let mut reused = engine.state(0);
    run(&mut reused, 1);
    engine.reset(&mut reused, 0);
    run(&mut reused, 2);
    let mut fresh = engine.state(0);
    run(&mut fresh, 2);
    assert_eq!(reused.output, fresh.output);
    assert_eq!(reused.stats, fresh.stats);
    let reference = forward_dense(&net, &random_input(2, 20, net.n_inputs(), 0.0075), 20).unwrap();
    assert_eq!(fresh.output_counts(26), reference.output_counts(26));
}

#[test]
fn spike_trains_from_the_encoder_run_as_the_dense_reference_does() {
    use encoders::spike_train::{SpikeTrainConfig, SpikeTrainEncoder};
    use encoders::{Event, Polarity, Resolution};
    // Events of a 40x30 sensor pooled by 2 into 2x15x20 inputs, 1 ms steps.
    let sensor = Resolution::new(40, 30);
    let enc = SpikeTrainEncoder::new(SpikeTrainConfig {
        dt_us: 1_000,
        pool: 2,
        sensor,
        mask_cols: None,
        binary: false,
        merge_polarities: false,
    })
    .unwrap();
    let events: Vec<Event> = (0..3_000u32)
        .map(|k| Event::new(k as i64 * 7, (k * 13 % 40) as u16, (k * 7 % 30) as u16, Polarity::from_on(k % 3 == 0)))
        .collect();
    let train = enc.encode(&events, 0, 21);
    let conv = Op::Conv2d {
        in_shape: [2, 15, 20],
        out_channels: 4,
        kernel: [3, 3],
        stride: [2, 2],
        padding: [1, 1],
        weight: dense_w(2 * 9, 4, 8, 0.9),
        bias: None,
    };
    let dense = Op::Dense { n_in: 4 * 8 * 10, n_out: 6, weight: dense_w(320, 6, 9, 0.5), bias: None };
    let net = Network::new(
        vec![2, 15, 20],
        vec![layer(conv, Some(NeuronParams::lif(0.85))), layer(dense, Some(NeuronParams::lif(0.9)))],
    )
    .unwrap();
    let engine = Engine::new(&net, 1_000, Mode::Stepped).unwrap();
    let mut st = engine.state(0);
    engine.run_train(&mut st, &train).unwrap();
    let reference = forward_dense(&net, &train.to_dense(), train.n_steps()).unwrap();
    assert_eq!(st.output_counts(6), reference.output_counts(6));
    assert!(reference.output_counts(6).iter().sum::<u32>() > 0);
    let wrong = enc.encode(&events, 0, 3);
    let small = Engine::new(&net, 500, Mode::Stepped).unwrap();
    assert!(small.run_train(&mut small.state(0), &wrong).is_err());
}

#[test]
fn many_streams_in_parallel_give_what_they_give_one_by_one() {
    use rayon::prelude::*;
    let net = peers_conv(4, 7.5);
    let engine = Engine::new(&net, 1_000, Mode::Stepped).unwrap();
    let n = net.n_inputs();
    let run = |seed: u64| {
        let mut st = engine.state(0);
        feed(&engine, &mut st, &random_input(seed, 20, n, 0.0075), n, 20);
        (st.output, st.stats)
    };
    let sequential: Vec<_> = (0..8).map(run).collect();
    let parallel: Vec<_> = (0..8u64).into_par_iter().map(run).collect();
    assert_eq!(sequential, parallel);
}

#[test]
fn leaky_integrator_readout_equals_dense_in_both_modes() {
    // recurrent CubaLIF hidden layer, then a leaky-integrator readout (never fires)
    let hidden = Layer {
        op: Op::Dense { n_in: 30, n_out: 16, weight: dense_w(30, 16, 11, 1.4), bias: None },
        neurons: Some(NeuronParams::cuba_lif(0.7, 0.9).with_reset(Reset::Subtract)),
        recurrent: Some(dense_w(16, 16, 12, 0.5)),
        recurrent_bias: None,
    };
    let readout = layer(
        Op::Dense { n_in: 16, n_out: 6, weight: dense_w(16, 6, 13, 2.0), bias: None },
        Some(NeuronParams::leaky_integrator(0.95)),
    );
    let net = Network::new(vec![30], vec![hidden, readout]).unwrap();
    for seed in 0..4 {
        let input = random_input(200 + seed, 50, 30, 0.1);
        let reference = forward_dense(&net, &input, 50).unwrap();
        assert_eq!(reference.v_max.len(), 6);
        assert!(reference.v_max.iter().any(|&v| v > 0.0), "the readout must rise");
        assert!(reference.spikes[1].iter().all(Vec::is_empty), "a leaky integrator never fires");
        let (out, st) = run_stepped(&net, &input, 50, 1_000);
        assert!(out[0].iter().all(Vec::is_empty));
        assert_eq!(st.output_v_max(), &reference.v_max[..], "stepped readout differs");
    }
    // async mode: a feed-forward LIF layer into the readout; the maximum follows the membrane
    // after each input, which stepped mode sees at step ends
    let ff = Network::new(
        vec![30],
        vec![
            dense_layer(30, 16, 11, 1.4, NeuronParams::lif(0.9)),
            dense_layer(16, 6, 13, 2.0, NeuronParams::leaky_integrator(0.95)),
        ],
    )
    .unwrap();
    let engine = Engine::new(&ff, 1_000, Mode::Async).unwrap();
    let mut st = engine.state(0);
    let input = random_input(300, 50, 30, 0.1);
    feed(&engine, &mut st, &input, 30, 50);
    assert!(st.output_v_max().iter().any(|&v| v > 0.0));
    // a leaky integrator is a readout only: not in the middle of a network
    let bad = Network::new(
        vec![4],
        vec![
            layer(
                Op::Dense { n_in: 4, n_out: 4, weight: vec![0.1; 16], bias: None },
                Some(NeuronParams::leaky_integrator(0.9)),
            ),
            layer(Op::Dense { n_in: 4, n_out: 2, weight: vec![0.1; 8], bias: None }, Some(NeuronParams::lif(0.9))),
        ],
    );
    assert!(bad.unwrap_err().to_string().contains("readout"));
}

#[test]
fn stepped_equals_dense_with_eight_and_sixteen_channels_leak_subtraction_and_an_identity_conv() {
    // The engine unrolls convolutions of 8 and 16 channels into whole registers, with a path of
    // its own for a resting level of exactly zero; this covers the others: a resting level
    // between zero and threshold, reset by subtraction, IF, and a convolution without neurons.
    let conv = |in_c: usize, hw: usize, out_c: usize, seed: u64, scale: f32| Op::Conv2d {
        in_shape: [in_c, hw, hw],
        out_channels: out_c,
        kernel: [3, 3],
        stride: [1, 1],
        padding: [1, 1],
        weight: dense_w(in_c * 9, out_c, seed, scale),
        bias: None,
    };
    let mut leaky = NeuronParams::lif(0.8).with_reset(Reset::Subtract);
    leaky.v_leak = 0.4;
    let net = Network::new(
        vec![2, 10, 10],
        vec![
            layer(conv(2, 10, 8, 21, 1.6), Some(leaky)),
            layer(conv(8, 10, 16, 22, 0.5), None),
            layer(conv(16, 10, 16, 23, 0.4), Some(NeuronParams::integrate_and_fire().with_reset(Reset::Subtract))),
            layer(
                Op::Dense { n_in: 1600, n_out: 7, weight: dense_w(1600, 7, 24, 0.3), bias: None },
                Some(NeuronParams::lif(0.9)),
            ),
        ],
    )
    .unwrap();
    for seed in 0..4 {
        let input = random_input(200 + seed, 30, net.n_inputs(), 0.05);
        let (reference, _) = assert_same_output(&net, &input, 30);
        for k in [0, 2] {
            let n: usize = reference.spikes[k].iter().map(Vec::len).sum();
            assert!(n > 50, "layer {k} must be active: {n} spikes");
        }
    }
}

#[test]
fn every_neuron_of_eight_and_sixteen_channel_convolutions_firing_at_once_is_kept() {
    // Each channel of a step keeps its spikes in a bucket of one slot per position; here every
    // position of every channel fires in the same steps, so every bucket fills to the brim.
    let conv = |in_c: usize, out_c: usize, w: f32| Op::Conv2d {
        in_shape: [in_c, 6, 6],
        out_channels: out_c,
        kernel: [3, 3],
        stride: [1, 1],
        padding: [1, 1],
        weight: vec![w; in_c * 9 * out_c],
        bias: None,
    };
    let lif = NeuronParams::lif(0.8);
    let net = Network::new(
        vec![2, 6, 6],
        vec![
            layer(conv(2, 8, 2.0), Some(lif)),
            layer(conv(8, 16, 1.5), Some(lif)),
            layer(Op::Dense { n_in: 576, n_out: 5, weight: dense_w(576, 5, 31, 0.2), bias: None }, Some(lif)),
        ],
    )
    .unwrap();
    let steps = 6;
    let input = vec![1.0; steps * net.n_inputs()];
    let (reference, st) = assert_same_output(&net, &input, steps);
    assert!(reference.spikes[0].iter().all(|s| s.len() == 8 * 36), "every layer-0 neuron fires every step");
    assert!(reference.spikes[1].iter().all(|s| s.len() == 16 * 36), "every layer-1 neuron fires every step");
    assert_eq!(st.stats.spikes[0], (steps * 8 * 36) as u64);
}

#[test]
fn a_step_of_more_inputs_than_the_fan_in_takes_at_once_equals_dense() {
    // The input fan-in into a convolution of 8 or 16 channels gathers a step's inputs 128 at a
    // time (asking the cache for each one's targets two inputs ahead): steps of all 288 inputs
    // (graded values) cross the gathering's boundary twice, steps of about half of them once.
    let conv = |out_c: usize, seed: u64| Op::Conv2d {
        in_shape: [2, 12, 12],
        out_channels: out_c,
        kernel: [3, 3],
        stride: [1, 1],
        padding: [1, 1],
        weight: dense_w(2 * 9, out_c, seed, 0.9),
        bias: None,
    };
    for (out_c, seed) in [(8, 51), (16, 52)] {
        let net = Network::new(
            vec![2, 12, 12],
            vec![
                layer(conv(out_c, seed), Some(NeuronParams::lif(0.8))),
                layer(
                    Op::Dense {
                        n_in: out_c * 144,
                        n_out: 6,
                        weight: dense_w(out_c * 144, 6, seed + 10, 0.2),
                        bias: None,
                    },
                    Some(NeuronParams::lif(0.9)),
                ),
            ],
        )
        .unwrap();
        let steps = 8;
        let all: Vec<f32> = (0..steps * net.n_inputs()).map(|k| 0.5 + (k % 5) as f32 * 0.25).collect();
        for input in [all, random_input(seed, steps, net.n_inputs(), 0.5)] {
            let (reference, _) = assert_same_output(&net, &input, steps);
            let n: usize = reference.spikes[0].iter().map(Vec::len).sum();
            assert!(n > 100, "the convolution must be active: {n} spikes");
        }
    }
}

#[test]
fn stepped_equals_dense_with_wide_and_narrow_dense_layers() {
    // a step's spikes into a dense layer: up to 64 outputs summed in registers (the portable
    // code 16 at a time; with AVX2, all of them in 2, 4, 6 or 8 registers of eight: outputs padded
    // to 16, 32, 48 and 64), beyond that row by row
    let net = Network::new(
        vec![30],
        vec![
            dense_layer(30, 90, 41, 1.6, NeuronParams::lif(0.8)),
            dense_layer(90, 70, 42, 1.2, NeuronParams::lif(0.85)),
            dense_layer(70, 37, 43, 1.0, NeuronParams::lif(0.9).with_reset(Reset::Subtract)),
            dense_layer(37, 60, 45, 1.4, NeuronParams::lif(0.9)),
            dense_layer(60, 21, 44, 1.0, NeuronParams::lif(0.9)),
            dense_layer(21, 10, 46, 1.6, NeuronParams::lif(0.9)),
        ],
    )
    .unwrap();
    for seed in 0..4 {
        let input = random_input(200 + seed, 30, net.n_inputs(), 0.3);
        let (reference, _) = assert_same_output(&net, &input, 30);
        for k in 0..5 {
            let fired: usize = reference.spikes[k].iter().map(Vec::len).sum();
            assert!(fired > 0, "layer {k} must fire (seed {seed})");
        }
    }
}

/// A merged ensemble (`spec::ensemble`) of recurrent members: the engine gives each member's
/// spikes side by side, and its synaptic operations are the members' summed, not three times
/// that: a recurrent spike reaches its own member's block, not the zero blocks of the others.
#[test]
fn an_ensembles_recurrent_spikes_cost_their_own_block() {
    use snn::spec::{LayerSpec, NetworkSpec, OpSpec, ensemble};
    let dense = |n_out, neurons, recurrent| LayerSpec {
        op: OpSpec::Dense { n_out },
        neurons: Some(neurons),
        recurrent,
        bias: false,
        recurrent_bias: false,
    };
    let spec = NetworkSpec {
        input_shape: vec![8],
        layers: vec![
            dense(12, NeuronParams::cuba_lif(0.8, 0.9).with_reset(Reset::Subtract), true),
            dense(3, NeuronParams::leaky_integrator(0.95), false),
        ],
    };
    let members: Vec<_> = (1..=3).map(|seed| spec.init(seed, 2.5).unwrap()).collect();
    let (merged, weights) = ensemble(&spec, &members).unwrap();
    let steps = 40;
    let input = random_input(4, steps, 8, 0.3);
    let run = |net: &Network| {
        let engine = Engine::new(net, 1_000, Mode::Stepped).unwrap();
        let mut st = engine.state(0);
        feed(&engine, &mut st, &input, 8, steps);
        st.stats
    };
    let whole = run(&merged.build(weights).unwrap());
    let parts: Vec<_> = members.iter().map(|w| run(&spec.build(w.clone()).unwrap())).collect();
    assert!(parts.iter().all(|s| s.spikes[0] > 20), "the test needs recurrent spikes: {parts:?}");
    assert_eq!(whole.spikes[0], parts.iter().map(|s| s.spikes[0]).sum::<u64>());
    assert_eq!(whole.synops, parts.iter().map(|s| s.synops).sum::<u64>());
}
