//! The networks that read the reader's windows: the ResNet (batch of one, on burn's CPU
//! backend) and the SNN (stepped, one step per frame, either sharing its first layer's work
//! between overlapping windows or on the event-driven engine), with their work counted. Both
//! architectures get identical windows of identical streams.

use crate::error::{Error, Result};
use crate::input::CharInput;
use crate::reader::{Window, WindowClassifier};
use learn::resnet::Resnet;
use serde::{Deserialize, Serialize};
use snn::engine::{Engine, EngineState, Mode};
use snn::model_file::{Readout, SnnModel};
use snn::sliding::{RunScratch, Sliding};
use std::time::Instant;

/// How the SNN reads a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SnnRunner {
    /// The first layer's synaptic currents are computed once per frame and shared by the
    /// overlapping windows (`snn::sliding`); exactly the trained network's output.
    Sliding,
    /// Every window runs on the event-driven engine (stepped mode) from rest.
    Engine,
}

/// Per bin of the stream: its events cropped and pooled to the model's grid, `(polarity, row,
/// col, count)`, and the layer-0 currents already made from them (per vertical shift).
struct BinCache {
    t_end_us: i64,
    cells: Vec<(usize, usize, usize, f32)>,
    /// Events and their sum of rows (for the vertical centring).
    mass: f64,
    moment: f64,
    currents: Vec<(i64, Vec<f32>)>,
}

#[allow(clippy::large_enum_variant)] // one per model: the size does not matter
enum Runner {
    Resnet {
        model: Resnet,
        input: CharInput,
    },
    Engine {
        model: SnnModel,
        input: CharInput,
        engine: Engine,
        state: EngineState,
    },
    Sliding {
        model: SnnModel,
        input: CharInput,
        net: Sliding,
        bins: std::collections::VecDeque<BinCache>,
        scratch: Vec<f32>,
        run: RunScratch,
    },
}

/// A trained network that reads windows, with its work counted.
pub struct WindowModel {
    runner: Runner,
    classes: Vec<String>,
    /// Windows read, synaptic operations (SNN), time spent.
    pub calls: u64,
    pub synops: u64,
    pub nanos: u64,
    /// The time of each call (bounded memory).
    pub latency: Histogram,
}

/// Durations in logarithmic buckets (four per octave, 1 ns to about 4 s): percentiles within 19%,
/// in constant memory however many calls.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Histogram {
    /// `counts[k]` holds durations in `[2^(k/4), 2^((k+1)/4))` ns.
    pub counts: Vec<u64>,
}

impl Default for Histogram {
    fn default() -> Self {
        Histogram { counts: vec![0; 128] }
    }
}

impl Histogram {
    pub fn add(&mut self, ns: u64) {
        let k = ((ns.max(1) as f64).log2() * 4.0).floor() as usize;
        let last = self.counts.len() - 1;
        self.counts[k.min(last)] += 1;
    }

    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    /// The lower edge (ns) of bucket `k`.
    pub fn edge_ns(k: usize) -> f64 {
        2f64.powf(k as f64 / 4.0)
    }

    /// The `q`-quantile (0-1), as its bucket's geometric middle, in ns; `None` when empty.
    pub fn quantile_ns(&self, q: f64) -> Option<f64> {
        let n = self.total();
        if n == 0 {
            return None;
        }
        let target = ((q.clamp(0.0, 1.0) * n as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (k, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= target {
                return Some((Self::edge_ns(k) * Self::edge_ns(k + 1)).sqrt());
            }
        }
        None
    }

    pub fn merge(&mut self, other: &Histogram) {
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
    }
}

impl WindowModel {
    /// A ResNet (in evaluation mode) whose input is made as `input` says.
    pub fn resnet(model: Resnet, input: CharInput, classes: Vec<String>) -> WindowModel {
        WindowModel {
            runner: Runner::Resnet { model, input },
            classes,
            calls: 0,
            synops: 0,
            nanos: 0,
            latency: Histogram::default(),
        }
    }

    /// An SNN whose input spikes are made as `input` says.
    pub fn snn(model: SnnModel, input: CharInput, runner: SnnRunner) -> Result<WindowModel> {
        let n = 2 * input.shape()[1] * input.shape()[2];
        if model.network.n_inputs() != n {
            return Err(Error::Config(format!(
                "the preparation gives {n} inputs, the network takes {}",
                model.network.n_inputs()
            )));
        }
        let net_err = |e: snn::Error| Error::Config(e.to_string());
        let classes = model.classes.clone();
        let runner = match runner {
            SnnRunner::Engine => {
                let engine = Engine::new(&model.network, model.config.dt_us, Mode::Stepped).map_err(net_err)?;
                let state = engine.state(0);
                Runner::Engine { model, input, engine, state }
            }
            SnnRunner::Sliding => Runner::Sliding {
                net: Sliding::new(&model.network).map_err(net_err)?,
                model,
                input,
                bins: Default::default(),
                scratch: Vec::new(),
                run: RunScratch::default(),
            },
        };
        Ok(WindowModel { runner, classes, calls: 0, synops: 0, nanos: 0, latency: Histogram::default() })
    }

    /// A ResNet model file (`braille train --arch resnet`).
    pub fn load_resnet(path: &std::path::Path) -> Result<WindowModel> {
        let bad = |what: String| Error::Config(format!("{}: {what}", path.display()));
        let f = snn::model_file::ModelFile::read(path, snn::model_file::Arch::Resnet)
            .map_err(|e| Error::Config(e.to_string()))?;
        let config: learn::resnet::ResnetConfig =
            serde_json::from_value(f.config.clone()).map_err(|e| bad(format!("header `config`: {e}")))?;
        let input: CharInput =
            serde_json::from_value(f.preprocess.clone()).map_err(|e| bad(format!("header `preprocess`: {e}")))?;
        if input.shape() != config.input {
            return Err(bad(format!(
                "the preprocessing gives {:?}, the network takes {:?}",
                input.shape(),
                config.input
            )));
        }
        if f.classes.len() != config.classes {
            return Err(bad(format!("{} class names for a network of {} outputs", f.classes.len(), config.classes)));
        }
        let model = learn::resnet::from_tensors(&config, &f.tensors).map_err(bad)?;
        Ok(WindowModel::resnet(model, input, f.classes))
    }

    /// An SNN model file trained on simulated windows (`braille train --arch snn` without `--data`).
    pub fn load_snn(path: &std::path::Path, runner: SnnRunner) -> Result<WindowModel> {
        let bad = |what: String| Error::Config(format!("{}: {what}", path.display()));
        let model = SnnModel::load(path).map_err(|e| Error::Config(e.to_string()))?;
        let input: CharInput = serde_json::from_value(model.preprocess.clone())
            .map_err(|e| bad(format!("header `preprocess` is not a character-window input: {e}")))?;
        WindowModel::snn(model, input, runner).map_err(|e| bad(e.to_string()))
    }

    pub fn classes(&self) -> &[String] {
        &self.classes
    }

    pub fn input(&self) -> &CharInput {
        match &self.runner {
            Runner::Resnet { input, .. } | Runner::Engine { input, .. } | Runner::Sliding { input, .. } => input,
        }
    }
}

fn softmax(v: &[f32]) -> Vec<f32> {
    let m = v.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let e: Vec<f32> = v.iter().map(|x| (x - m).exp()).collect();
    let s: f32 = e.iter().sum();
    e.into_iter().map(|x| x / s).collect()
}

/// A bin's cells cropped and pooled as [`CharInput::crop_window`] does, in
/// ascending (polarity, row, column) order; `scratch` is a zeroed grid of the crop.
fn crop_bin(
    input: &CharInput,
    cells: &[crate::reader::Cell],
    height: usize,
    width: usize,
    scratch: &mut Vec<f32>,
) -> Vec<(usize, usize, usize, f32)> {
    let [_, h, w] = input.shape();
    scratch.resize(2 * h * w, 0.0);
    let mut touched: Vec<usize> = Vec::new();
    for c in cells {
        if let Some(j) = input.crop_cell(c.input, height, width) {
            if scratch[j] == 0.0 {
                touched.push(j);
            }
            scratch[j] += c.count;
        }
    }
    touched.sort_unstable();
    touched
        .into_iter()
        .map(|j| {
            let v = std::mem::take(&mut scratch[j]);
            (j / (h * w), (j / w) % h, j % w, v)
        })
        .collect()
}

impl WindowModel {
    fn sliding(&mut self, w: &Window) -> Result<Vec<f32>> {
        let Runner::Sliding { model, input, net, bins, scratch, run } = &mut self.runner else {
            unreachable!("called for the sliding runner only")
        };
        let [_, h, wd] = input.shape();
        let n = w.n_bins();
        // the window's bins, cropped once each (the cache holds consecutive bins)
        let first = w.t_end_us - (n as i64 - 1) * w.bin_us;
        while bins.front().is_some_and(|b| b.t_end_us < first) {
            bins.pop_front();
        }
        if bins.front().is_some_and(|b| b.t_end_us != first) {
            bins.clear();
        }
        for (k, cells) in w.bins().enumerate() {
            let t = first + k as i64 * w.bin_us;
            if bins.back().is_none_or(|b| b.t_end_us < t) {
                let cells = crop_bin(input, cells, w.height, w.width, scratch);
                let (mass, moment) = cells
                    .iter()
                    .fold((0f64, 0f64), |(m, r), &(_, row, _, c)| (m + c as f64, r + c as f64 * row as f64));
                bins.push_back(BinCache { t_end_us: t, cells, mass, moment, currents: Vec::new() });
            }
        }
        if bins.len() != n {
            return Err(Error::Config("the window's bins are not consecutive".into()));
        }
        // the vertical centring of the whole window, as `CharInput::spikes` does it
        let shift = if input.preprocess.normalises() {
            let (mass, moment) = bins.iter().fold((0f64, 0f64), |(m, r), b| (m + b.mass, r + b.moment));
            if mass > 0.0 { ((h as f64 - 1.0) / 2.0 - moment / mass).round() as i64 } else { 0 }
        } else {
            0
        };
        let mut active = Vec::new();
        for b in bins.iter_mut() {
            if b.currents.iter().all(|c| c.0 != shift) {
                active.clear();
                for &(pol, r, col, c) in &b.cells {
                    let r = r as i64 + shift;
                    if (0..h as i64).contains(&r) {
                        active.push((((pol * h + r as usize) * wd + col) as u32, c));
                    }
                }
                active.sort_unstable_by_key(|a| a.0);
                let mut cur = Vec::new();
                self.synops += net.currents(&active, &mut cur).map_err(|e| Error::Config(e.to_string()))?;
                b.currents.push((shift, cur));
            }
        }
        let steps: Vec<&[f32]> = bins
            .iter()
            .map(|b| b.currents.iter().find(|c| c.0 == shift).map(|c| c.1.as_slice()).unwrap_or(&[]))
            .collect();
        let out = net.run_with(&steps, run);
        self.synops += out.synops;
        Ok(match model.config.readout {
            Readout::MaxMembrane => softmax(&out.v_max),
            Readout::SpikeCount => softmax(&out.counts.iter().map(|&c| c as f32).collect::<Vec<_>>()),
        })
    }
}

impl WindowClassifier for WindowModel {
    fn start_stream(&mut self) {
        if let Runner::Sliding { bins, .. } = &mut self.runner {
            bins.clear();
        }
    }

    fn classify(&mut self, w: &Window) -> Result<Vec<f32>> {
        let t = Instant::now();
        let p = match &mut self.runner {
            Runner::Resnet { model, input } => {
                let image = input.crop_window(w)?;
                let x = input.prepare(&image, None);
                learn::resnet::probabilities(model, input.shape(), &[&x]).remove(0)
            }
            Runner::Engine { model, input, engine, state } => {
                let image = input.crop_window(w)?;
                let train = input.spikes(&image, model.config.dt_us);
                engine.run_train(state, &train).map_err(|e| Error::Config(e.to_string()))?;
                self.synops += state.stats.synops;
                match model.config.readout {
                    Readout::MaxMembrane => softmax(state.output_v_max()),
                    Readout::SpikeCount => {
                        let c: Vec<f32> =
                            state.output_counts(engine.n_outputs()).into_iter().map(|c| c as f32).collect();
                        softmax(&c)
                    }
                }
            }
            Runner::Sliding { .. } => self.sliding(w)?,
        };
        let ns = t.elapsed().as_nanos() as u64;
        self.calls += 1;
        self.nanos += ns;
        self.latency.add(ns);
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_quantiles_fall_in_their_bucket() {
        let mut h = Histogram::default();
        assert_eq!(h.quantile_ns(0.5), None);
        for ns in [1_000u64, 1_000, 1_000, 50_000] {
            h.add(ns);
        }
        let p50 = h.quantile_ns(0.5).unwrap();
        assert!((840.0..1_190.0).contains(&p50), "{p50}");
        let p99 = h.quantile_ns(0.99).unwrap();
        assert!((42_000.0..59_500.0).contains(&p99), "{p99}");
        let mut g = Histogram::default();
        g.merge(&h);
        assert_eq!(g.total(), 4);
    }
}
