//! Each pixel's events: the crossings of its thresholds along its row's brightness profile, and
//! the print texture's events in closed form.

use super::*;

/// The print texture under the flat board face, where the face presses into the gel: a sinusoid
/// of log brightness sweeping past each pixel as the board slides. Its events are found per pixel
/// in closed form, half a period at a time, apart from the dots' (each source tracks its own
/// reference level; the readout's refractory period then applies to both).
pub(super) struct Texture {
    /// Wavenumber of the texture along board x and y, in rad/mm.
    pub(super) k_x: f64,
    pub(super) k_y: f64,
    /// Log-brightness amplitude at full conformity, after the gel's and the optics' blur.
    pub(super) amplitude: f64,
    /// Face penetration (mm) under the sensor along the slide, sampled every `ds` mm, and the
    /// share of the texture the gel takes there.
    pub(super) ds: f64,
    pub(super) conformity: Vec<f64>,
    /// Per photoreceptor level: the gain and phase lag of the low-pass at the sweep's frequency.
    pub(super) gain: Vec<f64>,
    pub(super) lag_rad: Vec<f64>,
}

impl Texture {
    pub(super) fn new(
        board: &Board,
        sensor: &Sensor,
        depth: &DepthProfile,
        speed_mm_s: f64,
        level_tau: &[f64],
    ) -> Option<Texture> {
        let g = &board.geometry;
        if g.texture_amplitude_mm <= 0.0 {
            return None;
        }
        let k = std::f64::consts::TAU / g.texture_pitch_mm;
        // Crests run at the angle to the row: the wavevector is normal to them.
        let normal = (g.texture_angle_deg + 90.0).to_radians();
        let (k_x, k_y) = (k * normal.cos(), k * normal.sin());
        if k_x.abs() < 1e-9 {
            return None;
        }
        let gel = &sensor.gel;
        let pitch = sensor.camera.pitch_mm();
        let optics_mm = gel.optics_blur_px * pitch * sensor.camera.resolution.width as f64 / 640.0;
        let blur = (-(k * gel.gel_blur_mm).powi(2) / 2.0).exp() * (-(k * optics_mm).powi(2) / 2.0).exp();
        let slope = g.texture_amplitude_mm * k * blur;
        let amplitude = crate::stamp::log_contrast_of_slope(gel, slope, normal);
        if amplitude <= 1e-6 {
            return None;
        }
        // Johnson's pressure for full contact with a wavy surface, against the face's pressure.
        let dynamics = &gel.dynamics;
        let full_mpa =
            std::f64::consts::PI * dynamics.contact_modulus_mpa() * g.texture_amplitude_mm / g.texture_pitch_mm;
        let ds = 0.5;
        let n = (depth.slide_mm / ds).ceil() as usize + 2;
        let conformity: Vec<f64> = (0..n)
            .map(|i| {
                let face_mm = depth.at(i as f64 * ds) - g.dot_height_mm;
                (dynamics.modulus_mpa * face_mm.max(0.0) / dynamics.thickness_mm / full_mpa).min(1.0)
            })
            .collect();
        if conformity.iter().all(|&c| c <= 0.0) {
            return None;
        }
        let omega = k_x.abs() * speed_mm_s;
        let gain = level_tau.iter().map(|t| 1.0 / (1.0 + (omega * t).powi(2)).sqrt()).collect();
        let lag_rad = level_tau.iter().map(|t| (omega * t).atan()).collect();
        Some(Texture { k_x, k_y, amplitude, ds, conformity, gain, lag_rad })
    }

    pub(super) fn conformity_at(&self, s: f64) -> f64 {
        let f = (s / self.ds).max(0.0);
        let i = (f as usize).min(self.conformity.len() - 2);
        let r = f - i as f64;
        self.conformity[i] * (1.0 - r) + self.conformity[i + 1] * r
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn pixel_events(
        &self,
        p: &Pixel,
        level: usize,
        c: f64,
        dir: f64,
        board_y: f64,
        slide: f64,
        motion: &TimeTable,
        tl: &Timeline,
        grid: i64,
        refractory: i64,
        out: &mut Vec<Event>,
    ) {
        let amp = self.amplitude * self.gain[level];
        // The texture can only fire a pixel whose thresholds its swing reaches.
        if 2.0 * amp < p.theta_on.min(p.theta_off) as f64 {
            return;
        }
        // Phase under the pixel as the slide goes on: psi(s) = psi0 + rate * s, where the pixel
        // sees board x = dir * (c + s).
        let rate = (dir * self.k_x).abs();
        let sign = (dir * self.k_x).signum();
        let psi0 = sign * (self.k_x * dir * c + self.k_y * board_y) - self.lag_rad[level];
        let mut st = PixelState { reference: 0.0, last_t_us: i64::MIN };
        // Half periods between extremes of cos(psi): psi = m * pi.
        let first = (psi0 / std::f64::consts::PI).floor() as i64;
        let last = ((psi0 + rate * slide) / std::f64::consts::PI).ceil() as i64;
        let value = |psi: f64, s: f64| (amp * self.conformity_at(s) * psi.cos()) as f32;
        let s_of = |psi: f64| ((psi - psi0) / rate).clamp(0.0, slide);
        let mut started = false;
        for m in first..last {
            let (psi_a, psi_b) = ((m as f64 * std::f64::consts::PI).max(psi0), ((m + 1) as f64 * std::f64::consts::PI));
            let psi_b = psi_b.min(psi0 + rate * slide);
            if psi_b <= psi_a {
                continue;
            }
            let (sa, sb) = (s_of(psi_a), s_of(psi_b));
            let (a, b) = (value(psi_a, sa), value(psi_b, sb));
            if !started {
                // The reference starts where the texture is when the slide begins.
                st.reference = a;
                started = true;
            }
            let mid_conformity = self.conformity_at((sa + sb) / 2.0);
            let peak = amp * mid_conformity;
            st.ramp(
                p,
                a,
                b,
                |f| {
                    let v = (a + f as f32 * (b - a)) as f64;
                    let cos = if peak > 0.0 { (v / peak).clamp(-1.0, 1.0) } else { 0.0 };
                    // psi in [m pi, (m + 1) pi]: cos falls on even m, rises on odd m.
                    let base = m as f64 * std::f64::consts::PI;
                    let psi =
                        if m.rem_euclid(2) == 0 { base + cos.acos() } else { base + std::f64::consts::PI - cos.acos() };
                    tl.slide_start_s + motion.time_of(s_of(psi.clamp(psi_a, psi_b)))
                },
                grid,
                refractory,
                out,
            );
        }
    }
}

/// First-order low-pass along the travel coordinate, exact for a piecewise-linear input.
pub(super) fn low_pass(x: &[f32], step: f64, tau: f64) -> Vec<f32> {
    if tau <= 0.0 {
        return x.to_vec();
    }
    let e = (-step / tau).exp();
    let mut y = Vec::with_capacity(x.len());
    let mut prev_y = 0.0f64;
    let mut prev_x = 0.0f64;
    for &xi in x {
        let xi = xi as f64;
        let m = (xi - prev_x) / step;
        prev_y = xi - m * tau + (prev_y - prev_x + m * tau) * e;
        prev_x = xi;
        y.push(prev_y as f32);
    }
    y
}

pub(super) fn monotone_runs(v: &[f32]) -> Vec<(u32, u32)> {
    let mut runs = Vec::new();
    let mut start = 0usize;
    let mut trend = 0i8;
    for j in 1..v.len() {
        let d = v[j] - v[j - 1];
        let s = if d > 0.0 {
            1
        } else if d < 0.0 {
            -1
        } else {
            0
        };
        if s != 0 && trend != 0 && s != trend {
            runs.push((start as u32, (j - 1) as u32));
            start = j - 1;
        }
        if s != 0 {
            trend = s;
        }
    }
    if v.len() > 1 {
        runs.push((start as u32, (v.len() - 1) as u32));
    }
    runs
}

pub(super) struct Pixel {
    pub(super) x: u16,
    pub(super) y: u16,
    pub(super) theta_on: f32,
    pub(super) theta_off: f32,
    pub(super) tau_s: f64,
}

/// A pixel's memory: its reference level and when it last fired.
pub(super) struct PixelState {
    pub(super) reference: f32,
    pub(super) last_t_us: i64,
}

impl PixelState {
    /// Emits an event at `t_s` on the readout grid, respecting the refractory period.
    pub(super) fn fire(
        &mut self,
        p: &Pixel,
        t_s: f64,
        polarity: Polarity,
        grid: i64,
        refractory: i64,
        out: &mut Vec<Event>,
    ) {
        let t_us = (t_s * 1e6).ceil() as i64;
        let mut t = t_us.div_euclid(grid) * grid + if t_us.rem_euclid(grid) == 0 { 0 } else { grid };
        if self.last_t_us != i64::MIN && t < self.last_t_us + refractory {
            let earliest = self.last_t_us + refractory;
            t = earliest.div_euclid(grid) * grid + if earliest.rem_euclid(grid) == 0 { 0 } else { grid };
        }
        self.last_t_us = t;
        out.push(Event { t_us: t, x: p.x, y: p.y, polarity });
    }

    /// Crossings of the signal going linearly from `a` to `b` over times `t0..t1`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn ramp(
        &mut self,
        p: &Pixel,
        a: f32,
        b: f32,
        time: impl Fn(f64) -> f64,
        grid: i64,
        refractory: i64,
        out: &mut Vec<Event>,
    ) {
        if b > a {
            while b >= self.reference + p.theta_on {
                self.reference += p.theta_on;
                let f = ((self.reference - a) / (b - a)).clamp(0.0, 1.0) as f64;
                self.fire(p, time(f), Polarity::On, grid, refractory, out);
            }
        } else if b < a {
            while b <= self.reference - p.theta_off {
                self.reference -= p.theta_off;
                let f = ((a - self.reference) / (a - b)).clamp(0.0, 1.0) as f64;
                self.fire(p, time(f), Polarity::Off, grid, refractory, out);
            }
        }
    }
}

/// Value of a span's samples at travel coordinate `q` (0 outside).
pub(super) fn value_at(span: &Span, samples: &[f32], q: f64, step: f64) -> f32 {
    let f = (q - span.p0) / step;
    if f < 0.0 || f >= (samples.len() - 1) as f64 {
        return 0.0;
    }
    let j = f as usize;
    let t = (f - j as f64) as f32;
    samples[j] * (1.0 - t) + samples[j + 1] * t
}

#[allow(clippy::too_many_arguments)]
pub(super) fn pixel_events(
    p: &Pixel,
    recovery: (f64, f64),
    spans: &[Span],
    level: usize,
    c: f64,
    slide: f64,
    step: f64,
    motion: &TimeTable,
    tl: &Timeline,
    grid: i64,
    refractory: i64,
    out: &mut Vec<Event>,
) {
    let (q0, q1) = (c, c + slide);
    let first = spans.partition_point(|s| s.p0 + (s.raw.len() as f64) * step < q0);
    let mut st = PixelState { reference: 0.0, last_t_us: i64::MIN };
    // Lowering: contrast appears where a dot is already under the pixel.
    let start_value = spans.get(first).map_or(0.0, |s| value_at(s, &s.raw, q0, step));
    if start_value != 0.0 {
        st.ramp(p, 0.0, start_value, |f| f * tl.lowered_s, grid, refractory, out);
    }
    let time_at = |q: f64| tl.slide_start_s + motion.time_of((q - c).clamp(0.0, slide));
    for span in &spans[first..] {
        if span.p0 > q1 {
            break;
        }
        let v = &span.filtered[level];
        for &(j0, j1) in &span.runs[level] {
            let (j0, j1) = (j0 as usize, j1 as usize);
            let (pa, pb) = (span.p0 + j0 as f64 * step, span.p0 + j1 as f64 * step);
            if pb < q0 || pa > q1 {
                continue;
            }
            let (va, vb) = (v[j0], v[j1]);
            // Within a monotone run only one polarity can fire; skip runs that cannot reach a level.
            let fully_inside = pa >= q0 && pb <= q1;
            if fully_inside
                && ((vb >= va && vb < st.reference + p.theta_on) || (vb < va && vb > st.reference - p.theta_off))
            {
                continue;
            }
            if fully_inside {
                // Within a monotone run, jump to the segment where the next level is crossed
                // (the same segments and crossings as walking every sample, in log time).
                let rising = vb >= va;
                let mut from = j0;
                while from < j1 {
                    let level = if rising { st.reference + p.theta_on } else { st.reference - p.theta_off };
                    let before = |j: usize| if rising { v[j + 1] < level } else { v[j + 1] > level };
                    // The first segment from `from` whose end reaches the level.
                    let (mut lo, mut hi) = (from, j1);
                    while lo < hi {
                        let mid = lo + (hi - lo) / 2;
                        if before(mid) { lo = mid + 1 } else { hi = mid }
                    }
                    let j = lo;
                    if j >= j1 {
                        break;
                    }
                    let (qa, qb) = (span.p0 + j as f64 * step, span.p0 + (j + 1) as f64 * step);
                    st.ramp(p, v[j], v[j + 1], |f| time_at(qa + f * (qb - qa)), grid, refractory, out);
                    from = j + 1;
                }
                continue;
            }
            for j in j0..j1 {
                let (mut qa, mut qb) = (span.p0 + j as f64 * step, span.p0 + (j + 1) as f64 * step);
                let (mut a, mut b) = (v[j], v[j + 1]);
                if qb < q0 || qa > q1 {
                    continue;
                }
                if qa < q0 {
                    a = value_at(span, v, q0, step);
                    qa = q0;
                }
                if qb > q1 {
                    b = value_at(span, v, q1, step);
                    qb = q1;
                }
                st.ramp(p, a, b, |f| time_at(qa + f * (qb - qa)), grid, refractory, out);
            }
        }
    }
    // Hold: the photoreceptor settles on the brightness under the pixel; then lifting removes it.
    let end = spans[first..].iter().find(|s| s.p0 <= q1 && q1 < s.p0 + s.raw.len() as f64 * step);
    if let Some(span) = end {
        let (y0, x) = (value_at(span, &span.filtered[level], q1, step), value_at(span, &span.raw, q1, step));
        if (y0 - x).abs() > 1e-6 {
            // y(t) = x + (y0 - x) exp(-t / tau): the crossing of level L is at tau * ln((y0 - x) / (L - x)).
            let tau = p.tau_s;
            st.ramp(
                p,
                y0,
                x,
                |f| {
                    let level = y0 as f64 + f * (x - y0) as f64;
                    let r = ((y0 - x) as f64 / (level - x as f64)).max(1.0);
                    tl.slide_end_s + (tau * r.ln()).min(tl.lift_start_s - tl.slide_end_s)
                },
                grid,
                refractory,
                out,
            );
        }
        if x != 0.0 {
            // The gel's elastic share lets go as the sensor lifts; a relaxing share follows with its
            // time constant (`recovery` = (fraction, tau) of the gel, zero without relaxation).
            let (g, tau) = recovery;
            let lift_end = tl.end_s - tl.recovery_s;
            let rest = x * g as f32;
            st.ramp(p, x, rest, |f| tl.lift_start_s + f * (lift_end - tl.lift_start_s), grid, refractory, out);
            if rest != 0.0 {
                st.ramp(
                    p,
                    rest,
                    0.0,
                    |f| {
                        let left = (1.0 - f).max(1e-9);
                        (lift_end - tau * left.ln()).min(tl.end_s)
                    },
                    grid,
                    refractory,
                    out,
                );
            }
        }
    }
}
