//! A model in a chip's arithmetic on any events (`braille bench --model M --chip xylo`): the
//! network mapped as `braille eval --chip` maps it, the input binned into the chip's steps (input
//! events per channel and step), every step timed; beside it, in the same run, the float engine
//! on the same input ([`super::models::run`], stepped), so that the time per sample of the two
//! is a ratio measured like for like (same network, input and thread).

use super::models::{
    BenchInput, Feed, Latency, ModelBench, accuracy_of, feed, for_each_file_chunk, latency_of, new_histogram,
};
use crate::error::{Error, Result};
use crate::eval::chip::ChipChoice;
use pipeline::network::LoadedNetwork;
use serde::Serialize;
use snn::chip::xylo;
use snn::chip::{ChipModel, ChipState, ChipWork};
use snn::engine::Mode;
use std::time::Instant;

/// What `braille bench --model M --chip C` measures.
#[derive(Debug, Clone, Serialize)]
pub struct ChipBench {
    pub model: String,
    pub chip: ChipChoice,
    pub input: String,
    pub samples: usize,
    pub steps_per_sample: f64,
    /// Input events per sample that reached the chip (at most 15 per channel and step on Xylo).
    pub input_events_per_sample: f64,
    pub synops_per_sample: f64,
    pub spikes_per_sample: f64,
    pub neuron_updates_per_sample: f64,
    /// When the input has labels and the network one output per class.
    pub accuracy: Option<f64>,
    /// One stream, every step timed (its input delivered, the neurons updated): nanoseconds per
    /// step.
    pub step_latency: Latency,
    /// One stream, untimed pass: milliseconds per sample.
    pub ms_per_sample: f64,
    /// The float engine (stepped) on the same input in the same run, one stream, untimed pass.
    pub float: ModelBench,
    pub float_ms_per_sample: f64,
    /// `ms_per_sample / float_ms_per_sample`. The work differs (the chip's neurons send several
    /// spikes per step): compare `synops_per_sample` with the float engine's beside it.
    pub time_ratio: f64,
    pub approximations: Vec<String>,
}

/// The input of one chip step: channels ascending and their event counts.
#[derive(Default)]
struct Step {
    counts: Vec<u16>,
    touched: Vec<u32>,
    channels: Vec<u32>,
    events: Vec<u16>,
}

impl Step {
    fn add(&mut self, i: u32) {
        let c = &mut self.counts[i as usize];
        if *c == 0 {
            self.touched.push(i);
        }
        *c = c.saturating_add(1);
    }

    /// The channels and counts gathered, ascending; then empty again.
    fn take(&mut self) -> (&[u32], &[u16]) {
        self.touched.sort_unstable();
        self.channels.clear();
        self.events.clear();
        for &i in &self.touched {
            self.channels.push(i);
            self.events.push(std::mem::take(&mut self.counts[i as usize]));
        }
        self.touched.clear();
        (&self.channels, &self.events)
    }
}

/// One stream's pass: per step timed or not.
struct Pass {
    latency: hdrhistogram::Histogram<u64>,
    steps: u64,
    stats: ChipWork,
    readouts: Vec<(Vec<f32>, Option<usize>)>,
}

/// Runs the events of one stream, `(t_us, input)` in time order from `t0_us` to `end_us`, as
/// steps of `dt_us`.
struct Stepper<'a> {
    chip: &'a ChipModel,
    dt_us: i64,
    t0_us: i64,
    /// The step being gathered.
    step: i64,
    input: Step,
    st: ChipState,
    run: xylo::Run,
    per_step: bool,
}

impl Stepper<'_> {
    fn run_step(&mut self, out: &mut Pass) -> Result<()> {
        let (c, e) = self.input.take();
        if self.per_step {
            let t0 = Instant::now();
            self.chip.step(&mut self.st, c, e, self.run)?;
            out.latency.saturating_record((t0.elapsed().as_nanos() as u64).max(1));
        } else {
            self.chip.step(&mut self.st, c, e, self.run)?;
        }
        out.steps += 1;
        self.step += 1;
        Ok(())
    }

    fn push(&mut self, events: &[(i64, u32)], out: &mut Pass) -> Result<()> {
        let n_in = self.chip.n_in() as u32;
        for &(t, i) in events {
            if i >= n_in {
                return Err(Error::Setting {
                    name: "input",
                    value: i.to_string(),
                    expected: "an input of the chip's network",
                });
            }
            let k = (t - self.t0_us).div_euclid(self.dt_us);
            while self.step < k {
                self.run_step(out)?;
            }
            self.input.add(i);
        }
        Ok(())
    }

    /// Steps up to `end_us` (the step holding `end_us - 1` included) and reads out.
    fn finish(&mut self, end_us: i64, label: Option<usize>, out: &mut Pass) -> Result<()> {
        let last = (end_us - 1 - self.t0_us).div_euclid(self.dt_us);
        while self.step <= last {
            self.run_step(out)?;
        }
        // Loihi 2's latency: steps without input until the output has answered the last input
        for _ in 0..self.chip.drain_steps() {
            self.run_step(out)?;
        }
        let s = ChipModel::work(&self.st);
        let o = &mut out.stats;
        o.input_events += s.input_events;
        o.synops += s.synops;
        o.spikes += s.spikes;
        o.output_spikes += s.output_spikes;
        o.neuron_updates += s.neuron_updates;
        out.readouts.push((self.chip.readout(&self.st), label));
        Ok(())
    }

    fn restart(&mut self, t0_us: i64) {
        self.st = self.chip.state();
        self.t0_us = t0_us;
        self.step = 0;
    }
}

fn pass(chip: &ChipModel, dt_us: i64, run: xylo::Run, feed: &Feed, per_step: bool) -> Result<Pass> {
    let mut out = Pass { latency: new_histogram(), steps: 0, stats: Default::default(), readouts: Vec::new() };
    let input = Step { counts: vec![0; chip.n_in()], ..Default::default() };
    let mut s = Stepper { chip, dt_us, t0_us: 0, step: 0, input, st: chip.state(), run, per_step };
    match feed {
        Feed::Samples(samples) => {
            for sample in samples {
                s.restart(0);
                s.push(&sample.events, &mut out)?;
                s.finish(sample.end_us, sample.label, &mut out)?;
            }
        }
        Feed::File { path, map, time_scale } => {
            let mut started = false;
            let end = for_each_file_chunk(path, map, *time_scale, |chunk| {
                if !started {
                    s.restart(chunk.first().map_or(0, |e| e.0));
                    started = true;
                }
                s.push(chunk, &mut out)
            })?;
            if !started {
                s.restart(0);
            }
            s.finish(end.max(s.t0_us + 1), None, &mut out)?;
        }
    }
    Ok(out)
}

/// Benchmarks `net` mapped to `choice`'s chip on `input` (one stream), and the float engine on
/// the same input in the same run.
pub fn run(net: &LoadedNetwork, model: &str, input: &BenchInput, choice: ChipChoice) -> Result<ChipBench> {
    let wrap = |source: snn::Error| Error::Engine { what: model.to_string(), source, hint: "" };
    let mapped = ChipModel::map(&net.network, choice.chip, choice.quantisation, net.readout).map_err(wrap)?;
    let chip = &mapped.model;
    let (feed, what) = feed(net, input)?;
    // warm up, and the work and readouts (identical in every pass)
    let warm = pass(chip, net.dt_us, choice.run, &feed, false)?;
    let n = warm.readouts.len().max(1) as f64;
    let accuracy = accuracy_of(&warm.readouts);
    let timed = pass(chip, net.dt_us, choice.run, &feed, true)?;
    let t0 = Instant::now();
    pass(chip, net.dt_us, choice.run, &feed, false)?;
    let ms_per_sample = 1e3 * t0.elapsed().as_secs_f64() / n;
    let float = super::models::run(net, model, input, Mode::Stepped, 1)?;
    let float_ms_per_sample = 1e3 * float.input_events_per_sample / float.input_events_per_s.max(1e-12);
    let s = &warm.stats;
    Ok(ChipBench {
        model: model.to_string(),
        chip: choice,
        input: what,
        samples: warm.readouts.len(),
        steps_per_sample: warm.steps as f64 / n,
        input_events_per_sample: s.input_events as f64 / n,
        synops_per_sample: s.synops as f64 / n,
        spikes_per_sample: s.spikes as f64 / n,
        neuron_updates_per_sample: s.neuron_updates as f64 / n,
        accuracy,
        step_latency: latency_of(&timed.latency),
        ms_per_sample,
        float_ms_per_sample,
        time_ratio: ms_per_sample / float_ms_per_sample,
        float,
        approximations: mapped.approximations.clone(),
    })
}

/// The text `braille bench --chip` prints.
impl std::fmt::Display for ChipBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} in {}'s arithmetic ({:?} quantisation, {:?} run) on {}: {:.0} steps, {:.1} input events, {:.0} synops, {:.1} spikes, {:.0} neuron updates per sample{}",
            self.model,
            self.chip.chip,
            self.chip.quantisation,
            self.chip.run,
            self.input,
            self.steps_per_sample,
            self.input_events_per_sample,
            self.synops_per_sample,
            self.spikes_per_sample,
            self.neuron_updates_per_sample,
            self.accuracy.map_or(String::new(), |a| format!("; accuracy {:.2}%", 100.0 * a))
        )?;
        let l = &self.step_latency;
        writeln!(
            f,
            "one stream: per step {:.0} ns (p50), {:.0} ns (p99), {:.0} ns at most; {:.3} ms per sample",
            l.p50_ns, l.p99_ns, l.max_ns, self.ms_per_sample
        )?;
        writeln!(
            f,
            "the float engine (stepped) on the same input, same run: {:.3} ms per sample, {:.0} synops per sample{}; {} / float: {:.2}x the time",
            self.float_ms_per_sample,
            self.float.synops_per_sample,
            self.float.accuracy.map_or(String::new(), |a| format!(", accuracy {:.2}%", 100.0 * a)),
            self.chip.chip,
            self.time_ratio
        )?;
        for a in &self.approximations {
            writeln!(f, "  mapping: {a}")?;
        }
        Ok(())
    }
}
