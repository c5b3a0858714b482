//! The image of one dot pressed into the gel: log-brightness change against the flat gel, on a
//! grid of sensor pixels around the dot. The board moves under the sensor, so a scan's image is
//! the sum of these stamps at the dots' moving positions; the gel's lag and drag during the slide
//! (see [`crate::sensor::GelDynamics`]) are part of each stamp, which therefore depends on the
//! direction and speed of the slide.

use crate::sensor::GelConfig;

/// Log-brightness change around one dot, on a grid with a step of one pixel: `2 half + 1` rows and
/// `x_lo + x_hi + 1` columns (a smear trails on one side).
#[derive(Debug, Clone)]
pub struct Stamp {
    pub half: usize,
    pub x_lo: usize,
    pub x_hi: usize,
    pub values: Vec<f32>,
    /// Contact radius used, in mm.
    pub contact_radius_mm: f64,
    /// The gel's tangential drag at the contact's edge, in mm.
    pub drag_mm: f64,
}

/// How the board moves under the sensor: the sensor slides towards `direction` (+1 forward,
/// -1 reverse along board x) at this speed; in the sensor's frame the dot moves the other way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampMotion {
    pub direction: f64,
    pub speed_mm_s: f64,
}

impl StampMotion {
    /// A dot at rest under the sensor (no lag, no drag).
    pub const STILL: StampMotion = StampMotion { direction: 1.0, speed_mm_s: 0.0 };
}

/// Phong shading relative to the flat gel, summed over the lights around the gel.
struct Shading {
    lights: Vec<([f64; 3], [f64; 3])>,
    share: f64,
    ambient: f64,
    diffuse: f64,
    specular: f64,
    shininess: f64,
    flat: f64,
}

impl Shading {
    fn new(gel: &GelConfig) -> Shading {
        let el = gel.light_elevation_deg.to_radians();
        let lights = (0..gel.light_count)
            .map(|k| {
                let az = gel.light_azimuth_deg.to_radians() + std::f64::consts::TAU * k as f64 / gel.light_count as f64;
                let l = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
                let v = [l[0], l[1], l[2] + 1.0];
                let m = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                (l, [v[0] / m, v[1] / m, v[2] / m])
            })
            .collect();
        let mut s = Shading {
            lights,
            share: 1.0 / gel.light_count as f64,
            ambient: gel.ambient,
            diffuse: gel.diffuse,
            specular: gel.specular,
            shininess: gel.shininess,
            flat: 1.0,
        };
        s.flat = s.shade(0.0, 0.0, 1.0);
        s
    }

    fn shade(&self, nx: f64, ny: f64, nz: f64) -> f64 {
        self.lights.iter().fold(self.ambient, |acc, (l, hv)| {
            let d = (nx * l[0] + ny * l[1] + nz * l[2]).max(0.0);
            let s = (nx * hv[0] + ny * hv[1] + nz * hv[2]).max(0.0).powf(self.shininess);
            acc + self.share * (self.diffuse * d + self.specular * s)
        })
    }

    /// Brightness of a surface of gradient (gx, gy) (towards the camera) over the flat gel's.
    fn relative(&self, gx: f64, gy: f64) -> f64 {
        let m = (gx * gx + gy * gy + 1.0).sqrt();
        self.shade(-gx / m, -gy / m, 1.0 / m) / self.flat
    }
}

/// Half the swing of log brightness of a surface tilted by `slope` (rad, small) back and forth
/// along the direction `azimuth_rad` (0 = +x): the log contrast of a ripple of that slope.
pub fn log_contrast_of_slope(gel: &GelConfig, slope: f64, azimuth_rad: f64) -> f64 {
    let shading = Shading::new(gel);
    let (c, s) = (azimuth_rad.cos(), azimuth_rad.sin());
    let up = shading.relative(slope * c, slope * s).max(1e-6).ln();
    let down = shading.relative(-slope * c, -slope * s).max(1e-6).ln();
    (up - down).abs() / 2.0
}

/// Contact radius of a dot of sphere radius `r` and height `h` pressed `d` into the gel.
pub fn contact_radius_mm(gel: &GelConfig, r: f64, h: f64, d: f64) -> f64 {
    let geometric = |d: f64| {
        let d = d.clamp(0.0, h);
        (2.0 * r * d - d * d).max(0.0).sqrt()
    };
    let d_ref = gel.reference_depth_mm.min(h);
    if d <= d_ref {
        geometric(d)
    } else {
        geometric(d).max(geometric(d_ref) * (d / d_ref).powf(gel.conformity_exponent))
    }
}

/// Height of the gel's indentation by the dot: the penetration up to the reference depth; beyond
/// it the indentation grows in proportion to the contact radius, so that the gel's slope around a
/// dot stays what it can take (the conformity limit) while the contact widens with load.
pub fn indentation_mm(gel: &GelConfig, r: f64, h: f64, d: f64) -> f64 {
    let d_ref = gel.reference_depth_mm.min(h);
    if d <= d_ref {
        d.max(0.0)
    } else {
        let a_ref = contact_radius_mm(gel, r, h, d_ref);
        if a_ref > 0.0 { (d_ref * contact_radius_mm(gel, r, h, d) / a_ref).min(h) } else { d.min(h) }
    }
}

fn gaussian_kernel(sigma: f64) -> Vec<f64> {
    if sigma <= 1e-6 {
        return vec![1.0];
    }
    let k = (3.0 * sigma).ceil() as i64;
    let w: Vec<f64> = (-k..=k).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp()).collect();
    let s: f64 = w.iter().sum();
    w.into_iter().map(|v| v / s).collect()
}

/// Separable blur of an `nx x ny` grid (row-major); values beyond the edge count as `edge`.
/// Every output is the sum over the kernel in its order, so the result does not depend on how
/// the loops run: away from the edges whole rows are accumulated at once (no bounds checks).
fn blur(grid: &mut [f64], nx: usize, ny: usize, sigma: f64, edge: f64) {
    let k = gaussian_kernel(sigma);
    if k.len() == 1 {
        return;
    }
    let r = k.len() / 2;
    let mut tmp = vec![0.0; grid.len()];
    // Along x.
    for i in 0..ny {
        let row = &grid[i * nx..(i + 1) * nx];
        let out = &mut tmp[i * nx..(i + 1) * nx];
        for (j, o) in out.iter_mut().enumerate() {
            let mut s = 0.0;
            if j >= r && j + r < nx {
                for (w, v) in k.iter().zip(&row[j - r..=j + r]) {
                    s += w * v;
                }
            } else {
                for (t, w) in k.iter().enumerate() {
                    let c = (j + t).wrapping_sub(r);
                    s += w * if c >= nx { edge } else { row[c] };
                }
            }
            *o = s;
        }
    }
    // Along y: a row of sums at a time.
    let mut acc = vec![0.0; nx];
    for i in 0..ny {
        acc.fill(0.0);
        for (t, w) in k.iter().enumerate() {
            let c = (i + t).wrapping_sub(r);
            if c >= ny {
                for a in acc.iter_mut() {
                    *a += w * edge;
                }
            } else {
                for (a, v) in acc.iter_mut().zip(&tmp[c * nx..(c + 1) * nx]) {
                    *a += w * v;
                }
            }
        }
        grid[i * nx..(i + 1) * nx].copy_from_slice(&acc);
    }
}

/// Viscoelastic recovery behind a moving dot. At a point of the gel the imposed indentation
/// `U(t)` passes as the dot does; each Prony term's share follows it through a first-order lag of
/// its time constant. Where the board presses, the surface is the board's (a one-sided contact);
/// where it lets go, the surface is the elastic share plus the lagging shares:
/// `max(U, (1 - sum g) U + sum g L_tau(U))`. In the dot's frame the lag is an exponential filter
/// along x of length speed x tau, running towards the side where the dot has been.
fn recover(
    u: &mut [f64],
    nx: usize,
    ny: usize,
    motion: StampMotion,
    pitch_mm: f64,
    terms: &[crate::sensor::PronyTerm],
) {
    let g: f64 = terms.iter().map(|t| t.fraction).sum();
    let mut out: Vec<f64> = u.iter().map(|v| (1.0 - g) * v).collect();
    let columns: Vec<usize> = if motion.direction >= 0.0 { (0..nx).collect() } else { (0..nx).rev().collect() };
    // Each row's filter runs along x; the rows advance together, a column at a time, so that
    // their chains of dependent steps overlap (every value is computed as row by row).
    let mut lagged = vec![0.0; ny];
    for t in terms {
        let length = motion.speed_mm_s * t.tau_s;
        let e = (-pitch_mm / length).exp();
        lagged.fill(0.0);
        for &j in &columns {
            for (i, l) in lagged.iter_mut().enumerate() {
                *l = e * *l + (1.0 - e) * u[i * nx + j];
                out[i * nx + j] += t.fraction * *l;
            }
        }
    }
    for (v, o) in u.iter_mut().zip(out) {
        *v = v.max(o);
    }
}

/// Frictional drag: the board pulls the gel's surface tangentially towards the board's motion in
/// the sensor's frame (against `direction`), by `drag_mm` at the contact's edge, falling as `a / r`
/// outside and as `r / a` inside (where the dot imposes the shape, the drag only moves material
/// along it: this keeps the displacement continuous). The surface shape moves with it.
#[allow(clippy::too_many_arguments)]
fn drag(
    u: &mut [f64],
    nx: usize,
    ny: usize,
    x_lo: usize,
    half: usize,
    pitch_mm: f64,
    a: f64,
    drag_mm: f64,
    direction: f64,
) {
    let src = u.to_vec();
    for i in 0..ny {
        let y = (i as f64 - half as f64) * pitch_mm;
        for j in 0..nx {
            let x = (j as f64 - x_lo as f64) * pitch_mm;
            let r = (x * x + y * y).sqrt();
            let shift = if r < a { drag_mm * r / a } else { drag_mm * a / r };
            // Material now at x came from x + direction * shift (it moved by -direction * shift).
            let fx = j as f64 + direction * shift / pitch_mm;
            let j0 = fx.floor();
            let t = fx - j0;
            let at = |jj: f64| if jj < 0.0 || jj >= nx as f64 { 0.0 } else { src[i * nx + jj as usize] };
            u[i * nx + j] = at(j0) * (1.0 - t) + at(j0 + 1.0) * t;
        }
    }
}

impl Stamp {
    /// The stamp of a dot (sphere radius `r`, height `h`) pressed `d` into the gel, for pixels of
    /// `pitch_mm`; `optics_px_scale` converts the optics blur from 640-pixel-wide pixels. `motion`
    /// sets the gel's lag and drag (none for a gel without dynamics or a dot at rest).
    pub fn new(
        gel: &GelConfig,
        r: f64,
        h: f64,
        d: f64,
        pitch_mm: f64,
        optics_px_scale: f64,
        motion: StampMotion,
    ) -> Stamp {
        let a = contact_radius_mm(gel, r, h, d);
        let amplitude = indentation_mm(gel, r, h, d);
        let dynamics = &gel.dynamics;
        let optics_px = gel.optics_blur_px * optics_px_scale;
        let margin = Self::margin_mm(gel, pitch_mm, optics_px_scale);
        let drag_mm =
            if motion.speed_mm_s > 0.0 { dynamics.drag_mm(dynamics.hertz_force_n(r, d.min(h)), a) } else { 0.0 };
        // The trailing smear: each relaxing term's share recovers over speed x tau behind the dot,
        // kept for four lengths (under 2% of it is left) up to 4 mm. A term slower than that
        // barely loads while a dot passes: at 8 mm/s the 5 s term leaves about g / 40 of the
        // depth, and dropping it beyond 4 mm removes a step of a micron or so.
        let smear_mm = if motion.speed_mm_s > 0.0 {
            dynamics.relaxation.iter().map(|t| 4.0 * motion.speed_mm_s * t.tau_s).fold(0.0, f64::max).min(4.0)
        } else {
            0.0
        };
        let half = Self::half_rows(gel, r, h, d, pitch_mm, optics_px_scale);
        let reach = ((a + margin + 2.0 * drag_mm) / pitch_mm).ceil() as usize + 1;
        let tail = (smear_mm / pitch_mm).ceil() as usize;
        // The smear trails on the side the sensor moves towards (where the dot has been, in the
        // sensor's frame); the drag pulls the surface the other way.
        let (x_lo, x_hi) = if motion.direction >= 0.0 { (reach, reach + tail) } else { (reach + tail, reach) };
        let (ny, nx) = (2 * half + 1, x_lo + x_hi + 1);
        // Surface height towards the camera.
        let mut u = vec![0.0f64; nx * ny];
        let x_of = |j: usize| (j as f64 - x_lo as f64) * pitch_mm;
        let y_of = |i: usize| (i as f64 - half as f64) * pitch_mm;
        if a > 0.0 {
            for i in 0..ny {
                for j in 0..nx {
                    let q = (x_of(j).powi(2) + y_of(i).powi(2)) / (a * a);
                    if q < 1.0 {
                        u[i * nx + j] = amplitude * (1.0 - q);
                    }
                }
            }
        }
        blur(&mut u, nx, ny, gel.gel_blur_mm / pitch_mm, 0.0);
        if smear_mm > 0.0 {
            recover(&mut u, nx, ny, motion, pitch_mm, &dynamics.relaxation);
        }
        if drag_mm > 0.0 {
            drag(&mut u, nx, ny, x_lo, half, pitch_mm, a, drag_mm, motion.direction);
        }
        let shading = Shading::new(gel);
        let mut intensity = vec![1.0f64; nx * ny];
        for i in 1..ny - 1 {
            for j in 1..nx - 1 {
                let gx = (u[i * nx + j + 1] - u[i * nx + j - 1]) / (2.0 * pitch_mm);
                let gy = (u[(i + 1) * nx + j] - u[(i - 1) * nx + j]) / (2.0 * pitch_mm);
                // A flat spot is as bright as the flat gel (exactly 1: the same shading over itself).
                if gx != 0.0 || gy != 0.0 {
                    intensity[i * nx + j] = shading.relative(gx, gy);
                }
            }
        }
        blur(&mut intensity, nx, ny, optics_px, 1.0);
        let values = intensity
            .iter()
            .map(|&v| {
                if v == 1.0 {
                    return 0.0; // ln 1, without the call
                }
                let s = v.max(1e-6).ln();
                if s.abs() < 1e-4 { 0.0 } else { s as f32 }
            })
            .collect();
        Stamp { half, x_lo, x_hi, values, contact_radius_mm: a, drag_mm }
    }

    /// The blurs' reach beyond the contact, in mm.
    fn margin_mm(gel: &GelConfig, pitch_mm: f64, optics_px_scale: f64) -> f64 {
        let optics_px = gel.optics_blur_px * optics_px_scale;
        3.5 * gel.gel_blur_mm + 3.5 * optics_px * pitch_mm + 2.0 * pitch_mm
    }

    /// The `half` of the stamp [`Stamp::new`] makes with these arguments, without making it: a
    /// dot changes no pixel row `half` rows or more from its centre.
    pub fn half_rows(gel: &GelConfig, r: f64, h: f64, d: f64, pitch_mm: f64, optics_px_scale: f64) -> usize {
        let a = contact_radius_mm(gel, r, h, d);
        ((a + Self::margin_mm(gel, pitch_mm, optics_px_scale)) / pitch_mm).ceil() as usize + 1
    }

    /// Bilinear value at an offset from the dot's centre, in pixels (x along the row).
    #[inline]
    pub fn at(&self, dx_px: f64, dy_px: f64) -> f32 {
        let (nx, ny) = (self.x_lo + self.x_hi + 1, 2 * self.half + 1);
        let fx = dx_px + self.x_lo as f64;
        let fy = dy_px + self.half as f64;
        if fx < 0.0 || fy < 0.0 || fx >= (nx - 1) as f64 || fy >= (ny - 1) as f64 {
            return 0.0;
        }
        let (x0, y0) = (fx as usize, fy as usize);
        let (tx, ty) = ((fx - x0 as f64) as f32, (fy - y0 as f64) as f32);
        let v = |y: usize, x: usize| self.values[y * nx + x];
        let top = v(y0, x0) * (1.0 - tx) + v(y0, x0 + 1) * tx;
        let bottom = v(y0 + 1, x0) * (1.0 - tx) + v(y0 + 1, x0 + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// Width of the region (through the centre, along x) where the brightness differs from the
    /// flat gel by more than `min_contrast` log units, in pixels.
    pub fn width_px(&self, min_contrast: f32) -> usize {
        let n = self.x_lo + self.x_hi + 1;
        let row = &self.values[self.half * n..(self.half + 1) * n];
        match (row.iter().position(|v| v.abs() > min_contrast), row.iter().rposition(|v| v.abs() > min_contrast)) {
            (Some(a), Some(b)) => b - a + 1,
            _ => 0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blur as first written: every tap bounds-checked, in kernel order.
    fn blur_reference(grid: &mut [f64], nx: usize, ny: usize, sigma: f64, edge: f64) {
        let k = gaussian_kernel(sigma);
        let r = (k.len() / 2) as i64;
        let mut tmp = vec![0.0; grid.len()];
        for i in 0..ny {
            for j in 0..nx {
                let mut s = 0.0;
                for (t, w) in k.iter().enumerate() {
                    let c = j as i64 + t as i64 - r;
                    s += w * if c < 0 || c >= nx as i64 { edge } else { grid[i * nx + c as usize] };
                }
                tmp[i * nx + j] = s;
            }
        }
        for i in 0..ny {
            for j in 0..nx {
                let mut s = 0.0;
                for (t, w) in k.iter().enumerate() {
                    let c = i as i64 + t as i64 - r;
                    s += w * if c < 0 || c >= ny as i64 { edge } else { tmp[c as usize * nx + j] };
                }
                grid[i * nx + j] = s;
            }
        }
    }

    #[test]
    fn the_blur_equals_its_reference_bit_for_bit() {
        // Grids narrower and wider than the kernel, with and without an edge value.
        for (nx, ny, sigma, edge) in [(37, 23, 2.3, 0.0), (5, 40, 3.0, 1.0), (64, 3, 0.8, 1.0), (9, 9, 4.0, 0.5)] {
            let grid: Vec<f64> = (0..nx * ny).map(|i| ((i * 7919) % 101) as f64 / 37.0 - 1.3).collect();
            let (mut a, mut b) = (grid.clone(), grid);
            blur(&mut a, nx, ny, sigma, edge);
            blur_reference(&mut b, nx, ny, sigma, edge);
            assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "{nx}x{ny}, sigma {sigma}");
        }
    }

    #[test]
    fn contact_radius_follows_geometry_then_load() {
        let g = GelConfig::default();
        // hemisphere of 0.5 mm at 0.2 mm: sqrt(2 * 0.5 * 0.2 - 0.04) = 0.4 mm
        assert!((contact_radius_mm(&g, 0.5, 0.5, 0.2) - 0.4).abs() < 1e-12);
        // beyond the reference depth: 0.4 * (d / 0.2)^exponent
        assert!((contact_radius_mm(&g, 0.5, 0.5, 1.5) - 0.4 * 7.5f64.powf(g.conformity_exponent)).abs() < 1e-12);
        // the indentation grows with the radius and never beyond the dot's height
        assert!(indentation_mm(&g, 0.5, 0.5, 1.5) > indentation_mm(&g, 0.5, 0.5, 0.6));
        assert!(indentation_mm(&g, 0.5, 0.5, 50.0) <= 0.5);
        assert_eq!(contact_radius_mm(&g, 0.5, 0.5, 0.0), 0.0);
    }

    #[test]
    fn stamps_are_zero_far_away_and_contrast_near_the_dot() {
        let g = GelConfig::default();
        let s = Stamp::new(&g, 0.5, 0.5, 0.6, 18.6 / 640.0, 1.0, StampMotion::STILL);
        assert_eq!(s.at(s.half as f64 + 5.0, 0.0), 0.0);
        let peak = s.values.iter().map(|v| v.abs()).fold(0.0f32, f32::max);
        assert!(peak > 0.3, "peak contrast {peak}");
        let corner = s.values[0];
        assert_eq!(corner, 0.0);
    }
}
