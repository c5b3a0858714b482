//! Every model file the project ships, named in one place: by the data it was trained on (a
//! simulator preset, or the iCub recordings), its architecture and its role. Commands, reports,
//! benches and the Python package ask here for a path; none writes a model's file name itself.
//!
//! The layout under the models folder (`models/` in the repository):
//!
//! | folder | what |
//! | --- | --- |
//! | `clean/`, `nominal/` | models trained on SIMULATED scans at that preset: the readers' segmentation networks and classifiers, Table I's classifiers |
//! | `PRESET/nir/` | the SNNs' reset-to-zero twins, which export to NIR as trained |
//! | `PRESET/chip/` | models within a chip's rules (Speck) |
//! | `icub/` | SNNs trained on the real iCub recordings (`snn-raw1350`, `snn-th10`), with `nir/` and `chip/` (Xylo) |
//! | `search/` | the models of `braille train --search`, by run |

use crate::error::{Error, Result};
use snn::model_file::Arch;
use std::fmt;
use std::path::{Path, PathBuf};

/// The data a simulated model was trained on: a simulator preset that has shipped models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Preset {
    /// The simulator before its nuisances, kept for regression.
    Clean,
    /// Every nuisance at its sourced or mid-range value: the default of every command.
    #[default]
    Nominal,
}

impl Preset {
    pub const ALL: [Preset; 2] = [Preset::Clean, Preset::Nominal];

    pub fn name(self) -> &'static str {
        match self {
            Preset::Clean => "clean",
            Preset::Nominal => "nominal",
        }
    }

    /// The preset of a simulator preset's name; an error for one without shipped models (`harsh`).
    pub fn of_name(name: &str) -> Result<Preset> {
        Preset::ALL.into_iter().find(|p| p.name() == name).ok_or_else(|| Error::Setting {
            name: "preset of the shipped models",
            value: name.to_string(),
            expected: "clean or nominal (no models are trained at other presets)",
        })
    }
}

impl fmt::Display for Preset {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A variant of a shipped SNN: as trained, its reset-to-zero twin that exports to NIR, or a
/// model within a chip's rules.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Variant {
    #[default]
    Trained,
    NirTwin,
    Chip,
}

impl Variant {
    /// Where the variant sits beside the models it follows (in `dir` itself, or a subfolder).
    fn under(self, dir: PathBuf) -> PathBuf {
        match self {
            Variant::Trained => dir,
            Variant::NirTwin => dir.join("nir"),
            Variant::Chip => dir.join("chip"),
        }
    }
}

/// A reader's two networks: the segmentation network and the character classifier.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReaderFiles {
    pub segmenter: PathBuf,
    pub classifier: PathBuf,
}

/// The names (file stems) of the reader's networks per architecture.
pub fn reader_names(arch: Arch) -> (&'static str, &'static str) {
    match arch {
        Arch::Resnet => ("resnet-tiny-segment", "resnet-lite-normaug-words"),
        Arch::Snn => ("snn-segment", "snn-words"),
    }
}

/// The reader of `arch` in the folder `dir` (a preset's or a variant's folder, or a lab's own),
/// under the shipped names.
pub fn reader_in(dir: &Path, arch: Arch) -> ReaderFiles {
    let (s, c) = reader_names(arch);
    ReaderFiles { segmenter: dir.join(format!("{s}.safetensors")), classifier: dir.join(format!("{c}.safetensors")) }
}

/// The reader of `arch` for a Braille code: the letters' ([`reader_in`]) for the paper's letters,
/// else the cell reader in `dir`'s `ueb/` folder (`scripts/ueb/train.sh`): the segmentation
/// network `snn-segment`, shared by both architectures (their classifiers read identical
/// detections), and `snn-cells` or `resnet-lite-cells`.
pub fn reader_for(dir: &Path, arch: Arch, code: crate::code::BrailleCode) -> ReaderFiles {
    if code == crate::code::BrailleCode::Grade1Letters {
        return reader_in(dir, arch);
    }
    let ueb = dir.join("ueb");
    let (s, c) = match arch {
        Arch::Resnet => ("snn-segment", "resnet-lite-cells"),
        Arch::Snn => ("snn-segment", "snn-cells"),
    };
    ReaderFiles { segmenter: ueb.join(format!("{s}.safetensors")), classifier: ueb.join(format!("{c}.safetensors")) }
}

/// The paper's character classifier of `arch` in the folder `dir`, under its shipped name.
pub fn chars_in(dir: &Path, arch: Arch) -> PathBuf {
    dir.join(format!("{}.safetensors", chars_name(arch)))
}

/// The paper's character classifier of each architecture (Table I's protocol).
pub fn chars_name(arch: Arch) -> &'static str {
    match arch {
        Arch::Resnet => "resnet-lite-normaug",
        Arch::Snn => "snn-chars",
    }
}

/// Table I's classifiers: (key on the command line, name in tables, file stem), the words models
/// last (they go beyond the paper's training protocol).
pub const TABLE_I: [(&str, &str, &str); 8] = [
    ("raw", "ResNet lite Raw", "resnet-lite-raw"),
    ("norm", "ResNet lite Norm", "resnet-lite-norm"),
    ("aug", "ResNet lite Aug", "resnet-lite-aug"),
    ("normaug", "ResNet lite NormAug", "resnet-lite-normaug"),
    // the paper's own architecture on its 160x120 input, where it has been trained
    ("paper-normaug", "ResNet-34 (paper preset) NormAug", "resnet-paper-normaug"),
    ("snn", "SNN (event-driven engine)", "snn-chars"),
    ("normaug-words", "ResNet lite NormAug + words", "resnet-lite-normaug-words"),
    ("snn-words", "SNN + words", "snn-words"),
];

/// The SNNs trained on simulated scans that have a NIR twin, and the chip model among them.
pub const SIMULATED_SNNS: [&str; 3] = ["snn-chars", "snn-words", "snn-segment"];
pub const SIMULATED_CHIP: &str = "speck-chars";

/// The iCub datasets with a shipped SNN (`models/icub/snn-NAME.safetensors`), and the Xylo model.
pub const ICUB_DATASETS: [&str; 2] = ["raw1350", "th10"];
pub const ICUB_CHIP: &str = "xylo-braille7";

/// The shipped models under one folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Shipped {
    root: PathBuf,
}

impl Shipped {
    /// The models under `root`.
    pub fn at(root: impl Into<PathBuf>) -> Shipped {
        Shipped { root: root.into() }
    }

    /// The repository's models: `$BRAILLE_MODELS` if set, else `models/` of the working
    /// directory if it has one, else the `models/` of the checkout this crate was built from.
    pub fn repo() -> Shipped {
        if let Some(dir) = std::env::var_os("BRAILLE_MODELS") {
            return Shipped::at(dir);
        }
        let local = PathBuf::from("models");
        if local.join(Preset::Nominal.name()).is_dir() {
            return Shipped::at(local);
        }
        Shipped::at(Path::new(env!("CARGO_MANIFEST_DIR")).join("../models"))
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The folder of the models trained at `preset`.
    pub fn dir(&self, preset: Preset) -> PathBuf {
        self.root.join(preset.name())
    }

    /// The folder of a variant of the models trained at `preset`.
    pub fn variant_dir(&self, preset: Preset, variant: Variant) -> PathBuf {
        variant.under(self.dir(preset))
    }

    /// Model `name` (a file stem) trained at `preset`, as trained or a variant.
    pub fn model(&self, preset: Preset, variant: Variant, name: &str) -> PathBuf {
        self.variant_dir(preset, variant).join(format!("{name}.safetensors"))
    }

    /// The reader of `arch` trained at `preset`.
    pub fn reader(&self, preset: Preset, arch: Arch) -> ReaderFiles {
        reader_in(&self.dir(preset), arch)
    }

    /// The paper's character classifier of `arch` trained at `preset`.
    pub fn chars(&self, preset: Preset, arch: Arch) -> PathBuf {
        chars_in(&self.dir(preset), arch)
    }

    /// The folder of the models trained on the iCub recordings.
    pub fn icub_dir(&self, variant: Variant) -> PathBuf {
        variant.under(self.root.join("icub"))
    }

    /// The SNN trained on iCub dataset `name` (`raw1350`, `th10`), as trained or its NIR twin.
    pub fn icub(&self, name: &str, variant: Variant) -> PathBuf {
        self.icub_dir(variant).join(format!("snn-{name}.safetensors"))
    }

    /// The Xylo model of the iCub seven-letter task.
    pub fn icub_chip(&self) -> PathBuf {
        self.icub_dir(Variant::Chip).join(format!("{ICUB_CHIP}.safetensors"))
    }

    /// The models of a search run (`braille train --search --out`).
    pub fn search_dir(&self) -> PathBuf {
        self.root.join("search")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_shipped_model_is_named_by_preset_variant_and_role() {
        let s = Shipped::at("m");
        assert_eq!(
            s.reader(Preset::Nominal, Arch::Snn),
            ReaderFiles {
                segmenter: "m/nominal/snn-segment.safetensors".into(),
                classifier: "m/nominal/snn-words.safetensors".into()
            }
        );
        assert_eq!(
            s.reader(Preset::Clean, Arch::Resnet).segmenter,
            Path::new("m/clean/resnet-tiny-segment.safetensors")
        );
        assert_eq!(s.chars(Preset::Clean, Arch::Resnet), Path::new("m/clean/resnet-lite-normaug.safetensors"));
        assert_eq!(
            s.model(Preset::Nominal, Variant::NirTwin, "snn-words"),
            Path::new("m/nominal/nir/snn-words.safetensors")
        );
        assert_eq!(
            s.model(Preset::Nominal, Variant::Chip, SIMULATED_CHIP),
            Path::new("m/nominal/chip/speck-chars.safetensors")
        );
        assert_eq!(s.icub("th10", Variant::NirTwin), Path::new("m/icub/nir/snn-th10.safetensors"));
        assert_eq!(s.icub_chip(), Path::new("m/icub/chip/xylo-braille7.safetensors"));
        assert_eq!(Preset::of_name("clean").unwrap(), Preset::Clean);
        assert!(Preset::of_name("harsh").unwrap_err().to_string().contains("clean or nominal"));
    }

    #[test]
    fn the_repository_ships_every_model_the_registry_names() {
        let s = Shipped::at(Path::new(env!("CARGO_MANIFEST_DIR")).join("../models"));
        let mut names = Vec::new();
        for p in Preset::ALL {
            for a in [Arch::Snn, Arch::Resnet] {
                let r = s.reader(p, a);
                names.extend([r.segmenter, r.classifier, s.chars(p, a)]);
            }
            names.extend(SIMULATED_SNNS.map(|n| s.model(p, Variant::NirTwin, n)));
            names.push(s.model(p, Variant::Chip, SIMULATED_CHIP));
            names.extend(TABLE_I.iter().filter(|t| t.0 != "paper-normaug").map(|t| s.model(p, Variant::Trained, t.2)));
        }
        for d in ICUB_DATASETS {
            names.extend([s.icub(d, Variant::Trained), s.icub(d, Variant::NirTwin)]);
        }
        names.push(s.icub_chip());
        for n in &names {
            assert!(n.is_file(), "{} is named by the registry but not shipped", n.display());
        }
        // and loads: every reader pair with its typed headers (operating point, calibration,
        // preprocessing), every other file as the network it holds
        for p in Preset::ALL {
            for a in [Arch::Snn, Arch::Resnet] {
                let r = s.reader(p, a);
                crate::classify::ReaderModels::load(&r.segmenter, &r.classifier, crate::classify::SnnRunner::Sliding)
                    .unwrap_or_else(|e| panic!("{p} {a}: {e}"));
            }
        }
        for n in names {
            match crate::models::load(&n).unwrap_or_else(|e| panic!("{e}")) {
                crate::models::Model::Snn(m) => {
                    crate::models::Preprocessing::of_header(&m.preprocess, &n).unwrap();
                    crate::network::load_network(&n, crate::network::NirReading::default()).unwrap();
                }
                crate::models::Model::Resnet(_) => {}
            }
        }
    }
}
