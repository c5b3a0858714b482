//! Sigma-delta encoding of sampled analog signals (for example taxel pressures) into events: an
//! ON event each time the signal rises `threshold` above its reference level, an OFF event each
//! time it falls `threshold` below; the reference then moves by `threshold`, so a large step
//! gives several events.

use crate::error::{Error, Result};
use crate::event::{Event, Polarity};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SigmaDeltaConfig {
    /// Change of the signal, in its own units, that produces one event.
    pub threshold: f32,
    /// Place each event at the linearly interpolated time the signal crossed its level, instead
    /// of at the time of the sample that revealed it.
    pub interpolate: bool,
}

impl Default for SigmaDeltaConfig {
    fn default() -> Self {
        Self { threshold: 2.0, interpolate: false }
    }
}

/// Encodes frames of `channels` values sampled every `period_us` (row-major: frame after frame)
/// into events with `x = channel`, `y = 0`, in time order. The reference of each channel starts
/// at its first sample.
pub fn encode(config: &SigmaDeltaConfig, frames: &[f32], channels: usize, period_us: i64) -> Result<Vec<Event>> {
    if !(config.threshold > 0.0 && config.threshold.is_finite()) {
        return Err(Error::config("sigma-delta threshold", format!("must be positive, got {}", config.threshold)));
    }
    if channels == 0 || channels > u16::MAX as usize || !frames.len().is_multiple_of(channels) {
        return Err(Error::config(
            "frames",
            format!("{} samples do not form frames of {channels} channels", frames.len()),
        ));
    }
    if let Some(i) = frames.iter().position(|v| !v.is_finite()) {
        return Err(Error::config(
            "frames",
            format!("sample {i} (frame {}, channel {}) is not finite", i / channels, i % channels),
        ));
    }
    let th = config.threshold as f64;
    let mut reference: Vec<f64> = frames.iter().take(channels).map(|&v| v as f64).collect();
    let mut events = Vec::new();
    let mut frame_events: Vec<Event> = Vec::new();
    for (k, frame) in frames.chunks_exact(channels).enumerate().skip(1) {
        let t_prev = (k as i64 - 1) * period_us;
        let t_now = k as i64 * period_us;
        frame_events.clear();
        for (c, &v) in frame.iter().enumerate() {
            let prev = frames[(k - 1) * channels + c] as f64;
            let v = v as f64;
            let r = &mut reference[c];
            let mut emit = |level: f64, polarity| {
                let t = if config.interpolate && v != prev {
                    let frac = ((level - prev) / (v - prev)).clamp(0.0, 1.0);
                    t_prev + (frac * period_us as f64).round().max(1.0) as i64
                } else {
                    t_now
                };
                frame_events.push(Event::new(t, c as u16, 0, polarity));
            };
            while v - *r >= th {
                *r += th;
                emit(*r, Polarity::On);
            }
            while *r - v >= th {
                *r -= th;
                emit(*r, Polarity::Off);
            }
        }
        frame_events.sort_by_key(|e| (e.t_us, e.x));
        events.extend_from_slice(&frame_events);
    }
    Ok(events)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_give_one_event_per_threshold() {
        let cfg = SigmaDeltaConfig { threshold: 2.0, interpolate: false };
        // one channel: 0 -> 5 (two ON, reference 4) -> 4.5 (none) -> 0 (two OFF, reference 0)
        let ev = encode(&cfg, &[0.0, 5.0, 4.5, 0.0], 1, 25_000).unwrap();
        let pols: Vec<_> = ev.iter().map(|e| (e.t_us, e.polarity)).collect();
        assert_eq!(
            pols,
            vec![(25_000, Polarity::On), (25_000, Polarity::On), (75_000, Polarity::Off), (75_000, Polarity::Off)]
        );
    }

    #[test]
    fn interpolated_times_fall_inside_the_interval_and_stay_sorted() {
        let cfg = SigmaDeltaConfig { threshold: 1.0, interpolate: true };
        let frames = [0.0, 10.0, 4.0, 0.0]; // two channels, two frames
        let ev = encode(&cfg, &frames, 2, 1000).unwrap();
        assert_eq!(ev.iter().filter(|e| e.x == 0).count(), 4);
        assert_eq!(ev.iter().filter(|e| e.x == 1).count(), 10);
        assert!(ev.windows(2).all(|w| w[0].t_us <= w[1].t_us));
        assert!(ev.iter().all(|e| e.t_us > 0 && e.t_us <= 1000));
    }

    #[test]
    fn bad_input_is_rejected() {
        let cfg = SigmaDeltaConfig::default();
        assert!(encode(&cfg, &[1.0, 2.0, 3.0], 2, 10).is_err());
        assert!(encode(&cfg, &[1.0, f32::NAN], 1, 10).is_err());
        assert!(encode(&SigmaDeltaConfig { threshold: 0.0, interpolate: false }, &[1.0], 1, 10).is_err());
    }
}
