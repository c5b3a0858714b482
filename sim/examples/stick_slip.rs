//! What the stick-slip model gives (docs/simulator.md), mechanics only, no events: slips per 100
//! mm of slide, the largest jump of the camera and its lag behind the arm, over the mount's
//! compliance (as `braille robustness` sweeps it) and the speed, at 1.5 mm with the `nominal`
//! gel; the rest of the mount as `harsh`'s (`StickSlip::LIGHT_MOUNT`).
//!
//! `cargo run --release -p sim --example stick_slip > docs/results/stick_slip.md`

use sim::StickSlip;
use sim::mount::{Contact, trace};

fn main() -> sim::Result<()> {
    let setup = sim::Realism::Nominal.setup();
    let sensor = setup.sensor(encoders::Resolution::DVXPLORER, 1)?;
    let contact = Contact::of(&sensor);
    let depth_mm = 1.5;
    let face = depth_mm - setup.geometry.dot_height_mm;
    let p = StickSlip::LIGHT_MOUNT;
    println!("# Stick-slip through the mount (SIMULATED mechanics)\n");
    println!(
        "The `nominal` gel (kinetic friction {}, sensor build 1) pressed {depth_mm} mm: the board's face presses with {:.1} N. Static friction {} above the kinetic; mount mass {} kg, damping ratio {}; 100 mm of slide at a constant commanded speed. Regenerate: `cargo run --release -p sim --example stick_slip > docs/results/stick_slip.md` (docs/simulator.md).\n",
        contact.friction,
        contact.face_force_n(face),
        p.static_excess,
        p.mount_mass_kg,
        p.mount_damping_ratio
    );
    println!(
        "| compliance (um/N) | stiffness (kN/m) | speed (mm/s) | slips per 100 mm | largest jump (mm) | lag at mid-slide (mm) |"
    );
    println!("| --- | --- | --- | --- | --- | --- |");
    for compliance in [1.0, 2.0, 5.0, 10.0, 20.0, 33.0, 50.0] {
        let p = StickSlip::light_mount_with_compliance(compliance);
        for v in [8.0, 16.0, 32.0, 64.0] {
            let (_, out) = trace(&p, &contact, 100.0, v, |t| (v * t, v), |_| face)?;
            println!(
                "| {compliance} | {:.0} | {v} | {} | {:.3} | {:.3} |",
                p.mount_stiffness_n_per_m / 1e3,
                out.slips,
                out.largest_jump_mm,
                out.lag_mid_mm
            );
        }
    }
    println!(
        "\nOne slip where the slide starts is the touch-down slip; its jump includes the mount's ringing as the arm steps from rest to its speed."
    );
    Ok(())
}
