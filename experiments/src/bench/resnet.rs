//! A ResNet model file's inference time (`braille bench --model RESNET`): windows of the model's
//! input shape (random, at a chosen density, or cut from simulated scans of a board as the reader
//! cuts them), at batch 1 on one thread and at batch N on T threads, on our folded path
//! ([`learn::resnet::folded`], the reader's) and on burn's `flex` backend in the same run, with
//! the largest difference of their logits. The peer side (the same network in PyTorch) is
//! `scripts/peers/resnet.sh`.

use crate::Progress;
use crate::error::{Error, Result};
use learn::resnet::ResnetConfig;
use learn::resnet::folded::FoldedResnet;
use pipeline::models::ResnetModel;
use rand::{Rng, SeedableRng};
use serde::Serialize;
use std::time::Instant;

/// Which windows are fed.
#[derive(Debug, Clone)]
pub enum Windows {
    /// `count` random windows with `density` of their cells non-zero (counts 1-4, as a heat
    /// map's), seeded.
    Random { count: usize, density: f64, seed: u64 },
    /// The windows the labeler cuts from one trial of `board`'s rows (SIMULATED, `realism`, the
    /// test sensor builds, 8 mm/s, 1.5 mm), prepared as the model was trained.
    Board { board: sim::BoardKind, realism: sim::Realism },
}

/// What to time.
#[derive(Debug, Clone)]
pub struct ResnetBenchSpec {
    pub windows: Windows,
    /// Batch of the second measurement (the first is batch 1 on one thread).
    pub batch: usize,
    /// Threads of the second measurement.
    pub threads: usize,
    /// Passes over the windows; the median pass is reported.
    pub repeats: usize,
}

/// One path's time.
#[derive(Debug, Clone, Serialize)]
pub struct PathTiming {
    /// Median over the passes of a pass's time per window.
    pub ms_per_window: f64,
    /// Fastest and slowest pass.
    pub ms_per_window_min: f64,
    pub ms_per_window_max: f64,
    pub windows_per_s: f64,
    /// The dense network's multiply-accumulates per second (a scattering stem does fewer).
    pub macs_per_s: f64,
}

/// Both paths at one batch and thread count, timed in the same run.
#[derive(Debug, Clone, Serialize)]
pub struct BatchRow {
    pub batch: usize,
    pub threads: usize,
    pub folded: PathTiming,
    /// Ours with every dense convolution by im2col and `gemm` (the path of a CPU without AVX2
    /// and FMA), when `folded` computed some directly.
    pub folded_im2col: Option<PathTiming>,
    pub burn: PathTiming,
    /// burn's time over ours (above 1: ours is faster).
    pub burn_over_folded: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct ResnetBench {
    pub model: String,
    /// `[channels, height, width]`.
    pub input: [usize; 3],
    pub windows: usize,
    /// Where the windows came from.
    pub source: String,
    /// Share of non-zero input cells over the windows.
    pub density: f64,
    pub macs_per_window: u64,
    /// Whether ours computed the qualifying convolutions directly (AVX2 and FMA here).
    pub direct_convolution: bool,
    pub rows: Vec<BatchRow>,
    /// The largest difference between the two paths' logits over every window.
    pub max_abs_logit_difference: f32,
    /// The same relative to the logit's size (`|ours - burn| / max(1, |burn|)`).
    pub max_rel_logit_difference: f32,
    pub repeats: usize,
}

impl std::fmt::Display for ResnetBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{}: input {:?}, {} windows ({}, {:.2}% of cells non-zero), {} MACs a window",
            self.model,
            self.input,
            self.windows,
            self.source,
            100.0 * self.density,
            self.macs_per_window
        )?;
        for r in &self.rows {
            writeln!(
                f,
                "batch {} on {} thread(s): ours {:.3} ms a window ({:.0} windows/s, {:.2} dense GMAC/s), burn {:.3} ms: burn / ours {:.2}x",
                r.batch,
                r.threads,
                r.folded.ms_per_window,
                r.folded.windows_per_s,
                r.folded.macs_per_s / 1e9,
                r.burn.ms_per_window,
                r.burn_over_folded
            )?;
            if let Some(t) = &r.folded_im2col {
                writeln!(
                    f,
                    "  ours with the direct convolution switched off (im2col and gemm throughout): {:.3} ms a window, {:.2}x ours",
                    t.ms_per_window,
                    t.ms_per_window / r.folded.ms_per_window
                )?;
            }
        }
        writeln!(
            f,
            "largest logit difference, ours against burn: {:.2e} ({:.2e} of the logit)",
            self.max_abs_logit_difference, self.max_rel_logit_difference
        )
    }
}

fn windows(m: &ResnetModel, w: &Windows, progress: &dyn Progress) -> Result<(Vec<Vec<f32>>, String)> {
    match w {
        Windows::Random { count, density, seed } => {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(*seed);
            let size: usize = m.config.input.iter().product();
            let ims = (0..*count)
                .map(|_| {
                    (0..size)
                        .map(|_| if rng.random_bool(*density) { rng.random_range(1..=4) as f32 } else { 0.0 })
                        .collect()
                })
                .collect();
            Ok((ims, format!("random, seed {seed}")))
        }
        Windows::Board { board, realism } => {
            let spec = corpus::windows::CharSetSpec {
                boards: vec![board.clone()],
                speed_mm_s: 8.0,
                depth_mm: 1.5,
                trials: 1,
                seed: corpus::world::TEST_SEED,
                task: corpus::windows::Task::for_classes(m.config.classes),
                jitter_ms: 0.0,
                world: corpus::World::test(*realism),
                blank_cells: false,
                sweep: None,
            };
            let (raw, _) = corpus::windows::build(&spec, &m.input, progress)?;
            let ims = raw.data.iter().map(|d| m.input.prepare(d)).collect();
            Ok((ims, format!("SIMULATED {} at 8 mm/s, 1.5 mm, {realism:?}", corpus::boards::board_name(board))))
        }
    }
}

/// Times `f` over `ims` in batches of `batch`, `repeats` passes: (median, min, max) ms a window.
fn time_passes(ims: &[&[f32]], batch: usize, repeats: usize, mut f: impl FnMut(&[&[f32]])) -> (f64, f64, f64) {
    f(&ims[..batch.min(ims.len())]); // warm up
    let mut passes: Vec<f64> = (0..repeats.max(1))
        .map(|_| {
            let t = Instant::now();
            for chunk in ims.chunks(batch) {
                f(chunk);
            }
            t.elapsed().as_secs_f64() * 1e3 / ims.len() as f64
        })
        .collect();
    passes.sort_by(f64::total_cmp);
    (passes[passes.len() / 2], passes[0], passes[passes.len() - 1])
}

fn timing((median, min, max): (f64, f64, f64), macs: u64) -> PathTiming {
    PathTiming {
        ms_per_window: median,
        ms_per_window_min: min,
        ms_per_window_max: max,
        windows_per_s: 1e3 / median,
        macs_per_s: macs as f64 * 1e3 / median,
    }
}

/// Benchmarks the ResNet model `m` (from `path`) as `spec` says.
pub fn run(m: &ResnetModel, path: &str, spec: &ResnetBenchSpec, progress: &dyn Progress) -> Result<ResnetBench> {
    let folded = FoldedResnet::from_tensors(&m.config, &m.tensors)?;
    let burn_model = learn::resnet::from_tensors(&m.config, &m.tensors)?;
    let im2col = folded.direct_convolution().then(|| folded.clone().with_direct_convolution(false));
    let (ims, source) = windows(m, &spec.windows, progress)?;
    if ims.is_empty() {
        return Err(Error::Setting { name: "windows", value: "0".into(), expected: "at least one window to time" });
    }
    let refs: Vec<&[f32]> = ims.iter().map(Vec::as_slice).collect();
    let cells: usize = ims.iter().map(Vec::len).sum();
    let density = ims.iter().flatten().filter(|v| **v != 0.0).count() as f64 / cells as f64;
    let (mut max_diff, mut max_rel) = (0.0f32, 0.0f32);
    for chunk in refs.chunks(32) {
        let ours = folded.logits_batch(chunk)?;
        for (a, b) in ours.iter().zip(learn::resnet::logits(&burn_model, m.config.input, chunk)) {
            for (x, y) in a.iter().zip(&b) {
                max_diff = max_diff.max((x - y).abs());
                max_rel = max_rel.max((x - y).abs() / y.abs().max(1.0));
            }
        }
    }
    let macs = ResnetConfig::macs(&m.config);
    let mut rows = Vec::new();
    for (batch, threads) in [(1, 1), (spec.batch.max(1), spec.threads.max(1))] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| Error::Setting {
            name: "threads",
            value: format!("{threads} ({e})"),
            expected: "a pool rayon can build",
        })?;
        let (f, i, b) = pool.install(|| -> Result<_> {
            let ours = |net: &FoldedResnet| -> Result<(f64, f64, f64)> {
                let mut failed = None;
                let t = time_passes(&refs, batch, spec.repeats, |c| {
                    if let Err(e) = net.logits_batch(c) {
                        failed = Some(e);
                    }
                });
                failed.map_or(Ok(t), |e| Err(e.into()))
            };
            let f = ours(&folded)?;
            let i = im2col.as_ref().map(ours).transpose()?;
            let b = time_passes(&refs, batch, spec.repeats, |c| {
                std::hint::black_box(learn::resnet::logits(&burn_model, m.config.input, c));
            });
            Ok((f, i, b))
        })?;
        rows.push(BatchRow {
            batch,
            threads,
            burn_over_folded: b.0 / f.0,
            folded: timing(f, macs),
            folded_im2col: i.map(|i| timing(i, macs)),
            burn: timing(b, macs),
        });
    }
    Ok(ResnetBench {
        model: path.to_string(),
        input: m.config.input,
        windows: ims.len(),
        source,
        density,
        macs_per_window: macs,
        direct_convolution: folded.direct_convolution(),
        rows,
        max_abs_logit_difference: max_diff,
        max_rel_logit_difference: max_rel,
        repeats: spec.repeats,
    })
}
