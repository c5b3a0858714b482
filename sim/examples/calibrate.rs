//! How the one calibrated parameter was set: the exponent of the contact radius's growth with
//! depth, swept against the seed paper's measured depth gains (events per dot at 0.6 / 1.0 / 1.5 mm
//! over 0.2 mm: +45% / +71% / +91%), measured as `braille sim-check` measures them, on each
//! realism preset's board, blur and gel (`harsh` takes `nominal`'s). Physics only: no classifier
//! is involved.
//!
//! `cargo run --release -p sim --example calibrate`

use sim::checks::{PAPER_DEPTH_GAIN, depth_at};
use sim::{GelConfig, Realism, Setup};

fn main() -> Result<(), sim::Error> {
    for (realism, exponents) in
        [(Realism::Clean, [0.25, 0.28, 0.30, 0.32, 1.0 / 3.0]), (Realism::Nominal, [0.20, 0.22, 0.23, 0.24, 0.25])]
    {
        println!("\n{realism}\nexponent | gain 0.6 | gain 1.0 | gain 1.5 | squared error");
        let base = realism.setup();
        for exponent in exponents {
            let setup = Setup { gel: GelConfig { conformity_exponent: exponent, ..base.gel.clone() }, ..base.clone() };
            let (gain, _) = depth_at(&setup, 8)?;
            let mut err = 0.0;
            let mut row = format!("{exponent:8.3}");
            for (d, target) in PAPER_DEPTH_GAIN {
                let g = gain[&format!("{d:.1}")];
                err += (g - target) * (g - target);
                row += &format!(" | {g:8.3}");
            }
            println!("{row} | {err:.4}");
        }
    }
    Ok(())
}
