//! `braille sim-check`: the simulator's physics checks on fresh scans.

use anyhow::Result;
use sim::checks::{self, PAPER_DEPTH_GAIN};

#[derive(clap::Args)]
pub struct Args {
    /// Boards (each with its own tolerances) averaged for the depth measurement.
    #[arg(long, default_value_t = 8)]
    trials: u64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> Result<()> {
    let r = checks::run(args.trials.max(1))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    println!("Simulator physics checks (simulated scans; see SIMULATOR.md):\n");
    println!("| check | measured | expected |\n| --- | --- | --- |");
    for (d, target) in PAPER_DEPTH_GAIN {
        let g = r.depth_gain[&format!("{d:.1}")];
        println!(
            "| 1. events per dot at {d} mm over 0.2 mm | +{:.0}% | +{:.0}% +-10 points (paper) |",
            g * 100.0,
            target * 100.0
        );
    }
    println!("| 2. events per pass across 8-32 mm/s | largest deviation {:.1}% | within 15% |", r.speed_spread * 100.0);
    for v in checks::SPEEDS_MM_S {
        let key = format!("{v:.0}");
        println!(
            "| 2. column lag at {key} mm/s | {:.1} ms | {:.1} ms (2.5 mm / speed) |",
            r.column_lag_ms[&key], r.expected_column_lag_ms[&key]
        );
    }
    println!("| 3. ON/OFF ratio per pass | {:.2} | 0.9-1.2 |", r.on_off_ratio);
    println!(
        "| 3. leading / trailing edge, forward | {} / {} | opposite |\n| 3. leading / trailing edge, reverse | {} / {} | opposite; each physical edge swaps |",
        r.leading_polarity["forward"],
        r.trailing_polarity["forward"],
        r.leading_polarity["reverse"],
        r.trailing_polarity["reverse"]
    );
    for (d, w) in &r.blob_width_px {
        let expected = if d == "0.2" { "about 27 px" } else { "34-55 px" };
        println!("| 4. dot blob width at {d} mm | {w:.0} px | {expected} |");
    }
    println!("| 4. six-dot patterns read back from events | {}/26 | 26/26 |", r.patterns_recovered);
    println!(
        "| 5. noise floor without contact | {:.0} Hz | {:.0} Hz configured |",
        r.noise_rate_hz, r.expected_noise_rate_hz
    );
    println!("| 6. last event after the motion stops | {:.1} ms | within about 5 ms |", r.static_settle_ms);
    println!("| 7. smallest gap between events of one pixel | {} us | >= 500 us refractory |", r.min_pixel_gap_us);
    println!("| 7. timestamps on the 200 us readout grid | {} | true |", r.on_readout_grid);
    println!("| 8. same seed, same stream bit for bit | {} | true |", r.deterministic);
    Ok(())
}
