//! The one event type of the project, and what a stream declares about itself.

use serde::{Deserialize, Serialize};

/// Polarity of a brightness change: ON (brighter) or OFF (darker).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[repr(u8)]
pub enum Polarity {
    Off = 0,
    On = 1,
}

impl Polarity {
    /// Channel index used by every encoder: OFF = 0, ON = 1.
    #[inline]
    pub fn index(self) -> usize {
        self as usize
    }

    #[inline]
    pub fn from_on(on: bool) -> Self {
        if on { Polarity::On } else { Polarity::Off }
    }

    #[inline]
    pub fn is_on(self) -> bool {
        self == Polarity::On
    }
}

/// One address event: a pixel (or taxel) `x, y` changed with `polarity` at `t_us` microseconds.
///
/// Timestamps are signed 64-bit microseconds, as AEDAT4 stores them (DV writes Unix time).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Event {
    pub t_us: i64,
    pub x: u16,
    pub y: u16,
    pub polarity: Polarity,
}

impl Event {
    #[inline]
    pub fn new(t_us: i64, x: u16, y: u16, polarity: Polarity) -> Self {
        Self { t_us, x, y, polarity }
    }
}

/// Sensor size in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Resolution {
    pub width: u16,
    pub height: u16,
}

impl Resolution {
    /// The DVXplorer (Mini) in Evetac: 640 x 480.
    pub const DVXPLORER: Resolution = Resolution { width: 640, height: 480 };

    pub fn new(width: u16, height: u16) -> Self {
        Self { width, height }
    }

    #[inline]
    pub fn contains(&self, x: u16, y: u16) -> bool {
        x < self.width && y < self.height
    }

    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

impl std::fmt::Display for Resolution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

impl std::str::FromStr for Resolution {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (w, h) =
            s.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT such as 640x480, got {s:?}"))?;
        let parse = |v: &str| {
            v.trim()
                .parse::<u16>()
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| format!("expected a size from 1 to 65535, got {v:?} in {s:?}"))
        };
        Ok(Resolution::new(parse(w)?, parse(h)?))
    }
}
