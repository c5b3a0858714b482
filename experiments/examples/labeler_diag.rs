//! The labeler's misses on the validation board, looked at one scan at a time (SIMULATED):
//! for every scan of VAL at `nominal` with the training sensor builds and the validation seed,
//! the count found against the row's, and for a miscounted scan its peaks (time and height), the
//! events of the start window around each peak by 40-pixel band of image rows, and the times the
//! truth puts each character's columns at the start window. This is how the extra peaks of the
//! next rows' dots at the image's edge were found (docs/labeling.md).
//!
//! `cargo run --release -p experiments --example labeler_diag [trials] [depth_mm] [speed_mm_s] [whole]`
//! (`whole`: the start window over every row, as before the fix).

use corpus::world::{VALIDATION_SEED, World};
use pipeline::labeling::{LabelerConfig, label, peaks};
use sim::{BoardKind, Realism};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let trials: u64 = args.first().map_or(Ok(10), |s| s.parse())?;
    let depth: f64 = args.get(1).map_or(Ok(1.5), |s| s.parse())?;
    let speed: f64 = args.get(2).map_or(Ok(8.0), |s| s.parse())?;
    let mut cfg = LabelerConfig::default();
    if args.get(3).map(String::as_str) == Some("whole") {
        cfg.start_window_rows = 0..120;
    }
    let world = World::train(Realism::Nominal);
    let setup = world.setup();
    let sensors = world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
    let kind = BoardKind::Val;
    let board = world.board(&setup, &kind)?;
    let window_col = (cfg.start_window_cols.start + cfg.start_window_cols.end) as f64 / 2.0;
    let mut missed = 0;
    for row in 0..board.rows.len() {
        for trial in 0..trials {
            let seed = world.scan_seed(VALIDATION_SEED, &kind, row, trial, speed, depth);
            let sensor = &sensors[(trial % sensors.len() as u64) as usize];
            let s = sim::simulate(&board, sensor, &setup.scan(speed, depth, row, seed))?;
            let n = s.truth.characters.iter().filter(|c| !c.columns.is_empty()).count();
            let l = label(&s.events, sensor.camera.resolution, speed, n, &cfg)?;
            let sc = experiments::eval::labeling::score(&l, &s.truth, &cfg);
            println!(
                "row {row} trial {trial}: expected {n}, found {}, at their character {}",
                l.windows.len(),
                sc.correct
            );
            if l.count_matched {
                continue;
            }
            missed += 1;
            for b in peaks(&l.profile, cfg.min_peak_fraction) {
                let t = l.t0_us + b as i64 * l.bin_us;
                let mut bands = [0u32; 12];
                for e in s
                    .events
                    .iter()
                    .filter(|e| (e.t_us - t).abs() < 30_000 && cfg.start_window_cols.contains(&(e.x / cfg.pool)))
                {
                    bands[(e.y / 40).min(11) as usize] += 1;
                }
                println!(
                    "  peak {:.2} s, height {:.0}: events by 40-px row band {bands:?}",
                    t as f64 * 1e-6,
                    l.profile[b]
                );
            }
            // when each character's columns cross the start window (forward scans)
            let x_mm = (window_col * cfg.pool as f64 - s.truth.resolution.width as f64 / 2.0) * s.truth.pitch_mm;
            let truth: Vec<String> = s
                .truth
                .characters
                .iter()
                .filter(|c| !c.columns.is_empty())
                .map(|c| {
                    let ts: Vec<String> = c
                        .columns
                        .iter()
                        .filter_map(|col| col.t_center_s)
                        .map(|t| format!("{:.2}", t - x_mm / speed))
                        .collect();
                    format!("{}[{}]", c.letter, ts.join(","))
                })
                .collect();
            println!("  truth {}", truth.join(" "));
        }
    }
    println!("{missed} of {} scans miscounted", trials * board.rows.len() as u64);
    Ok(())
}
