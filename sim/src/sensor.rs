//! The sensor: an event camera (DVXplorer Mini) behind a gel (GelSight Mini), and one physical
//! instance of it (per-pixel thresholds, background, hot pixels) drawn from its seed; with a
//! [`SensorVariation`], the seed also draws what differs between builds of the sensor (gel
//! thickness and hardness, LED brightness and shading, threshold spread, noise rates, hot pixels).

use crate::error::{Error, Result, check};
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
    /// Standard deviation of each event's latency before readout (assumed; the DVXplorer's
    /// datasheet gives a latency under 1 ms). 0 for none.
    #[serde(default)]
    pub latency_jitter_us: f64,
    /// The readout's event-rate limit (DVXplorer: 165 M events/s, datasheet). In the default
    /// variable-rate mode a readout frame lasts `max(readout_grid_us, events / limit)`: on overload
    /// frames stretch and events arrive late, none is dropped (libcaer's defaults, REALISM.md 2).
    /// `None` for an unlimited readout on the fixed grid.
    #[serde(default)]
    pub event_rate_limit_hz: Option<f64>,
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
            latency_jitter_us: 0.0,
            event_rate_limit_hz: None,
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
        const POSITIVE: &str = "a positive number";
        const NON_NEGATIVE: &str = "zero or more";
        check("fov_width_mm", self.fov_width_mm, f64::MIN_POSITIVE..1e3, POSITIVE)?;
        check("threshold_on", self.threshold_on, f64::MIN_POSITIVE..10.0, POSITIVE)?;
        check("threshold_off", self.threshold_off, f64::MIN_POSITIVE..10.0, POSITIVE)?;
        check("threshold_sigma", self.threshold_sigma, 0.0..10.0, NON_NEGATIVE)?;
        check("refractory_us", self.refractory_us, 0.., NON_NEGATIVE)?;
        check("readout_grid_us", self.readout_grid_us, 1.., "at least 1 us")?;
        check("photoreceptor_cutoff_hz", self.photoreceptor_cutoff_hz, f64::MIN_POSITIVE..1e9, POSITIVE)?;
        check("leak_hz_per_pixel", self.leak_hz_per_pixel, 0.0..1e6, NON_NEGATIVE)?;
        check("shot_hz_per_pixel", self.shot_hz_per_pixel, 0.0..1e6, NON_NEGATIVE)?;
        check("hot_pixel_hz", self.hot_pixel_hz, 0.0..1e6, NON_NEGATIVE)?;
        check("background_dn", self.background_dn, f64::MIN_POSITIVE..=255.0, "in (0, 255] DN")?;
        check("background_falloff", self.background_falloff, 0.0..1.0, "in [0, 1)")?;
        check("latency_jitter_us", self.latency_jitter_us, 0.0..1e6, NON_NEGATIVE)?;
        if let Some(limit) = self.event_rate_limit_hz {
            check("event_rate_limit_hz", limit, 1.0..1e12, "at least 1 event/s")?;
        }
        if self.resolution.width == 0 || self.resolution.height == 0 {
            return Err(Error::out_of_range("resolution", self.resolution, "at least 1x1 pixels"));
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
    /// The gel's mechanics during a slide; the default has none (the surface follows the board).
    #[serde(default)]
    pub dynamics: GelDynamics,
}

/// One term of a Prony series: a fraction of the gel's modulus that relaxes with a time constant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PronyTerm {
    pub fraction: f64,
    pub tau_s: f64,
}

/// What the gel does besides taking the board's shape: viscoelastic recovery and friction.
///
/// - Recovery: where the board presses, the gel's surface takes the board's shape (contact is a
///   one-sided constraint). Where the board lets go, each Prony term's share of the indentation
///   recovers with its time constant (a standard linear solid per term), so the surface lags
///   behind a dot that has passed: a trailing smear of length speed x tau, and a loop between
///   pressing and releasing. A term much slower than a dot's passage barely loads and so leaves
///   almost nothing behind; one much faster recovers at once; the smear peaks in between.
/// - Friction: the board drags the gel's surface along, tangentially, by Cerruti's displacement of
///   a Hertz contact under the kinetic friction force, `u = mu F (2 - nu) / (4 pi G a)`, decaying as
///   `a / r` outside the contact. A marker-free gel shows it only through the shape of the surface
///   around each dot, which it shifts towards the board's motion.
/// - Modulus and thickness give the contact force (Hertz, for the dots) and the pressure of the
///   flat board face against the gel (`E delta / thickness`), which sets how much of the print
///   texture the gel takes (Johnson's full-contact pressure of a wavy surface, `pi E* A / lambda`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GelDynamics {
    pub relaxation: Vec<PronyTerm>,
    /// Kinetic friction coefficient of the gel on the board (0: frictionless).
    pub friction: f64,
    /// Young's modulus (GelSight Mini: 0.435 MPa, from FEATS's Neo-Hookean fit, REALISM.md 1).
    pub modulus_mpa: f64,
    /// Poisson's ratio (0.5: incompressible, as FEATS's fit).
    pub poisson_ratio: f64,
    /// Gel thickness at the centre (FEATS's CAD: about 4.0 mm).
    pub thickness_mm: f64,
}

impl Default for GelDynamics {
    fn default() -> Self {
        Self { relaxation: Vec::new(), friction: 0.0, modulus_mpa: 0.435, poisson_ratio: 0.5, thickness_mm: 4.0 }
    }
}

impl GelDynamics {
    /// The share of the modulus that relaxes.
    pub fn relaxing_fraction(&self) -> f64 {
        self.relaxation.iter().map(|t| t.fraction).sum()
    }

    /// The relaxing share and its mean time constant (weighted by share), for the recovery after a
    /// lift; terms slower than 1 s are left out (they barely load during a press).
    pub fn recovery(&self) -> (f64, f64) {
        let fast = self.relaxation.iter().filter(|t| t.tau_s <= 1.0);
        let g: f64 = fast.clone().map(|t| t.fraction).sum();
        if g <= 0.0 {
            return (0.0, 0.0);
        }
        (g, fast.map(|t| t.fraction * t.tau_s).sum::<f64>() / g)
    }

    /// Plane-strain modulus `E / (1 - nu^2)`, in MPa.
    pub fn contact_modulus_mpa(&self) -> f64 {
        self.modulus_mpa / (1.0 - self.poisson_ratio * self.poisson_ratio)
    }

    /// Hertz normal force of a sphere of radius `r` pressed `d` into the gel, in newtons.
    pub fn hertz_force_n(&self, r_mm: f64, d_mm: f64) -> f64 {
        // MPa x mm^2 = N.
        4.0 / 3.0 * self.contact_modulus_mpa() * r_mm.sqrt() * d_mm.max(0.0).powf(1.5)
    }

    /// Tangential surface displacement at the edge of a contact of radius `a` carrying `force_n`
    /// normally, under kinetic friction (Cerruti), in mm.
    pub fn drag_mm(&self, force_n: f64, a_mm: f64) -> f64 {
        if a_mm <= 0.0 || self.friction <= 0.0 {
            return 0.0;
        }
        let shear_mpa = self.modulus_mpa / (2.0 * (1.0 + self.poisson_ratio));
        self.friction * force_n * (2.0 - self.poisson_ratio) / (4.0 * std::f64::consts::PI * shear_mpa * a_mm)
    }

    pub fn validate(&self) -> Result<()> {
        for t in &self.relaxation {
            check("relaxation.fraction", t.fraction, 0.0..1.0, "in [0, 1)")?;
            check("relaxation.tau_s", t.tau_s, f64::MIN_POSITIVE..1e6, "a positive time")?;
        }
        check("relaxation (sum of fractions)", self.relaxing_fraction(), 0.0..1.0, "below 1")?;
        check("friction", self.friction, 0.0..10.0, "zero or more")?;
        check("modulus_mpa", self.modulus_mpa, f64::MIN_POSITIVE..1e4, "a positive modulus")?;
        check("poisson_ratio", self.poisson_ratio, 0.0..=0.5, "in [0, 0.5]")?;
        check("thickness_mm", self.thickness_mm, f64::MIN_POSITIVE..100.0, "a positive thickness")?;
        Ok(())
    }
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
            dynamics: GelDynamics::default(),
        }
    }
}

impl GelConfig {
    pub fn validate(&self) -> Result<()> {
        check("reference_depth_mm", self.reference_depth_mm, f64::MIN_POSITIVE..100.0, "a positive depth")?;
        check("conformity_exponent", self.conformity_exponent, 0.0..10.0, "zero or more")?;
        check("gel_blur_mm", self.gel_blur_mm, 0.0..10.0, "zero or more")?;
        check("light_count", self.light_count, 1..1000, "at least one light")?;
        check("light_elevation_deg", self.light_elevation_deg, 0.0..=90.0, "in [0, 90] degrees")?;
        check("ambient", self.ambient, f64::MIN_POSITIVE..1e3, "positive")?;
        check("diffuse", self.diffuse, 0.0..1e3, "zero or more")?;
        check("specular", self.specular, 0.0..1e3, "zero or more")?;
        check("shininess", self.shininess, 0.0..1e4, "zero or more")?;
        check("optics_blur_px", self.optics_blur_px, 0.0..100.0, "zero or more")?;
        self.dynamics.validate()
    }
}

/// How builds of the sensor differ from one another: the spreads from which a sensor seed draws
/// one instance ([`Sensor::instance`]). Zero everywhere (the default) gives the nominal build.
/// Sources and reasoning for each value are in docs/simulator.md; most are assumed (REALISM.md 5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorVariation {
    /// Gel thickness (assumed: +-0.1-0.2 mm for a cast gel, taken as 2 sigma).
    pub gel_thickness_sigma_mm: f64,
    /// Relative spread of the gel's modulus (assumed: +-3 Shore 00 points, about +-10% in E).
    pub modulus_rel_sigma: f64,
    /// Relative spread of the LED's brightness behind the gel (assumed: +-10-20% between builds).
    pub led_gain_rel_sigma: f64,
    /// Range of the shading's fall-off away from the LED side (assumed: 20-40% edge to centre).
    pub falloff_range: (f64, f64),
    /// Range of the pixel-to-pixel threshold spread, relative to the threshold (assumed: 10-20%;
    /// DVS128: 2.1%, v2e: 0.03 on 0.2).
    pub threshold_rel_sigma_range: (f64, f64),
    /// Spread of the background-activity rate between units, in decades (v2e: 0.1).
    pub noise_rate_sigma_decades: f64,
    /// Expected fraction of hot pixels and their rates (assumed: 0.01-0.1% of pixels above
    /// 10 Hz); rates are drawn log-uniform in the range.
    pub hot_pixel_fraction: f64,
    pub hot_pixel_hz_range: (f64, f64),
    /// Relative spread of the field of view's width on the gel, the optics' scale in mm per pixel
    /// (assumed: a hand-assembled build's lens and mount; docs/simulator.md). Drawn from a stream
    /// of its own and clipped at 3 sigma. Files written before it existed read 0 (every build
    /// with the nominal 18.6 mm).
    #[serde(default)]
    pub fov_rel_sigma: f64,
}

impl Default for SensorVariation {
    fn default() -> Self {
        Self {
            gel_thickness_sigma_mm: 0.0,
            modulus_rel_sigma: 0.0,
            led_gain_rel_sigma: 0.0,
            falloff_range: (0.4, 0.4),
            threshold_rel_sigma_range: (0.0, 0.0),
            noise_rate_sigma_decades: 0.0,
            hot_pixel_fraction: 0.0,
            hot_pixel_hz_range: (10.0, 10.0),
            fov_rel_sigma: 0.0,
        }
    }
}

impl SensorVariation {
    /// No variation at all: [`Sensor::instance`] then equals [`Sensor::new`].
    pub fn is_none(&self) -> bool {
        *self == SensorVariation::default()
    }

    pub fn validate(&self) -> Result<()> {
        let range = |name: &'static str, (lo, hi): (f64, f64), max: f64| {
            check(name, lo, 0.0..=max, "a range within bounds")?;
            check(name, hi, lo..=max, "a range whose end is not below its start")
        };
        check("gel_thickness_sigma_mm", self.gel_thickness_sigma_mm, 0.0..1.0, "in [0, 1) mm")?;
        check("modulus_rel_sigma", self.modulus_rel_sigma, 0.0..0.5, "in [0, 0.5)")?;
        check("led_gain_rel_sigma", self.led_gain_rel_sigma, 0.0..0.5, "in [0, 0.5)")?;
        range("falloff_range", self.falloff_range, 0.99)?;
        range("threshold_rel_sigma_range", self.threshold_rel_sigma_range, 1.0)?;
        check("noise_rate_sigma_decades", self.noise_rate_sigma_decades, 0.0..2.0, "in [0, 2) decades")?;
        check("hot_pixel_fraction", self.hot_pixel_fraction, 0.0..0.1, "in [0, 0.1)")?;
        range("hot_pixel_hz_range", self.hot_pixel_hz_range, 1e5)?;
        check("fov_rel_sigma", self.fov_rel_sigma, 0.0..0.2, "in [0, 0.2)")?;
        Ok(())
    }

    /// The build a seed draws: the camera and gel of one unit.
    pub fn draw(&self, camera: &CameraConfig, gel: &GelConfig, seed: u64) -> Result<(CameraConfig, GelConfig)> {
        self.validate()?;
        let (mut camera, mut gel) = (camera.clone(), gel.clone());
        if self.is_none() {
            return Ok((camera, gel));
        }
        // A stream of its own, so that the per-pixel draws of `Sensor::new` keep their seed.
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5345_4e53_4f52_5641);
        let unit = Normal::new(0.0, 1.0).map_err(Error::distribution("unit normal"))?;
        let mut z = || unit.sample(&mut rng);
        let (z_thick, z_mod, z_led, z_noise) = (z(), z(), z(), z());
        let d = &mut gel.dynamics;
        d.thickness_mm = (d.thickness_mm + self.gel_thickness_sigma_mm * z_thick).max(0.5 * d.thickness_mm);
        d.modulus_mpa *= (1.0 + self.modulus_rel_sigma * z_mod).max(0.5);
        camera.background_dn = (camera.background_dn * (1.0 + self.led_gain_rel_sigma * z_led).max(0.3)).min(255.0);
        let between = |(lo, hi): (f64, f64), rng: &mut ChaCha8Rng| if hi > lo { rng.random_range(lo..hi) } else { lo };
        camera.background_falloff = between(self.falloff_range, &mut rng);
        let rel = between(self.threshold_rel_sigma_range, &mut rng);
        if rel > 0.0 {
            camera.threshold_sigma = rel * 0.5 * (camera.threshold_on + camera.threshold_off);
        }
        let noise_gain = 10f64.powf(self.noise_rate_sigma_decades * z_noise);
        camera.leak_hz_per_pixel *= noise_gain;
        // Shot noise grows in darker pixels (v2e); the LED's gain moves it.
        camera.shot_hz_per_pixel *= noise_gain * (1.0 + self.led_gain_rel_sigma * z_led).max(0.3).recip();
        if self.hot_pixel_fraction > 0.0 {
            let mean = self.hot_pixel_fraction * camera.resolution.pixels() as f64;
            camera.hot_pixels = rand_distr::Poisson::new(mean)
                .map_err(|e| Error::Distribution { name: "hot_pixel_fraction", source: Box::new(e) })?
                .sample(&mut rng) as usize;
            let (lo, hi) = self.hot_pixel_hz_range;
            camera.hot_pixel_hz = (lo.ln() + (hi.ln() - lo.ln()) * rng.random::<f64>()).exp();
        }
        if self.fov_rel_sigma > 0.0 {
            // A stream of its own, so that the draws above do not move with the optics.
            let mut optics = ChaCha8Rng::seed_from_u64(seed ^ 0x4f50_5449_4353_4d4d);
            let z = unit.sample(&mut optics).clamp(-3.0, 3.0);
            camera.fov_width_mm *= 1.0 + self.fov_rel_sigma * z;
        }
        Ok((camera, gel))
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
    /// One build of the sensor: `variation` drawn from `seed` (see [`SensorVariation::draw`]),
    /// then its pixels, as [`Sensor::new`].
    pub fn instance(camera: &CameraConfig, gel: &GelConfig, variation: &SensorVariation, seed: u64) -> Result<Sensor> {
        let (camera, gel) = variation.draw(camera, gel, seed)?;
        Sensor::new(camera, gel, seed)
    }

    /// The same build with its noise switched off: no leak, shot or hot-pixel events.
    pub fn without_noise(mut self) -> Sensor {
        self.camera = self.camera.without_noise();
        self.hot_pixels.clear();
        self
    }

    pub fn new(camera: CameraConfig, gel: GelConfig, seed: u64) -> Result<Sensor> {
        camera.validate()?;
        gel.validate()?;
        let (w, h) = (camera.resolution.width as usize, camera.resolution.height as usize);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, camera.threshold_sigma).map_err(Error::distribution("threshold_sigma"))?;
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
