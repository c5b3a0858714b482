//! Stick-slip of the gel on the board's flat face, seen through the compliance of the sensor's
//! mount.
//!
//! Where the board's face presses into the gel (depth beyond the dots' height), friction acts on
//! the whole contact: the face pressure `E delta / t` over the field of view gives tens of newtons
//! at 1-1.5 mm. The gel's surface sticks to the board until the shear force reaches the static
//! friction `mu_s N`, then slides at the kinetic `mu_k N`. The camera sees the board's relief,
//! which stays on the board whether the gel's surface sticks or slides; what moves the image is
//! the sensor body, held by the arm through a spring: while the surface sticks, the gel's shear
//! spring holds the body back; at a slip the force drops by `(mu_s - mu_k) N` and the body jumps
//! forward, ringing on the mount. The body (mass `m`) integrates
//!
//! `m x'' = k_a (u - x) + c (u' - x') - F`, with `F = k_g (x - y)` while the surface sticks at `y`
//! and `F = mu_k N` while it slides,
//!
//! where `u` is the arm's commanded displacement (with its ripple and a hand's swings), `k_a` the
//! mount's stiffness, `c = 2 zeta sqrt(k_a m)`, and `k_g = G A / t` the gel layer's shear
//! stiffness. The surface sticks again when the body stops. With a well damped mount there is one
//! slip, where the slide starts (stick-slip at touch-down), and then steady sliding behind the
//! command by `mu_k N / k_a`; with a light one, slips recur at speeds below about
//! `(mu_s - mu_k) N / sqrt(k_a m)`.
//!
//! The simulator turns the camera's displacement into times through one monotone table, so the
//! trace is made monotone: a backward swing of the body is held at its furthest point, and the
//! largest such swing is reported in the scan's truth.

use crate::error::{Result, check};
use serde::{Deserialize, Serialize};

/// The mount and the static friction (assumed values: docs/simulator.md).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StickSlip {
    /// Static friction coefficient minus the kinetic one (the gel's `friction`).
    pub static_excess: f64,
    /// The mount's lateral stiffness along the slide (arm, wrist and adapter), N/m.
    pub mount_stiffness_n_per_m: f64,
    /// The mass moving on that spring (sensor and wrist), kg.
    pub mount_mass_kg: f64,
    /// The mount's damping ratio.
    pub mount_damping_ratio: f64,
}

impl StickSlip {
    /// A light, lightly damped mount (assumed: a desktop arm's wrist, 30 kN/m, 1 kg, damping
    /// ratio 0.1) and a static coefficient 0.2 above the kinetic one (assumed: 0.1-0.3 for
    /// silicone on a hard polymer). Slips recur below about 20-30 mm/s from 1 mm depth.
    pub const LIGHT_MOUNT: StickSlip =
        StickSlip { static_excess: 0.2, mount_stiffness_n_per_m: 3e4, mount_mass_kg: 1.0, mount_damping_ratio: 0.1 };

    /// The middle of the assumed range of mounts: 100 kN/m (10 um/N, the logarithmic middle of
    /// 10^4-10^6 N/m), otherwise [`StickSlip::LIGHT_MOUNT`]. At 1.5 mm depth slips recur at 8 mm/s
    /// (every 0.9 mm), not from 16 mm/s (`nominal`; docs/results/stick_slip.md).
    pub const MID_MOUNT: StickSlip = StickSlip { mount_stiffness_n_per_m: 1e5, ..StickSlip::LIGHT_MOUNT };

    /// [`StickSlip::LIGHT_MOUNT`] with the mount's compliance set instead, in um per N (the axis
    /// `braille robustness` sweeps and `braille simulate --mount-compliance-um-per-n` takes).
    pub fn light_mount_with_compliance(um_per_n: f64) -> StickSlip {
        StickSlip { mount_stiffness_n_per_m: 1e6 / um_per_n, ..StickSlip::LIGHT_MOUNT }
    }

    pub fn validate(&self) -> Result<()> {
        check("stick_slip.static_excess", self.static_excess, 0.0..=2.0, "in [0, 2]")?;
        check("stick_slip.mount_stiffness_n_per_m", self.mount_stiffness_n_per_m, 1e2..=1e9, "in [1e2, 1e9] N/m")?;
        check("stick_slip.mount_mass_kg", self.mount_mass_kg, 1e-3..=100.0, "in [1e-3, 100] kg")?;
        check("stick_slip.mount_damping_ratio", self.mount_damping_ratio, 0.0..=10.0, "in [0, 10]")?;
        Ok(())
    }
}

/// The gel and contact quantities the mechanics needs, in SI units.
#[derive(Debug, Clone, Copy)]
pub struct Contact {
    /// Kinetic friction coefficient.
    pub friction: f64,
    /// Young's modulus (Pa), Poisson's ratio and thickness (m) of the gel.
    pub modulus_pa: f64,
    pub poisson_ratio: f64,
    pub thickness_m: f64,
    /// The face's contact area (the field of view), m^2. A build's optics scale its view by a
    /// few per cent (`SensorVariation::fov_rel_sigma`), and the area with it: within the spread
    /// of its modulus.
    pub area_m2: f64,
}

impl Contact {
    /// The contact of `sensor`'s gel (this build's modulus and thickness) over its field of view.
    pub fn of(sensor: &crate::Sensor) -> Contact {
        let (gel, cam) = (&sensor.gel.dynamics, &sensor.camera);
        let aspect = cam.resolution.height as f64 / cam.resolution.width as f64;
        Contact {
            friction: gel.friction,
            modulus_pa: gel.modulus_mpa * 1e6,
            poisson_ratio: gel.poisson_ratio,
            thickness_m: gel.thickness_mm * 1e-3,
            area_m2: cam.fov_width_mm * cam.fov_width_mm * aspect * 1e-6,
        }
    }

    /// Normal force of the flat face pressed `face_depth_mm` into the gel (0 when it does not
    /// touch), N.
    pub fn face_force_n(&self, face_depth_mm: f64) -> f64 {
        self.modulus_pa * self.area_m2 * (face_depth_mm.max(0.0) * 1e-3) / self.thickness_m
    }

    /// Shear stiffness of the gel layer, `G A / t`, N/m.
    pub fn shear_stiffness_n_per_m(&self) -> f64 {
        self.modulus_pa / (2.0 * (1.0 + self.poisson_ratio)) * self.area_m2 / self.thickness_m
    }
}

/// What a scan's stick-slip did (in its truth file).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct StickSlipTruth {
    /// Slips during the slide.
    pub slips: usize,
    /// The camera's advance beyond the command's during a slip, mm: largest and mean.
    pub largest_jump_mm: f64,
    pub mean_jump_mm: f64,
    /// The camera's lag behind the command at the middle of the slide, mm.
    pub lag_mid_mm: f64,
    /// The largest backward swing of the body, held at its furthest point in the trace, mm.
    pub clipped_backward_mm: f64,
}

/// The camera's displacement along the slide, sampled every `dt_s` from the slide's start, non
/// decreasing, ending at or beyond the slide's length.
#[derive(Debug, Clone)]
pub struct Trace {
    pub dt_s: f64,
    pub x_mm: Vec<f64>,
}

impl Trace {
    /// The first time the displacement reaches `s_mm` (linear between samples).
    pub fn time_of(&self, s_mm: f64) -> f64 {
        let x = &self.x_mm;
        let i = x.partition_point(|&v| v < s_mm);
        if i == 0 {
            return 0.0;
        }
        if i >= x.len() {
            return (x.len() - 1) as f64 * self.dt_s;
        }
        let (a, b) = (x[i - 1], x[i]);
        let r = if b > a { (s_mm - a) / (b - a) } else { 0.0 };
        (i as f64 - 1.0 + r) * self.dt_s
    }
}

/// Integration step and the trace's sampling.
const DT_S: f64 = 10e-6;
const SAMPLE_EVERY: usize = 5;
/// How far the camera advances before the face's force is looked up again, mm.
const FORCE_STEP_MM: f64 = 1e-3;

/// Integrates the body on its mount from the slide's start until the camera has covered
/// `slide_mm`. `command(t)` gives the arm's displacement (mm) and speed (mm/s) at time `t` from
/// the slide's start; `face_depth_mm(s)` the face's indentation where the camera is, `s` mm along
/// the slide.
pub fn trace(
    params: &StickSlip,
    contact: &Contact,
    slide_mm: f64,
    mean_speed_mm_s: f64,
    command: impl Fn(f64) -> (f64, f64),
    face_depth_mm: impl Fn(f64) -> f64,
) -> Result<(Trace, StickSlipTruth)> {
    params.validate()?;
    // The trace holds a sample every 50 us: an hour of slide is 72 M samples (0.6 GB).
    if slide_mm / mean_speed_mm_s > 3600.0 {
        return Err(crate::error::Error::Inconsistent {
            names: "stick-slip slide and speed",
            why: format!(
                "a {slide_mm} mm slide at {mean_speed_mm_s} mm/s lasts over an hour; the trace covers at most one"
            ),
        });
    }
    let (ka, m) = (params.mount_stiffness_n_per_m, params.mount_mass_kg);
    let c = 2.0 * params.mount_damping_ratio * (ka * m).sqrt();
    let inv_m = 1.0 / m;
    let kg = contact.shear_stiffness_n_per_m();
    let (mu_k, mu_s) = (contact.friction, contact.friction + params.static_excess);
    // Long enough for the slide at a tenth of its mean speed; the command keeps its motion law.
    let max_steps = ((10.0 * slide_mm / mean_speed_mm_s) / DT_S).ceil() as usize + 1000;
    let (mut x, mut v, mut y) = (0.0f64, 0.0f64, 0.0f64);
    // Direction of sliding (+1 forward, -1 back), or 0 while the surface sticks.
    let mut sliding = 0.0f64;
    let mut samples = vec![0.0];
    let mut furthest = 0.0f64;
    let mut out = StickSlipTruth::default();
    // A slip's jump: the camera's advance beyond the command's from the slip's onset, its peak
    // until the surface sticks again or five periods of the mount have passed.
    let window_s = 5.0 * std::f64::consts::TAU * (m / ka).sqrt();
    let mut open: Option<(f64, f64, f64, f64)> = None; // (onset t, x, u, peak)
    let mut jumps = Vec::new();
    let mut mid_done = false;
    let (mut n, mut n_at_mm) = (0.0, f64::NEG_INFINITY);
    let span = DT_S * SAMPLE_EVERY as f64;
    let (mut seg_k, mut seg) = (0usize, (command(0.0), command(span)));
    for step in 1..=max_steps {
        let t = step as f64 * DT_S;
        // The command is smooth over a sample (its swings are below 20 Hz): evaluated at the
        // samples, linear between.
        let k = (step - 1) / SAMPLE_EVERY;
        if k != seg_k {
            seg_k = k;
            seg = (seg.1, command((k + 1) as f64 * span));
        }
        let r = (t - k as f64 * span) / span;
        let (u_mm, ud_mm_s) = (seg.0.0 + (seg.1.0 - seg.0.0) * r, seg.0.1 + (seg.1.1 - seg.0.1) * r);
        let (u, ud) = (u_mm * 1e-3, ud_mm_s * 1e-3);
        // Without friction there is no static friction either. The depth changes over millimetres
        // of slide: the force is looked up again each micrometre the camera advances.
        if mu_k > 0.0 && furthest - n_at_mm >= FORCE_STEP_MM {
            n = contact.face_force_n(face_depth_mm(furthest));
            n_at_mm = furthest;
        }
        let force = if n <= 0.0 {
            // No face contact: the surface is free and carries no force.
            sliding = 0.0;
            y = x;
            0.0
        } else if sliding == 0.0 {
            let f = kg * (x - y);
            if f.abs() > mu_s * n {
                sliding = f.signum();
                out.slips += 1;
                if let Some((.., peak)) = open.take() {
                    jumps.push(peak);
                }
                open = Some((t, x, u, 0.0));
                sliding * mu_k * n
            } else {
                f
            }
        } else {
            sliding * mu_k * n
        };
        let a = (ka * (u - x) + c * (ud - v) - force) * inv_m;
        v += a * DT_S;
        x += v * DT_S;
        if sliding != 0.0 {
            // The surface rides with the body at the kinetic force, and sticks when it stops.
            y = x - force / kg;
            if v * sliding <= 0.0 {
                sliding = 0.0;
            }
        }
        if let Some((t0, x0, u0, peak)) = open.as_mut() {
            *peak = peak.max(((x - *x0) - (u - *u0)) * 1e3);
            if sliding == 0.0 || t - *t0 > window_s {
                jumps.push(*peak);
                open = None;
            }
        }
        let x_mm = x * 1e3;
        if x_mm > furthest {
            furthest = x_mm;
        } else {
            out.clipped_backward_mm = out.clipped_backward_mm.max(furthest - x_mm);
        }
        if !mid_done && furthest >= slide_mm / 2.0 {
            out.lag_mid_mm = u_mm - x_mm;
            mid_done = true;
        }
        if step % SAMPLE_EVERY == 0 {
            samples.push(furthest);
        }
        if furthest >= slide_mm {
            if step % SAMPLE_EVERY != 0 {
                samples.push(furthest);
            }
            jumps.extend(open.map(|o| o.3));
            out.largest_jump_mm = jumps.iter().cloned().fold(0.0, f64::max);
            out.mean_jump_mm = if jumps.is_empty() { 0.0 } else { jumps.iter().sum::<f64>() / jumps.len() as f64 };
            // A last partial sample is stretched to a whole step: the error is below DT_S * 5.
            return Ok((Trace { dt_s: DT_S * SAMPLE_EVERY as f64, x_mm: samples }, out));
        }
    }
    Err(crate::error::Error::Inconsistent {
        names: "stick-slip mount and friction",
        why: format!(
            "the camera did not cover the {slide_mm} mm slide in {:.1} s (a mount too soft for the friction?)",
            max_steps as f64 * DT_S
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contact() -> Contact {
        Contact {
            friction: 0.8,
            modulus_pa: 0.435e6,
            poisson_ratio: 0.5,
            thickness_m: 4e-3,
            area_m2: 18.6e-3 * 13.95e-3,
        }
    }

    fn run(p: StickSlip, v: f64, face_mm: f64) -> (Trace, StickSlipTruth) {
        trace(&p, &contact(), 60.0, v, |t| (v * t, v), |_| face_mm).unwrap()
    }

    #[test]
    fn no_face_contact_means_no_slip_and_no_lag() {
        let p = StickSlip {
            static_excess: 0.3,
            mount_stiffness_n_per_m: 2e4,
            mount_mass_kg: 1.0,
            mount_damping_ratio: 0.1,
        };
        let (tr, out) = run(p, 16.0, 0.0);
        assert_eq!(out.slips, 0);
        assert!(out.lag_mid_mm.abs() < 1e-3, "{out:?}");
        // Without friction the body follows the command: 30 mm at 16 mm/s take 1.875 s.
        assert!((tr.time_of(30.0) - 1.875).abs() < 1e-3);
    }

    #[test]
    fn a_damped_mount_slips_once_and_then_lags_by_the_kinetic_force() {
        let p = StickSlip {
            static_excess: 0.2,
            mount_stiffness_n_per_m: 3e4,
            mount_mass_kg: 1.0,
            mount_damping_ratio: 1.0,
        };
        let c = contact();
        let n = c.face_force_n(1.12);
        assert!((20.0..45.0).contains(&n), "tens of newtons at 1.5 mm: {n}");
        let (tr, out) = run(p, 16.0, 1.12);
        assert_eq!(out.slips, 1, "{out:?}");
        let lag = 0.8 * n / 3e4 * 1e3;
        assert!((out.lag_mid_mm / lag - 1.0).abs() < 0.02, "{} against {lag}", out.lag_mid_mm);
        // The jump is about the static excess over the mount's stiffness.
        let quasi = 0.2 * n / 3e4 * 1e3;
        assert!(out.largest_jump_mm > 0.5 * quasi && out.largest_jump_mm < 2.5 * quasi, "{out:?}, {quasi}");
        assert!(tr.x_mm.windows(2).all(|w| w[1] >= w[0]));
        assert_eq!(out.clipped_backward_mm, 0.0);
    }

    #[test]
    fn a_light_mount_keeps_slipping_slowly_and_slides_fast() {
        let p = StickSlip {
            static_excess: 0.3,
            mount_stiffness_n_per_m: 2e4,
            mount_mass_kg: 1.0,
            mount_damping_ratio: 0.05,
        };
        let per_100mm = |v: f64| run(p, v, 1.12).1.slips as f64 / 0.6;
        let (slow, fast) = (per_100mm(8.0), per_100mm(200.0));
        assert!(slow > 10.0, "slips per 100 mm at 8 mm/s: {slow}");
        assert!(fast < slow, "{fast} >= {slow}");
    }
}
