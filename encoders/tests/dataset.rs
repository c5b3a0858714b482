//! The tactile dataset loader on the repository's copies of the real iCub recordings.

use encoders::dataset::{Dataset, DatasetKind, SampleData, Split};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/icub_braille").join(name)
}

#[test]
fn th10_events_load_with_their_split() {
    let ds = Dataset::load(&data("th10"), 0).unwrap();
    assert_eq!(ds.kind, DatasetKind::Events);
    assert_eq!((ds.samples.len(), ds.classes.len(), ds.channels), (5400, 27, 12));
    assert_eq!((ds.classes[0].as_str(), ds.classes[1].as_str(), ds.classes[26].as_str()), ("Space", "A", "Z"));
    let events: usize = ds
        .samples
        .iter()
        .map(|s| match &s.data {
            SampleData::Events(e) => e.len(),
            _ => 0,
        })
        .sum();
    assert_eq!(events, 221_107);
    assert_eq!((ds.split(Split::Train).count(), ds.split(Split::Test).count()), (4320, 1080));
}

#[test]
fn raw1350_frames_load_with_any_channel_count() {
    let ds = Dataset::load(&data("raw1350"), 25_000).unwrap();
    assert_eq!(ds.kind, DatasetKind::Analog);
    assert_eq!((ds.samples.len(), ds.classes.len(), ds.channels), (1350, 27, 12));
    for s in &ds.samples {
        let SampleData::Analog { frames } = &s.data else { panic!() };
        assert!(frames.len() == 76 * 12 || frames.len() == 77 * 12, "sample {} has {} values", s.id, frames.len());
    }
    assert_eq!((ds.split(Split::Train).count(), ds.split(Split::Test).count()), (1080, 270));
}

#[test]
fn small_synthetic_dataset_with_other_channels_and_bad_rows() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("split.csv"), "sample,split\n0,train\n1,test\n").unwrap();
    std::fs::write(
        d.join("raw.csv"),
        "sample,letter,label,t_idx,c0,c1,c2\n0,up,0,0,1,2,3\n0,up,0,1,1,2,4\n1,down,1,0,5,5,5\n",
    )
    .unwrap();
    let ds = Dataset::load(d, 1000).unwrap();
    assert_eq!((ds.channels, ds.classes.clone()), (3, vec!["up".to_string(), "down".to_string()]));
    std::fs::write(d.join("raw.csv"), "sample,letter,label,t_idx,c0,c1,c2\n0,up,0,0,1,2,3\n0,up,0,1,1,NaN,4\n")
        .unwrap();
    let err = Dataset::load(d, 1000).unwrap_err().to_string();
    assert!(err.contains("raw.csv") && err.contains("line 3") && err.contains("c1"), "{err}");
    std::fs::write(d.join("raw.csv"), "sample,letter,label,t_idx,c0\n0,up,0,0,1\n0,down,0,1,1\n").unwrap();
    let err = Dataset::load(d, 1000).unwrap_err().to_string();
    assert!(err.contains("line 3") && err.contains("letter"), "{err}");
    std::fs::write(d.join("raw.csv"), "sample,letter,label,t_idx,c0\n7,up,0,0,1\n").unwrap();
    let err = Dataset::load(d, 1000).unwrap_err().to_string();
    assert!(err.contains("line 2") && err.contains("split.csv"), "{err}");
}
