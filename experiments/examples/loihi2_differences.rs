//! What each of Loihi 2's differences costs a tactile model, on its validation hold-out (its train
//! split when it was trained without one; never its test split): the float engine as trained, with Loihi 2's neurons (decays rounded to 12
//! bits, reset to zero), with the weights on the chip's 8-bit grid (dequantised from the mapped
//! model), with both, and the chip's own run (Lava's fixed-point arithmetic).
//!
//! `cargo run --release -p experiments --example loihi2_differences -- MODEL DATA_DIR`
//! (for example `models/icub/nir/snn-raw1350.safetensors data/icub_braille/raw1350`)

use experiments::eval::chip::chip_accuracy;
use experiments::eval::tactile::{SplitChoice, encoding_of, load_split, snn_accuracy};
use snn::chip::loihi2::{self, Loihi2Layer};
use snn::chip::xylo::Run;
use snn::chip::{Chip, ChipModel};
use snn::engine::Mode;
use snn::network::{Network, Op};
use std::path::Path;

/// The float weights a chip layer stands for: Lava's values times `2^exp`, over the layer's scale.
fn dequantise(values: &[i16], exp: i8, scale: f32) -> Vec<f32> {
    values.iter().map(|&w| w as f32 * 2f32.powi(exp as i32) / scale).collect()
}

/// `net` with each weighted layer's weights replaced by what the chip holds.
fn on_grid(net: &Network, layers: &[Loihi2Layer]) -> Network {
    let mut out = net.clone();
    let mut chip = layers.iter();
    for l in out.layers.iter_mut() {
        let weight = match &mut l.op {
            Op::Dense { weight, .. } | Op::Conv2d { weight, .. } => weight,
            Op::Pool { .. } => continue,
        };
        let c = chip.next().expect("a chip layer per weighted layer");
        *weight = dequantise(&c.weights, c.weight_exp, c.scale);
        if let (Some(r), Some(q)) = (&mut l.recurrent, &c.recurrent) {
            *r = dequantise(q, c.recurrent_weight_exp, c.scale);
        }
    }
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [model_path, data] = &args[..] else {
        return Err("usage: loihi2_differences MODEL DATA_DIR".into());
    };
    let model_path = Path::new(model_path);
    let model = pipeline::models::load_snn(model_path)?;
    let seed = model.provenance["train"]["seed"].as_u64().unwrap_or(1);
    let fraction = model.provenance["recipe"]["val_fraction"].as_f64().unwrap_or(0.1);
    // a model trained on the whole train split (no hold-out) is read on it, said below
    let split = if fraction > 0.0 { SplitChoice::Validation { fraction, seed } } else { SplitChoice::Train };
    let set = load_split(Path::new(data), &encoding_of(&model, model_path)?, split)?;
    let mapped = loihi2::map(&model.network, model.config.readout)?;
    let mut chip_neurons = model.network.clone();
    for l in chip_neurons.layers.iter_mut() {
        l.neurons = l.neurons.map(|p| Chip::Loihi2.neurons(p));
    }
    let grid = on_grid(&model.network, &mapped.spec.layers);
    let both = on_grid(&chip_neurons, &mapped.spec.layers);
    println!("{} on the {} of {data} ({} samples):", model_path.display(), split.name(), set.len());
    for (what, net) in [
        ("float, as trained", &model.network),
        ("float, Loihi 2's neurons", &chip_neurons),
        ("float, weights on the 8-bit grid", &grid),
        ("float, both", &both),
    ] {
        let s = snn_accuracy(net, &model.config, &set, Mode::Stepped)?;
        println!("  {what:<34} {:.2}%", 100.0 * s.accuracy);
    }
    let chip = ChipModel::Loihi2(mapped.spec.compile()?);
    let (s, _) = chip_accuracy(&chip, &set, Run::EventDriven)?;
    println!("  {:<34} {:.2}%", "Loihi 2 (Lava's arithmetic)", 100.0 * s.accuracy);
    Ok(())
}
