//! The labeler's running median (`LabelerConfig::despike_bins`) chosen on the validation boards
//! (SIMULATED): for each window length, the scans whose count the labeler matched and the
//! windows at their character, on VAL over depth and speed and on VAL-WORDS at 8 and 32 mm/s,
//! with the training sensor builds and the validation seed (docs/labeling.md).
//!
//! `cargo run --release -p experiments --example labeler_despike [clean|nominal|harsh] [trials] [bins,bins,...]`
//! (0: no median, the paper's profile).

use corpus::world::{VALIDATION_SEED, World};
use pipeline::labeling::{LabelerConfig, label};
use sim::{BoardKind, Realism};
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let realism = match args.first().map(String::as_str) {
        None | Some("nominal") => Realism::Nominal,
        Some("clean") => Realism::Clean,
        Some("harsh") => Realism::Harsh,
        Some(other) => return Err(format!("unknown preset {other}").into()),
    };
    let trials: u64 = args.get(1).map_or(Ok(3), |s| s.parse())?;
    let kbins: Vec<usize> =
        args.get(2).map_or("0,3,5,7,9", String::as_str).split(',').map(str::parse).collect::<Result<_, _>>()?;
    println!(
        "| board | speed (mm/s) | depth (mm) | {} |",
        kbins.iter().map(|k| format!("{k} bins: matched, windows right")).collect::<Vec<_>>().join(" | ")
    );
    println!("| --- | --- | --- |{}", " --- |".repeat(kbins.len()));
    let world = World::train(realism);
    let setup = world.setup();
    let sensors = world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
    let conds: Vec<(BoardKind, f64, f64)> = vec![
        (BoardKind::Val, 8.0, 0.2),
        (BoardKind::Val, 8.0, 0.6),
        (BoardKind::Val, 8.0, 1.0),
        (BoardKind::Val, 8.0, 1.5),
        (BoardKind::Val, 16.0, 1.5),
        (BoardKind::Val, 32.0, 1.5),
        (corpus::boards::parse_board("VAL-WORDS")?, 8.0, 1.5),
        (corpus::boards::parse_board("VAL-WORDS")?, 32.0, 1.5),
    ];
    for (kind, speed, depth) in conds {
        let board = world.board(&setup, &kind)?;
        let mut tot = vec![(0usize, 0usize, 0usize); kbins.len()];
        for row in 0..board.rows.len() {
            for trial in 0..trials {
                let seed = world.scan_seed(VALIDATION_SEED, &kind, row, trial, speed, depth);
                let sensor = &sensors[(trial % sensors.len() as u64) as usize];
                let s = sim::simulate(&board, sensor, &setup.scan(speed, depth, row, seed))?;
                let n = s.truth.characters.iter().filter(|c| !c.columns.is_empty()).count();
                for (i, &k) in kbins.iter().enumerate() {
                    let cfg = LabelerConfig { despike_bins: k, ..LabelerConfig::default() };
                    let l = label(&s.events, sensor.camera.resolution, speed, n, &cfg)?;
                    let sc = experiments::eval::labeling::score(&l, &s.truth, &cfg);
                    tot[i].0 += l.count_matched as usize;
                    tot[i].1 += sc.correct;
                    tot[i].2 += n;
                }
            }
        }
        let name = if matches!(kind, BoardKind::Val) { "VAL".to_string() } else { "VAL-WORDS".to_string() };
        let scans = board.rows.len() as u64 * trials;
        let cells: Vec<String> = tot.iter().map(|(m, c, n)| format!("{m}/{scans}, {c}/{n}")).collect();
        println!("| {name} | {speed} | {depth} | {} |", cells.join(" | "));
    }
    Ok(())
}
