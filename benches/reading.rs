//! End-to-end stream reading (SIMULATED data): one row of the EV board ("RIGHT LEFT EXIT OPEN")
//! scanned at 32 mm/s by the virtual Evetac (about 7 s of events, seeded), read from its raw
//! events to words by each architecture's shipped networks: segmentation network on every frame,
//! character classifier where a character is present, temporal filter, lexicon decoder. The
//! issue's target: the SNN path within 1% of the stream's duration. The reader estimates the
//! speed from the events (the deployable reader); `_given` is the same reader told the speed, so
//! the difference is what estimating it costs. Prints the stream's duration and what was read
//! once before measuring. The row is read at `clean` (the regression models, as first measured)
//! and at `nominal` (the default preset's kinematics and noise, a test build of the sensor, the
//! models trained there).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{Spell, Speller, Timing, read_all};
use pipeline::shipped::{Preset, Shipped};
use sim::{Board, BoardGeometry, BoardKind, ScanConfig};
use snn::model_file::Arch;
use std::hint::black_box;
use std::path::Path;

const SPEED_MM_S: f64 = 32.0;

/// The row at a preset: `clean` as before (sensor build 1, the regression models' world); beyond
/// it the preset's kinematics and a test build of the sensor (101), which no model trained on.
fn scan(realism: sim::Realism) -> sim::Scan {
    let kind = BoardKind::Ev;
    if realism == sim::Realism::Clean {
        let board = Board::new(kind.clone(), BoardGeometry::default(), Board::default_seed(&kind)).expect("EV board");
        let camera = sim::sensor::CameraConfig::default();
        let sensor = sim::sensor::Sensor::new(camera, sim::sensor::GelConfig::default(), 1).expect("sensor");
        let cfg = ScanConfig { speed_mm_s: SPEED_MM_S, depth_mm: 1.5, row: 0, seed: 7, ..ScanConfig::default() };
        return sim::simulate(&board, &sensor, &cfg).expect("simulated scan");
    }
    let setup = realism.setup();
    let board = Board::new(kind.clone(), setup.geometry.clone(), Board::default_seed(&kind)).expect("EV board");
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, 101).expect("sensor");
    sim::simulate(&board, &sensor, &setup.scan(SPEED_MM_S, 1.5, 0, 7)).expect("simulated scan")
}

/// The shipped reader of an architecture at a preset (`pipeline::shipped`), loaded by the one
/// model loader.
fn models(arch: Arch, realism: sim::Realism) -> ReaderModels {
    let shipped = Shipped::at(Path::new(env!("CARGO_MANIFEST_DIR")).join("models"));
    let preset = Preset::of_name(&realism.to_string()).expect("a preset with shipped models");
    let r = shipped.reader(preset, arch);
    ReaderModels::load(&r.segmenter, &r.classifier, SnnRunner::Sliding).expect("shipped models")
}

fn reading(c: &mut Criterion) {
    let speller = Speller::new(Spell::Lexicon);
    let mut group = c.benchmark_group("reading");
    group.sample_size(10);
    for realism in [sim::Realism::Clean, sim::Realism::Nominal] {
        let s = scan(realism);
        let resolution = s.truth.resolution;
        let duration_s = s.events.last().map_or(0.0, |e| e.t_us as f64 / 1e6);
        group.throughput(Throughput::Elements(s.events.len() as u64));
        // `clean` keeps its old names (the history in docs/reading.md); `nominal` is prefixed.
        let prefix = if realism == sim::Realism::Clean { String::new() } else { format!("{realism}_") };
        for (arch, timing, suffix) in [
            (Arch::Snn, Timing::ESTIMATED, ""),
            (Arch::Resnet, Timing::ESTIMATED, ""),
            (Arch::Snn, Timing::Given { speed_mm_s: SPEED_MM_S }, "_given"),
        ] {
            let m = models(arch, realism);
            let cfg = m.config(timing);
            let r = read_all(&s.events, cfg.clone(), resolution, &m.segmenter, &m.classifier, &speller).expect("read");
            let (words, stats) = (r.words, r.stats);
            let text: Vec<String> = words.iter().map(|w| w.text.clone()).collect();
            eprintln!(
                "SIMULATED EV row 0 at {SPEED_MM_S} mm/s, {realism}: {:.2} s of stream, {} events, {} frames; {arch}{suffix} read {:?} at {:?} mm/s ({} classifier calls); 1% of the duration is {:.1} ms",
                duration_s,
                s.events.len(),
                stats.frames,
                text.join(" "),
                stats.speed_mm_s,
                stats.classifier_calls,
                duration_s * 10.0
            );
            group.bench_function(format!("{prefix}ev_row_32mm_s_{arch}{suffix}"), |b| {
                b.iter(|| {
                    black_box(
                        read_all(&s.events, cfg.clone(), resolution, &m.segmenter, &m.classifier, &speller)
                            .expect("read")
                            .words
                            .len(),
                    )
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, reading);
criterion_main!(benches);
