//! How much of a real setup's nuisances a simulation includes: `clean`, `nominal` or `harsh`.
//!
//! `clean` is the simulator as it was before the nuisances were modelled (kept for regression);
//! `nominal` takes every value from its source, or from the middle of an assumed range;
//! `harsh` puts every nuisance at the edge of what a real setup shows. Each value, its source and
//! its confidence are tabled in docs/simulator.md (REALISM.md gives the sources); none was chosen
//! for what a classifier scores.

use crate::board::BoardGeometry;
use crate::error::Result;
use crate::mount::StickSlip;
use crate::scan::ScanConfig;
use crate::sensor::{CameraConfig, GelConfig, GelDynamics, PronyTerm, Sensor, SensorVariation};
use encoders::Resolution;
use serde::{Deserialize, Serialize};

/// A preset of the simulator's nuisances.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Realism {
    /// No gel dynamics, texture, drift, jitter or sensor variation; little noise.
    Clean,
    /// Every nuisance at its sourced or mid-range value.
    Nominal,
    /// Every nuisance at the edge of what a real setup shows.
    Harsh,
}

impl std::fmt::Display for Realism {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(match self {
            Realism::Clean => "clean",
            Realism::Nominal => "nominal",
            Realism::Harsh => "harsh",
        })
    }
}

/// Everything a preset sets: the camera, the gel, the board's print, a scan's kinematics (speed,
/// depth, row and seed are the caller's) and how builds of the sensor differ.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Setup {
    pub realism: Realism,
    pub camera: CameraConfig,
    pub gel: GelConfig,
    pub geometry: BoardGeometry,
    pub scan: ScanConfig,
    pub variation: SensorVariation,
}

impl Realism {
    pub const ALL: [Realism; 3] = [Realism::Clean, Realism::Nominal, Realism::Harsh];

    pub fn setup(self) -> Setup {
        match self {
            Realism::Clean => Setup {
                realism: self,
                camera: CameraConfig::default(),
                gel: GelConfig::default(),
                geometry: BoardGeometry::default(),
                scan: ScanConfig::default(),
                variation: SensorVariation::default(),
            },
            Realism::Nominal => Setup::between(0.0),
            Realism::Harsh => Setup::between(1.0),
        }
    }
}

impl Setup {
    /// Every nuisance `level` of the way from its `nominal` value (0) to its `harsh` one (1),
    /// linearly (the mount's stiffness geometrically). The two presets
    /// differ in amounts only, so the levels between them are setups a real sensor can show: a
    /// training set drawn over them covers the envelope (`corpus::windows::Sweep::levels`). Not
    /// a preset: a level is never a source's value, and reports name `nominal` or `harsh` only.
    /// `level` is clamped to `0..=1` (not a number: 0).
    pub fn between(level: f64) -> Setup {
        let level = if level.is_finite() { level.clamp(0.0, 1.0) } else { 0.0 };
        let realism = if level >= 1.0 { Realism::Harsh } else { Realism::Nominal };
        // The presets' own values at the ends, bit for bit (their scans must not change).
        let pick = |nominal: f64, harsh: f64| match level {
            0.0 => nominal,
            1.0 => harsh,
            _ => nominal + level * (harsh - nominal),
        };
        let log_pick = |nominal: f64, harsh: f64| match level {
            0.0 => nominal,
            1.0 => harsh,
            _ => nominal * (harsh / nominal).powf(level),
        };
        let camera = CameraConfig {
            // Background activity: assumed 0.05-0.5 Hz per pixel under bright LEDs, shared
            // between leak and shot events.
            leak_hz_per_pixel: pick(0.05, 0.25),
            shot_hz_per_pixel: pick(0.05, 0.25),
            // Hot pixels come from the sensor variation.
            hot_pixels: 0,
            latency_jitter_us: pick(100.0, 300.0),
            event_rate_limit_hz: Some(165e6),
            ..CameraConfig::default()
        };
        let gel = GelConfig {
            // The one calibrated parameter, refitted on this preset's board and blur against the
            // paper's depth measurement (`cargo run --release -p sim --example calibrate`).
            conformity_exponent: 0.23,
            // "A few pixels" of optics blur (SIMULATOR.md 7); a coating of tens of microns.
            optics_blur_px: pick(2.0, 3.0),
            gel_blur_mm: pick(0.05, 0.08),
            dynamics: GelDynamics {
                relaxation: vec![
                    PronyTerm { fraction: pick(0.10, 0.20), tau_s: 0.1 },
                    PronyTerm { fraction: pick(0.05, 0.10), tau_s: 5.0 },
                ],
                friction: pick(0.8, 1.2),
                ..GelDynamics::default()
            },
            ..GelConfig::default()
        };
        // FDM PLA dots of a 0.5 mm design come out 0.38 +- 0.03 mm high and 1.0 +- 0.07 mm wide.
        let height = pick(0.38, 0.35);
        let geometry = BoardGeometry {
            dot_height_mm: height,
            dot_radius_mm: BoardGeometry::sphere_radius_mm(0.5, height),
            height_sigma_mm: pick(0.03, 0.045),
            base_radius_sigma_mm: pick(0.035, 0.05),
            position_sigma_mm: pick(0.025, 0.05),
            // Ra 6.9-7.8 um on FDM tops: a sinusoid of amplitude pi Ra / 2.
            texture_amplitude_mm: std::f64::consts::FRAC_PI_2 * pick(0.0073, 0.0078),
            ..BoardGeometry::default()
        };
        let scan = ScanConfig {
            speed_ripple: pick(0.035, 0.05),
            ripple_hz: pick(5.0, 10.0),
            misalignment_sigma_mm: pick(0.15, 0.3),
            yaw_sigma_deg: pick(0.5, 1.5),
            depth_tilt_sigma_mm_per_100mm: pick(0.05, 0.15),
            depth_wander_sigma_mm: pick(0.03, 0.06),
            // Stick-slip shows only through the mount's compliance, which no source gives for the
            // paper's arm: from a stiff, damped mount (one slip before the text and a constant lag,
            // invisible to a reader) to a light one (slips every few mm). `nominal` takes the
            // logarithmic middle of the assumed 10^4-10^6 N/m (10 um/N: at 1.5 mm slips recur at
            // 8 mm/s, not from 16), `harsh` the light end (30 kN/m); both lightly damped (0.1,
            // assumed; docs/simulator.md). `braille robustness` sweeps the compliance.
            stick_slip: Some(StickSlip {
                mount_stiffness_n_per_m: log_pick(
                    StickSlip::MID_MOUNT.mount_stiffness_n_per_m,
                    StickSlip::LIGHT_MOUNT.mount_stiffness_n_per_m,
                ),
                ..StickSlip::MID_MOUNT
            }),
            ..ScanConfig::default()
        };
        let variation = SensorVariation {
            gel_thickness_sigma_mm: pick(0.075, 0.1),
            modulus_rel_sigma: pick(0.05, 0.1),
            led_gain_rel_sigma: pick(0.075, 0.1),
            falloff_range: (0.2, pick(0.4, 0.5)),
            threshold_rel_sigma_range: (pick(0.1, 0.15), pick(0.2, 0.25)),
            noise_rate_sigma_decades: pick(0.1, 0.2),
            hot_pixel_fraction: pick(0.0003, 0.001),
            hot_pixel_hz_range: (10.0, 100.0),
            // The optics' scale: a lens's focal length within +-5% (a common tolerance of board
            // lenses) and the camera-to-gel distance within a printed mount's +-0.2 mm of about
            // 25 mm (assumed): +-5% taken as 2 sigma at `nominal`, as 1 sigma at `harsh`.
            fov_rel_sigma: pick(0.025, 0.05),
        };
        Setup { realism, camera, gel, geometry, scan, variation }
    }

    /// One build of the sensor at `resolution`, drawn from `seed`.
    pub fn sensor(&self, resolution: Resolution, seed: u64) -> Result<Sensor> {
        let camera = CameraConfig { resolution, ..self.camera.clone() };
        Sensor::instance(&camera, &self.gel, &self.variation, seed)
    }

    /// A scan of `row` at a speed and depth, with this preset's kinematics.
    pub fn scan(&self, speed_mm_s: f64, depth_mm: f64, row: usize, seed: u64) -> ScanConfig {
        ScanConfig { speed_mm_s, depth_mm, row, seed, ..self.scan.clone() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_validate_and_clean_is_the_default_simulator() {
        for r in Realism::ALL {
            let s = r.setup();
            s.camera.validate().unwrap();
            s.gel.validate().unwrap();
            s.geometry.validate().unwrap();
            s.variation.validate().unwrap();
        }
        let clean = Realism::Clean.setup();
        assert_eq!(clean.camera, CameraConfig::default());
        assert_eq!(clean.gel, GelConfig::default());
        assert_eq!(clean.geometry, BoardGeometry::default());
        assert!(clean.variation.is_none());
        // Harsh is at least as far from clean as nominal, nuisance by nuisance.
        let (n, h) = (Realism::Nominal.setup(), Realism::Harsh.setup());
        assert!(h.camera.leak_hz_per_pixel >= n.camera.leak_hz_per_pixel);
        assert!(h.scan.misalignment_sigma_mm >= n.scan.misalignment_sigma_mm);
        assert!(h.gel.dynamics.relaxing_fraction() >= n.gel.dynamics.relaxing_fraction());
        assert!(h.variation.hot_pixel_fraction >= n.variation.hot_pixel_fraction);
    }

    #[test]
    fn levels_between_the_presets_end_at_them_and_move_every_nuisance_one_way() {
        assert_eq!(Setup::between(0.0), Realism::Nominal.setup());
        assert_eq!(Setup::between(1.0), Realism::Harsh.setup());
        // The presets as sourced (docs/simulator.md): a refactor must not move them.
        let (n, h) = (Realism::Nominal.setup(), Realism::Harsh.setup());
        assert_eq!((n.camera.leak_hz_per_pixel, h.camera.leak_hz_per_pixel), (0.05, 0.25));
        assert_eq!(n.scan.stick_slip, Some(StickSlip::MID_MOUNT));
        assert_eq!(h.scan.stick_slip, Some(StickSlip::LIGHT_MOUNT));
        assert_eq!((n.variation.falloff_range, h.variation.falloff_range), ((0.2, 0.4), (0.2, 0.5)));
        let m = Setup::between(0.5);
        m.variation.validate().unwrap();
        m.geometry.validate().unwrap();
        assert!(n.camera.leak_hz_per_pixel < m.camera.leak_hz_per_pixel && m.camera.leak_hz_per_pixel < 0.25);
        assert!(m.scan.yaw_sigma_deg > n.scan.yaw_sigma_deg && m.scan.yaw_sigma_deg < h.scan.yaw_sigma_deg);
        let k = |s: &Setup| s.scan.stick_slip.unwrap().mount_stiffness_n_per_m;
        assert!((k(&m) - (1e5f64 * 3e4).sqrt()).abs() < 1e-6);
        assert_eq!(Setup::between(7.0), h);
        assert_eq!(Setup::between(f64::NAN), n);
    }

    #[test]
    fn sensor_instances_differ_by_seed_and_repeat_by_seed() {
        let s = Realism::Nominal.setup();
        let r = Resolution::new(64, 48);
        let (a, b) = (s.sensor(r, 1).unwrap(), s.sensor(r, 2).unwrap());
        assert_ne!(a.camera.background_dn, b.camera.background_dn);
        assert_ne!(a.gel.dynamics.thickness_mm, b.gel.dynamics.thickness_mm);
        // Each build has its own optics, drawn apart from the rest of the build: without the
        // optics' spread the build is the same but for its field of view.
        assert_ne!(a.camera.fov_width_mm, b.camera.fov_width_mm);
        let flat = Setup { variation: SensorVariation { fov_rel_sigma: 0.0, ..s.variation.clone() }, ..s.clone() };
        let a0 = flat.sensor(r, 1).unwrap();
        assert_eq!(a0.camera.fov_width_mm, 18.6);
        assert_eq!(CameraConfig { fov_width_mm: 18.6, ..a.camera.clone() }, a0.camera);
        assert_eq!(a.gel, a0.gel);
        let again = s.sensor(r, 1).unwrap();
        assert_eq!(a.camera, again.camera);
        assert_eq!(a.threshold_on, again.threshold_on);
        // Without variation an instance is the sensor itself.
        let c = Realism::Clean.setup();
        assert_eq!(
            c.sensor(r, 3).unwrap().threshold_on,
            Sensor::new(CameraConfig { resolution: r, ..c.camera.clone() }, c.gel.clone(), 3).unwrap().threshold_on
        );
    }
}
