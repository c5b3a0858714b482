//! The stream's background activity as the reader estimates it from its noise filter
//! (`encoders::denoise::BackgroundActivityFilter::background_rate_hz_per_pixel`), against the
//! rate the simulator drew (SIMULATED; the truth scores the estimate, it never reaches a reader):
//! the validation words (VAL-WORDS, validation builds, validation seed), every row scanned once at
//! each level of background activity (the rest of the preset as it is), DV's filter as the
//! seed's lab records (`dv-lab`).
//!
//! `cargo run --release -p experiments --example noise_estimate [nominal|harsh] [speed_mm_s] [depth_mm]`

use corpus::world::{SensorBuilds, VALIDATION_SEED, World};
use encoders::denoise::{BackgroundActivityFilter, NoiseFilterSettings};
use sim::Realism;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let realism: Realism =
        serde_json::from_value(serde_json::Value::String(args.first().cloned().unwrap_or_else(|| "nominal".into())))?;
    let speed_mm_s: f64 = args.get(1).map_or(Ok(8.0), |s| s.parse())?;
    let depth_mm: f64 = args.get(2).map_or(Ok(1.0), |s| s.parse())?;
    let world = World::of(realism, SensorBuilds::Validation);
    let board = corpus::boards::validation_words_board();
    let preset = world.setup();
    println!(
        "# Background activity estimated from the noise filter (SIMULATED)\n\nVAL-WORDS by validation builds {:?} (seed {VALIDATION_SEED}), `{realism}` but for the background activity, {speed_mm_s} mm/s, {depth_mm} mm, each row once; the filter `dv-lab`. Each build scales the preset's rate by its own gain (and hot pixels, {:.4} of the pixels at {:?} Hz, about {:.3} Hz per pixel in all, add to it): the truth column is the builds' own uncorrelated activity, which the estimate counts. Made by `cargo run --release -p experiments --example noise_estimate {realism} {speed_mm_s} {depth_mm}`.\n\n| preset's rate, Hz per pixel | the builds' own: background and hot pixels (truth, mean over rows) | estimated: mean over rows | lowest | highest | estimate over truth |\n| --- | --- | --- | --- | --- | --- |",
        world.sensors,
        preset.variation.hot_pixel_fraction,
        preset.variation.hot_pixel_hz_range,
        preset.variation.hot_pixel_fraction
            * 0.5
            * (preset.variation.hot_pixel_hz_range.0 + preset.variation.hot_pixel_hz_range.1)
    );
    let own = preset.camera.leak_hz_per_pixel + preset.camera.shot_hz_per_pixel;
    let mut levels = vec![0.0, 0.05, 0.1, 0.3, 0.5, 1.0, 2.0, 3.0];
    if !levels.contains(&own) {
        levels.push(own);
        levels.sort_by(f64::total_cmp);
    }
    for rate in levels {
        let mut setup = preset.clone();
        setup.camera.leak_hz_per_pixel = rate / 2.0;
        setup.camera.shot_hz_per_pixel = rate / 2.0;
        let b = world.board(&setup, &board)?;
        let sensors = world.sensors_at(&setup, encoders::Resolution::DVXPLORER)?;
        let (mut estimates, mut truths) = (Vec::new(), Vec::new());
        for row in 0..b.rows.len() {
            let seed = world.scan_seed(VALIDATION_SEED, &board, row, 0, speed_mm_s, depth_mm);
            let sensor = &sensors[row % sensors.len()];
            let c = &sensor.camera;
            truths.push(
                c.leak_hz_per_pixel
                    + c.shot_hz_per_pixel
                    + c.hot_pixels as f64 * c.hot_pixel_hz / c.resolution.pixels() as f64,
            );
            let s = sim::simulate(&b, sensor, &setup.scan(speed_mm_s, depth_mm, row, seed))?;
            let mut f = BackgroundActivityFilter::new(sensor.camera.resolution, NoiseFilterSettings::DV_LAB)?;
            for e in &s.events {
                f.retain(e);
            }
            let span_us = match (s.events.first(), s.events.last()) {
                (Some(a), Some(z)) => z.t_us - a.t_us,
                _ => 0,
            };
            estimates.extend(f.background_rate_hz_per_pixel(span_us));
        }
        let mean = estimates.iter().sum::<f64>() / estimates.len().max(1) as f64;
        let (lo, hi) = estimates.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
        let mark = if rate == own { format!(" (`{realism}`'s own)") } else { String::new() };
        let truth = truths.iter().sum::<f64>() / truths.len().max(1) as f64;
        println!("| {rate}{mark} | {truth:.3} | {mean:.3} | {lo:.3} | {hi:.3} | {:.2} |", mean / truth);
    }
    Ok(())
}
