//! The NIR reader and importer on arbitrary bytes: an error or a network, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.nir");
    if let Ok(g) = snn::nir::Graph::parse(path, data.to_vec()) {
        let _ = snn::nir::import(path, &g, &snn::nir::ImportOptions::default());
    }
});
