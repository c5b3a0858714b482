//! What each of Xylo's differences costs the Xylo model, on the raw1350 **train** split (never
//! its test split): a float emulation of the two-layer network with one difference at a time
//! (several spikes per step with subtraction, Xylo's order of synaptic decay, the one-step delay
//! to the outputs, the output synapse, decays rounded to bit shifts), all of them together, and
//! the fixed-point run at each ceiling on hidden thresholds (the mapper's `THRESHOLD_BITS`).
//!
//! `cargo run --release -p experiments --example xylo_differences`

use encoders::spike_train::SpikeTrain;
use experiments::eval::chip::chip_accuracy;
use experiments::eval::tactile::{SplitChoice, encoding_of, load_split};
use snn::chip::xylo::{self, Quantisation, Run, dash_of, decay_of};
use snn::network::{Network, Op};
use std::path::Path;

/// Which of Xylo's differences the emulation takes.
#[derive(Clone, Copy, Default)]
struct Differences {
    multi_spike: bool,
    decay_after_input: bool,
    output_delay: bool,
    output_synapse: bool,
    rounded_decays: bool,
}

/// The class the float emulation reads (highest output membrane).
fn read(net: &Network, t: &SpikeTrain, d: Differences) -> usize {
    let (Op::Dense { n_in, n_out: nh, weight: w0, .. }, Op::Dense { n_out: no, weight: w1, .. }) =
        (&net.layers[0].op, &net.layers[1].op)
    else {
        panic!("the Xylo model is dense, two layers")
    };
    let (p0, p1) = (net.layers[0].neurons.unwrap(), net.layers[1].neurons.unwrap());
    let round = |x: f32| if d.rounded_decays { decay_of(dash_of(x)) } else { x };
    let (a0, b0, b1) = (round(p0.alpha), round(p0.beta), round(p1.beta));
    let (mut i, mut v, mut s, mut prev) = (vec![0f32; *nh], vec![0f32; *nh], vec![0f32; *nh], vec![0f32; *nh]);
    let (mut io, mut vo, mut best) = (vec![0f32; *no], vec![0f32; *no], vec![0f32; *no]);
    for k in 0..t.n_steps() {
        let (channels, events) = t.step(k);
        let mut u = vec![0f32; *nh];
        for (&c, &n) in channels.iter().zip(events) {
            for (o, x) in u.iter_mut().enumerate() {
                *x += w0[o * n_in + c as usize] * n as f32;
            }
        }
        for o in 0..*nh {
            // with the mapper's gain 1 / alpha, Xylo's alpha (i + u / alpha) is the float order
            i[o] = if d.decay_after_input { a0 * (i[o] + u[o] / a0) } else { a0 * i[o] + u[o] };
            v[o] = b0 * v[o] + i[o];
            s[o] = 0.0;
            if d.multi_spike {
                while v[o] > 1.0 && s[o] < 31.0 {
                    s[o] += 1.0;
                    v[o] -= 1.0;
                }
            } else if v[o] > 1.0 {
                s[o] = 1.0;
                v[o] = 0.0;
            }
        }
        let src = if d.output_delay { &prev } else { &s };
        for o in 0..*no {
            let uo: f32 = (0..*nh).map(|j| w1[o * nh + j] * src[j]).sum();
            let x = if d.output_synapse {
                io[o] = 0.5 * (io[o] + uo);
                io[o]
            } else {
                uo
            };
            vo[o] = b1 * vo[o] + x;
            best[o] = best[o].max(vo[o]);
        }
        prev.copy_from_slice(&s);
    }
    (0..*no).max_by(|&a, &b| best[a].total_cmp(&best[b])).unwrap_or(0)
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let path = root.join("models/icub/chip/xylo-braille7.safetensors");
    let model = pipeline::models::load_snn(&path).expect("the Xylo model");
    let enc = encoding_of(&model, &path).expect("its encoding");
    let set = load_split(&root.join("data/icub_braille/raw1350"), &enc, SplitChoice::Train).expect("raw1350");
    let none = Differences::default();
    let all = Differences {
        multi_spike: true,
        decay_after_input: true,
        output_delay: true,
        output_synapse: true,
        rounded_decays: true,
    };
    let rows = [
        ("float, as trained", none),
        ("several spikes per step, subtracting", Differences { multi_spike: true, ..none }),
        ("synaptic decay after the input", Differences { decay_after_input: true, ..none }),
        ("outputs one step later", Differences { output_delay: true, ..none }),
        ("output synapse (dash 1)", Differences { output_synapse: true, ..none }),
        ("decays rounded to bit shifts", Differences { rounded_decays: true, ..none }),
        ("all of them", all),
        ("all but several spikes per step", Differences { multi_spike: false, ..all }),
    ];
    println!("raw1350 train split, {} samples, float emulation:", set.len());
    for (name, d) in rows {
        let correct = set.trains.iter().zip(&set.labels).filter(|(t, l)| read(&model.network, t, d) == **l).count();
        println!("  {name}: {:.2}%", 100.0 * correct as f64 / set.len() as f64);
    }
    println!("Xylo's fixed-point arithmetic, global quantisation, by ceiling on hidden thresholds:");
    for bits in 8..=14u8 {
        let mapped = xylo::map_with(&model.network, Quantisation::Global, bits).expect("maps");
        let chip = snn::chip::ChipModel::Xylo(Box::new(mapped.spec.clone().compile().expect("compiles")));
        let (s, _) = chip_accuracy(&chip, &set, Run::EventDriven).expect("runs");
        println!("  2^{bits} (weight shift {}): {:.2}%", mapped.spec.weight_shift_in, 100.0 * s.accuracy);
    }
}
