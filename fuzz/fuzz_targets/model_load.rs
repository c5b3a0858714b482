//! The model loader on arbitrary bytes: an error or a model, never a panic, a hang or a huge
//! allocation.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(m) = snn::model_file::SnnModel::parse(Path::new("fuzz.safetensors"), data) {
        // a model that loads runs in the engine
        let _ = snn::engine::Engine::new(&m.network, m.config.dt_us, snn::engine::Mode::Stepped);
    }
});
