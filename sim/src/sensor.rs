//! The sensor: an event camera (DVXplorer Mini) behind a gel (GelSight Mini), and one physical
//! instance of it (per-pixel thresholds, background, hot pixels) drawn from its seed.

use crate::error::{Error, Result};
use encoders::Resolution;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// The event camera. Defaults: DVXplorer Mini (640x480, 200 us readout grid), v2e's pixel model
/// (0.5 ms refractory, 300 Hz photoreceptor, leak 0.01 Hz and shot 0.001 Hz per pixel) and
/// contrast thresholds of SIMULATOR.md (N(0.25, 0.03) in log units).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraConfig {
    pub resolution: Resolution,
    /// Width of the field of view on the gel (GelSight Mini: about 18.6 x 14.3 mm).
    pub fov_width_mm: f64,
    /// Mean ON and OFF contrast thresholds (natural log units) and their per-pixel spread.
    pub threshold_on: f64,
    pub threshold_off: f64,
    pub threshold_sigma: f64,
    pub refractory_us: i64,
    /// Timestamps are read out on this grid.
    pub readout_grid_us: i64,
    /// Photoreceptor cutoff at full brightness (255 DN); darker pixels are slower, as in v2e:
    /// cutoff x (I + 20) / 275.
    pub photoreceptor_cutoff_hz: f64,
    pub leak_hz_per_pixel: f64,
    pub shot_hz_per_pixel: f64,
    /// Hot pixels (assumed: a few per sensor) and their rate.
    pub hot_pixels: usize,
    pub hot_pixel_hz: f64,
    /// Mean background brightness behind the gel, in DN, and its fall-off towards the far side
    /// from the LED strip (assumed: a side-lit gel is not uniform).
    pub background_dn: f64,
    pub background_falloff: f64,
}

impl Default for CameraConfig {
    fn default() -> Self {
        Self {
            resolution: Resolution::DVXPLORER,
            fov_width_mm: 18.6,
            threshold_on: 0.25,
            threshold_off: 0.25,
            threshold_sigma: 0.03,
            refractory_us: 500,
            readout_grid_us: 200,
            photoreceptor_cutoff_hz: 300.0,
            leak_hz_per_pixel: 0.01,
            shot_hz_per_pixel: 0.001,
            hot_pixels: 4,
            hot_pixel_hz: 10.0,
            background_dn: 150.0,
            background_falloff: 0.4,
        }
    }
}

impl CameraConfig {
    /// Millimetres on the gel per pixel.
    pub fn pitch_mm(&self) -> f64 {
        self.fov_width_mm / self.resolution.width as f64
    }

    pub fn fov_height_mm(&self) -> f64 {
        self.pitch_mm() * self.resolution.height as f64
    }

    /// The configured noise floor over the whole sensor, in events per second.
    pub fn noise_rate_hz(&self) -> f64 {
        self.resolution.pixels() as f64 * (self.leak_hz_per_pixel + self.shot_hz_per_pixel)
            + self.hot_pixels as f64 * self.hot_pixel_hz
    }

    pub fn without_noise(mut self) -> Self {
        self.leak_hz_per_pixel = 0.0;
        self.shot_hz_per_pixel = 0.0;
        self.hot_pixels = 0;
        self
    }

    pub fn validate(&self) -> Result<()> {
        let checks = [
            ("fov_width_mm", self.fov_width_mm > 0.0),
            ("threshold_on", self.threshold_on > 0.0),
            ("threshold_off", self.threshold_off > 0.0),
            ("threshold_sigma", self.threshold_sigma >= 0.0),
            ("refractory_us", self.refractory_us >= 0),
            ("readout_grid_us", self.readout_grid_us >= 1),
            ("photoreceptor_cutoff_hz", self.photoreceptor_cutoff_hz > 0.0),
            ("leak_hz_per_pixel", self.leak_hz_per_pixel >= 0.0),
            ("shot_hz_per_pixel", self.shot_hz_per_pixel >= 0.0),
            ("hot_pixel_hz", self.hot_pixel_hz >= 0.0),
            ("background_dn", self.background_dn > 0.0 && self.background_dn <= 255.0),
            ("background_falloff", (0.0..1.0).contains(&self.background_falloff)),
            ("resolution", self.resolution.width > 0 && self.resolution.height > 0),
        ];
        for (name, ok) in checks {
            if !ok {
                return Err(Error::Config(format!("camera parameter {name} is out of range")));
            }
        }
        Ok(())
    }
}

/// The gel and its illumination: how a dot pressed into the gel becomes a change of brightness.
///
/// Contact: a dot pressed `d` into the gel touches it over a radius that follows the geometry of
/// the dot's cap, `sqrt(2 R d - d^2)`, up to `reference_depth_mm`; beyond it the gel conforms
/// further with load, Hertz-like, radius growing as depth^`conformity_exponent`. (Geometry alone
/// saturates once the depth exceeds the dot height, which the measured depth trend does not.)
/// The gel surface follows a paraboloid of that radius whose height is the penetration up to the
/// reference depth and then grows with the radius (see [`crate::stamp::indentation_mm`]),
/// smoothed by the gel (`gel_blur_mm`); it is shaded by a grazing light (Phong, as Gomes et al.),
/// and the image is blurred by the optics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GelConfig {
    pub reference_depth_mm: f64,
    /// Exponent of the contact radius's growth with depth beyond the reference. Hertz contact with
    /// a load proportional to depth gives 1/3; 0.28 fits the seed paper's measured events per dot
    /// against depth (`cargo run --release -p sim --example calibrate`), the one parameter
    /// calibrated, and against physics only.
    pub conformity_exponent: f64,
    /// Gaussian smoothing of the surface by the gel and its coating (assumed).
    pub gel_blur_mm: f64,
    /// LEDs lighting the gel from its side (assumed: Evetac's one LED strip, along the side parallel
    /// to the scan, azimuth 90 degrees; 0 is light from +x, the scan axis), their elevation above
    /// the gel plane (assumed: grazing, 30 degrees), spread evenly in azimuth when more than one.
    pub light_count: usize,
    pub light_elevation_deg: f64,
    pub light_azimuth_deg: f64,
    pub ambient: f64,
    pub diffuse: f64,
    pub specular: f64,
    pub shininess: f64,
    /// Optics blur (Gaussian sigma) in pixels of the 640-pixel-wide image.
    pub optics_blur_px: f64,
}

impl Default for GelConfig {
    fn default() -> Self {
        Self {
            reference_depth_mm: 0.2,
            conformity_exponent: 0.28,
            gel_blur_mm: 0.03,
            light_count: 1,
            light_elevation_deg: 30.0,
            light_azimuth_deg: 90.0,
            ambient: 0.25,
            diffuse: 0.75,
            specular: 0.15,
            shininess: 5.0,
            optics_blur_px: 1.0,
        }
    }
}

impl GelConfig {
    pub fn validate(&self) -> Result<()> {
        let ok = self.reference_depth_mm > 0.0
            && self.conformity_exponent >= 0.0
            && self.gel_blur_mm >= 0.0
            && self.light_count >= 1
            && (0.0..=90.0).contains(&self.light_elevation_deg)
            && self.ambient > 0.0
            && self.diffuse >= 0.0
            && self.specular >= 0.0
            && self.optics_blur_px >= 0.0;
        if ok { Ok(()) } else { Err(Error::Config("gel parameters out of range".into())) }
    }
}

/// One physical sensor: its per-pixel thresholds, background brightness and hot pixels.
#[derive(Debug, Clone)]
pub struct Sensor {
    pub camera: CameraConfig,
    pub gel: GelConfig,
    pub seed: u64,
    /// Per pixel, row-major.
    pub threshold_on: Vec<f32>,
    pub threshold_off: Vec<f32>,
    /// Photoreceptor time constant per pixel, in seconds.
    pub tau_s: Vec<f32>,
    pub hot_pixels: Vec<(u16, u16)>,
}

impl Sensor {
    pub fn new(camera: CameraConfig, gel: GelConfig, seed: u64) -> Result<Sensor> {
        camera.validate()?;
        gel.validate()?;
        let (w, h) = (camera.resolution.width as usize, camera.resolution.height as usize);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, camera.threshold_sigma).map_err(|e| Error::Config(e.to_string()))?;
        let floor = 0.2 * camera.threshold_on.min(camera.threshold_off);
        let mut threshold_on = Vec::with_capacity(w * h);
        let mut threshold_off = Vec::with_capacity(w * h);
        let mut tau_s = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                threshold_on.push((camera.threshold_on + normal.sample(&mut rng)).max(floor) as f32);
                threshold_off.push((camera.threshold_off + normal.sample(&mut rng)).max(floor) as f32);
                // Brightness falls off away from the LED side (x = width) and towards the corners.
                let fx = 1.0 - x as f64 / w as f64;
                let fy = (y as f64 / h as f64 - 0.5) * 2.0;
                let b = camera.background_dn * (1.0 - camera.background_falloff * (0.7 * fx + 0.3 * fy * fy));
                let cutoff = camera.photoreceptor_cutoff_hz * (b + 20.0) / 275.0;
                tau_s.push((1.0 / (2.0 * std::f64::consts::PI * cutoff)) as f32);
            }
        }
        let hot_pixels =
            (0..camera.hot_pixels).map(|_| (rng.random_range(0..w as u16), rng.random_range(0..h as u16))).collect();
        Ok(Sensor { camera, gel, seed, threshold_on, threshold_off, tau_s, hot_pixels })
    }
}
