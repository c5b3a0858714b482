//! Events in: the project's one event type, event files (AEDAT 4.0, CSV, NumPy) read as bounded
//! streams and written atomically, and the encodings the networks take (heat maps for the CNN,
//! sparse spike trains for the SNN, sigma-delta for analog taxels).
//!
//! This crate depends on no other crate of the workspace.
//!
//! ```
//! use encoders::{Event, Polarity, Resolution};
//! use encoders::heatmap::{HeatmapConfig, HeatmapEncoder};
//!
//! // Two events 15 ms apart on a DVXplorer, counted in the paper's 10 ms bins, pooled by 4.
//! let events = [
//!     Event::new(1_000, 100, 40, Polarity::On),
//!     Event::new(16_000, 101, 41, Polarity::Off),
//! ];
//! let encoder = HeatmapEncoder::new(HeatmapConfig::new(Resolution::DVXPLORER)).unwrap();
//! let map = encoder.encode(&events, 0, 2);
//! assert_eq!((map.width, map.height), (160, 120));
//! assert_eq!(map.get(0, 1, 10, 25), 1.0); // bin 0, ON, row 40/4, column 100/4
//! assert_eq!(map.get(1, 0, 10, 25), 1.0); // bin 1, OFF
//! ```

pub mod braille;
pub mod dataset;
pub mod denoise;
pub mod error;
pub mod event;
pub mod formats;
pub mod heatmap;
pub mod pooling;
pub mod sigma_delta;
pub mod spike_train;
pub mod stats;

pub use error::{Error, Location, Result};
pub use event::{Event, Polarity, Resolution};
pub use formats::{EventSink, EventSource, Format, OpenOptions, StreamInfo};
