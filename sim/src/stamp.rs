//! The image of one dot pressed into the gel: log-brightness change against the flat gel, on a
//! grid of sensor pixels centred on the dot. The board moves rigidly under the sensor, so a scan's
//! image is the sum of these stamps at the dots' moving positions.

use crate::sensor::GelConfig;

/// Log-brightness change around one dot, on a `(2k+1) x (2k+1)` grid with a step of one pixel.
#[derive(Debug, Clone)]
pub struct Stamp {
    pub half: usize,
    pub values: Vec<f32>,
    /// Contact radius used, in mm.
    pub contact_radius_mm: f64,
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

/// Separable blur of an `n x n` grid; values beyond the edge count as `edge`.
fn blur(grid: &mut [f64], n: usize, sigma: f64, edge: f64) {
    let k = gaussian_kernel(sigma);
    if k.len() == 1 {
        return;
    }
    let r = (k.len() / 2) as i64;
    let mut tmp = vec![0.0; grid.len()];
    for pass in 0..2 {
        for a in 0..n {
            for b in 0..n {
                let mut s = 0.0;
                for (j, w) in k.iter().enumerate() {
                    let c = b as i64 + j as i64 - r;
                    let v = if c < 0 || c >= n as i64 {
                        edge
                    } else if pass == 0 {
                        grid[a * n + c as usize]
                    } else {
                        grid[c as usize * n + a]
                    };
                    s += w * v;
                }
                if pass == 0 {
                    tmp[a * n + b] = s;
                } else {
                    tmp[b * n + a] = s;
                }
            }
        }
        grid.copy_from_slice(&tmp);
    }
}

impl Stamp {
    /// The stamp of a dot (sphere radius `r`, height `h`) pressed `d` into the gel, for pixels of
    /// `pitch_mm`; `optics_px_scale` converts the optics blur from 640-pixel-wide pixels.
    pub fn new(gel: &GelConfig, r: f64, h: f64, d: f64, pitch_mm: f64, optics_px_scale: f64) -> Stamp {
        let a = contact_radius_mm(gel, r, h, d);
        let amplitude = indentation_mm(gel, r, h, d);
        let optics_px = gel.optics_blur_px * optics_px_scale;
        let margin = 3.5 * gel.gel_blur_mm + 3.5 * optics_px * pitch_mm + 2.0 * pitch_mm;
        let half = ((a + margin) / pitch_mm).ceil() as usize + 1;
        let n = 2 * half + 1;
        // Surface height towards the camera.
        let mut u = vec![0.0f64; n * n];
        if a > 0.0 {
            for i in 0..n {
                for j in 0..n {
                    let (y, x) = ((i as f64 - half as f64) * pitch_mm, (j as f64 - half as f64) * pitch_mm);
                    let q = (x * x + y * y) / (a * a);
                    if q < 1.0 {
                        u[i * n + j] = amplitude * (1.0 - q);
                    }
                }
            }
        }
        blur(&mut u, n, gel.gel_blur_mm / pitch_mm, 0.0);
        // Phong shading relative to the flat gel, summed over the lights around the gel.
        let el = gel.light_elevation_deg.to_radians();
        let lights: Vec<([f64; 3], [f64; 3])> = (0..gel.light_count)
            .map(|k| {
                let az = gel.light_azimuth_deg.to_radians() + std::f64::consts::TAU * k as f64 / gel.light_count as f64;
                let l = [el.cos() * az.cos(), el.cos() * az.sin(), el.sin()];
                let v = [l[0], l[1], l[2] + 1.0];
                let m = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                (l, [v[0] / m, v[1] / m, v[2] / m])
            })
            .collect();
        let share = 1.0 / gel.light_count as f64;
        let shade = |nx: f64, ny: f64, nz: f64| {
            lights.iter().fold(gel.ambient, |acc, (l, hv)| {
                let d = (nx * l[0] + ny * l[1] + nz * l[2]).max(0.0);
                let s = (nx * hv[0] + ny * hv[1] + nz * hv[2]).max(0.0).powf(gel.shininess);
                acc + share * (gel.diffuse * d + gel.specular * s)
            })
        };
        let flat = shade(0.0, 0.0, 1.0);
        let mut intensity = vec![1.0f64; n * n];
        for i in 1..n - 1 {
            for j in 1..n - 1 {
                let gx = (u[i * n + j + 1] - u[i * n + j - 1]) / (2.0 * pitch_mm);
                let gy = (u[(i + 1) * n + j] - u[(i - 1) * n + j]) / (2.0 * pitch_mm);
                let m = (gx * gx + gy * gy + 1.0).sqrt();
                intensity[i * n + j] = shade(-gx / m, -gy / m, 1.0 / m) / flat;
            }
        }
        blur(&mut intensity, n, optics_px, 1.0);
        let values = intensity
            .iter()
            .map(|&v| {
                let s = v.max(1e-6).ln();
                if s.abs() < 1e-4 { 0.0 } else { s as f32 }
            })
            .collect();
        Stamp { half, values, contact_radius_mm: a }
    }

    /// Bilinear value at an offset from the dot's centre, in pixels (x along the row).
    #[inline]
    pub fn at(&self, dx_px: f64, dy_px: f64) -> f32 {
        let n = 2 * self.half + 1;
        let fx = dx_px + self.half as f64;
        let fy = dy_px + self.half as f64;
        if fx < 0.0 || fy < 0.0 || fx >= (n - 1) as f64 || fy >= (n - 1) as f64 {
            return 0.0;
        }
        let (x0, y0) = (fx as usize, fy as usize);
        let (tx, ty) = ((fx - x0 as f64) as f32, (fy - y0 as f64) as f32);
        let v = |y: usize, x: usize| self.values[y * n + x];
        let top = v(y0, x0) * (1.0 - tx) + v(y0, x0 + 1) * tx;
        let bottom = v(y0 + 1, x0) * (1.0 - tx) + v(y0 + 1, x0 + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// Width of the region (through the centre, along x) where the brightness differs from the
    /// flat gel by more than `min_contrast` log units, in pixels.
    pub fn width_px(&self, min_contrast: f32) -> usize {
        let n = 2 * self.half + 1;
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
        let s = Stamp::new(&g, 0.5, 0.5, 0.6, 18.6 / 640.0, 1.0);
        assert_eq!(s.at(s.half as f64 + 5.0, 0.0), 0.0);
        let peak = s.values.iter().map(|v| v.abs()).fold(0.0f32, f32::max);
        assert!(peak > 0.3, "peak contrast {peak}");
        let corner = s.values[0];
        assert_eq!(corner, 0.0);
    }
}
