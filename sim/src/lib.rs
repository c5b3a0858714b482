//! A virtual Evetac: an event camera behind a gel skin sliding over 3D-printed Braille.
//!
//! Boards ([`board`]) are dots with manufacturing tolerances; the sensor ([`sensor`]) is a
//! DVXplorer-like pixel array behind a gel lit from the side; a scan ([`scan`]) lowers the
//! sensor onto a row, slides along it, holds and lifts, and yields events with ground truth.
//! Parameters without a public source are marked "assumed" in their docs. Results on these
//! streams are simulated, never measurements of the real sensor.
//!
//! ```
//! use sim::{Board, BoardGeometry, BoardKind, CameraConfig, GelConfig, ScanConfig, Sensor};
//! use encoders::Resolution;
//!
//! let board = Board::new(BoardKind::Text("AB".into()), BoardGeometry::default(), 1).unwrap();
//! // A small sensor keeps the example quick; the default is the DVXplorer's 640x480.
//! let camera = CameraConfig { resolution: Resolution::new(160, 120), ..CameraConfig::default() };
//! let sensor = Sensor::new(camera, GelConfig::default(), 7).unwrap();
//! let scan = sim::simulate(&board, &sensor, &ScanConfig { speed_mm_s: 32.0, ..ScanConfig::default() }).unwrap();
//! assert!(scan.events.len() > 1000);
//! assert_eq!(scan.truth.characters[0].letter, 'A');
//! ```

pub mod board;
pub mod checks;
pub mod error;
pub mod mount;
pub mod realism;
pub mod scan;
pub mod sensor;
pub mod stamp;

pub use board::{Board, BoardGeometry, BoardKind};
pub use error::{Error, Result};
pub use mount::{StickSlip, StickSlipTruth};
pub use realism::{Realism, Setup};
pub use scan::{Direction, Scan, ScanConfig, ScanTruth, simulate};
pub use sensor::{CameraConfig, GelConfig, GelDynamics, PronyTerm, Sensor, SensorVariation};
