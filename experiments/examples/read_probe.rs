//! The SNN reader on the `nominal` EV row of `cargo bench --bench reading` (SIMULATED: 32 mm/s,
//! the test sensor build 101, the speed estimated), read `reads` times in one process: the
//! fastest and the median read. For alternating two builds of the reader on a noisy host, where
//! criterion's runs take minutes (docs/reading.md, 2026-12-02).
//!
//! `cargo run --release -p experiments --example read_probe [reads]`
use pipeline::classify::{ReaderModels, SnnRunner};
use pipeline::reader::{Spell, Speller, Timing, read_all};
use pipeline::shipped::{Preset, Shipped};
use sim::{Board, BoardKind};
use snn::model_file::Arch;
use std::path::Path;
use std::time::Instant;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(10);
    let kind = BoardKind::Ev;
    let setup = sim::Realism::Nominal.setup();
    let board = Board::new(kind.clone(), setup.geometry.clone(), Board::default_seed(&kind)).unwrap();
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, 101).unwrap();
    let s = sim::simulate(&board, &sensor, &setup.scan(32.0, 1.5, 0, 7)).unwrap();
    let shipped = Shipped::at(Path::new(env!("CARGO_MANIFEST_DIR")).join("../models"));
    let r = shipped.reader(Preset::of_name("nominal").unwrap(), Arch::Snn);
    let m = ReaderModels::load(&r.segmenter, &r.classifier, SnnRunner::Sliding).unwrap();
    let cfg = m.config(Timing::ESTIMATED);
    let speller = Speller::new(Spell::Lexicon);
    let mut ms = Vec::new();
    let mut words = 0;
    for _ in 0..n {
        let t = Instant::now();
        let r = read_all(&s.events, cfg.clone(), s.truth.resolution, &m.segmenter, &m.classifier, &speller).unwrap();
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        words += r.words.len();
    }
    ms.sort_by(f64::total_cmp);
    if n > 0 {
        println!("{n} reads, {words} words: fastest {:.1} ms, median {:.1} ms", ms[0], ms[n / 2]);
    }
}
