//! Reading words from an unsegmented event stream as it arrives: the paper's streaming
//! inference.
//!
//! Events are binned as the labeler bins them (10 ms at 8 mm/s, scaled with speed; pooled by 4;
//! columns outside the active region masked). The speed comes from a [`Timing`]: by default the
//! reader estimates it from the events themselves ([`SpeedEstimator`](crate::speed::SpeedEstimator)) and retunes its bins and
//! the filter's durations as the estimate moves; the paper's fixed timing and a given speed are
//! the alternatives. Every closed bin is a frame: the window of the
//! last `frames` bins goes to the segmentation network, and only where it says a character is
//! present to the character classifier; the temporal filter turns the detections into characters
//! and words, and a speller corrects each finished word. The reader holds one window of sparse
//! bins, the filter's open segment and the open word: memory stays bounded however long the
//! stream runs.
//!
//! The classifiers are behind [`WindowClassifier`], so the ResNet and the SNN read identical
//! windows of identical streams.

mod config;
mod operating_point;
mod output;
mod speller;
mod stream;
mod window;

pub use config::{ReaderConfig, Timing, TimingMode};
pub use operating_point::{Abstention, CalibrationGrid, OperatingPoint, PointCalibration, f32_as_printed};
pub use output::{ReadOutput, ReadWord, ReaderStats};
pub use speller::{Spell, Speller};
pub use stream::{ReadAll, StreamReader, read_all};
pub use window::{Cell, Window, WindowClassifier};

#[cfg(test)]
mod tests;
