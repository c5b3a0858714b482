//! `braille train`'s settings as keys: every field of the SNN recipe ([`SnnRecipe`]) and of the
//! search ([`SearchOptions`], keys `search.*`), set as `key=value` (`--set`) over a recipe preset
//! or file. One parser for all of them ([`set_key`]): a value is JSON where it parses as JSON
//! (`0.5`, `true`, `[8, 16]`, `null`), a list where it holds commas (`8,16`), else a string
//! (`cuba-lif`); a key is a field's name, `-` read as `_`, `.` into a group (`distill.weight`). A
//! key or value that does not fit is an error that names the key and what it takes.

use crate::error::{Error, Result};
use crate::train::recipe::SnnRecipe;
use crate::train::search::{Halving, RULE_STEP_SCALE, SearchSpace};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::ffi::OsString;

/// How `braille train --data DIR --search` searches (keys `search.*`); the space itself is
/// [`SearchSpace`]'s documented one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SearchOptions {
    /// Trials at most (trial 0 is the derived recipe).
    pub trials: usize,
    /// Epochs at most per trial (each stops early after 15 without a better validation accuracy).
    pub epochs: usize,
    /// Seeds per trial; a trial's score is their mean.
    pub trial_seeds: u64,
    /// Successive halving (docs/training.md): 3x `trials` points in three rungs, each keeping the
    /// best third for three times the epochs, at about the cost of `trials` full trials.
    pub halving: bool,
    /// The SNN's step searched too, at these multiples of the derived step (empty: the derived
    /// step only; with `both_gradients`, the fixed rule's 1 and 2).
    pub step_scale: Vec<f64>,
    /// The fixed rule of issue #51 (docs/training.md): the space searched twice, with truncated
    /// gradients and with exact ones; the better by validation score trains the final models.
    pub both_gradients: bool,
}

impl Default for SearchOptions {
    fn default() -> Self {
        SearchOptions {
            trials: 16,
            epochs: 60,
            trial_seeds: 3,
            halving: false,
            step_scale: Vec::new(),
            both_gradients: false,
        }
    }
}

impl SearchOptions {
    /// The search space these options run.
    pub fn space(&self) -> SearchSpace {
        SearchSpace {
            trials: self.trials,
            epochs: self.epochs,
            trial_seeds: self.trial_seeds.max(1),
            halving: self.halving.then_some(Halving::DEFAULT),
            step_scale: match (&self.step_scale[..], self.both_gradients) {
                ([], true) => RULE_STEP_SCALE.to_vec(),
                ([], false) => SearchSpace::default().step_scale,
                (given, _) => given.to_vec(),
            },
            ..SearchSpace::default()
        }
    }
}

/// A recipe and the search's options, with the keys given so far.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainSettings {
    pub recipe: SnnRecipe,
    pub search: SearchOptions,
    given: Vec<String>,
}

impl TrainSettings {
    pub fn new(recipe: SnnRecipe) -> TrainSettings {
        TrainSettings { recipe, search: SearchOptions::default(), given: Vec::new() }
    }

    /// `base` with each `key=value` of `assignments` set in order, then checked as a whole.
    pub fn with(base: SnnRecipe, assignments: &[String]) -> Result<TrainSettings> {
        let mut s = TrainSettings::new(base);
        for a in assignments {
            s.set(a)?;
        }
        s.recipe.check()?;
        Ok(s)
    }

    /// Sets one `key=value`.
    pub fn set(&mut self, assignment: &str) -> Result<()> {
        let Some((key, value)) = assignment.split_once('=') else {
            return Err(Error::Key {
                key: assignment.to_string(),
                value: String::new(),
                what: "expected KEY=VALUE (`braille train --print-recipe` lists the keys)".into(),
            });
        };
        let key = key.trim().replace('-', "_");
        match key.strip_prefix("search.") {
            Some(k) => set_key(&mut self.search, k, value).map_err(|e| e.under("search."))?,
            None => self.recipe.set(&key, value)?,
        }
        self.given.push(key);
        Ok(())
    }

    /// Whether `key` was set (not only taken from the recipe).
    pub fn given(&self, key: &str) -> bool {
        self.given.iter().any(|k| k == key || k.starts_with(&format!("{key}.")))
    }
}

/// Sets the field `key` (`a.b` into a group) of `target` to `raw` (read as the module says),
/// through `target`'s own serde form, so every field takes what its type takes.
pub fn set_key<T: Serialize + DeserializeOwned>(target: &mut T, key: &str, raw: &str) -> Result<()> {
    let err = |what: String| Error::Key { key: key.to_string(), value: raw.to_string(), what };
    let whole = serde_json::to_value(&*target).map_err(|e| err(e.to_string()))?;
    let value = parse_value(raw);
    // the value as read first; then, for a type whose serde names are in another case, a name as
    // a command line writes it (`spike-count`, `zero` for `spike_count`, `Zero`); then one item
    // as a list of one: the first that fits
    let mut candidates = vec![value.clone()];
    if let Value::String(s) = &value {
        candidates.extend([Value::String(s.replace('-', "_")), Value::String(pascal_case(s))]);
    }
    if !value.is_array() && !value.is_null() {
        candidates.push(Value::Array(vec![value]));
    }
    let mut first_error = None;
    for candidate in candidates {
        let mut next = whole.clone();
        let mut slot = &mut next;
        for part in key.split('.') {
            if slot.is_null() {
                // a group not set yet (an optional one): its fields take their defaults
                *slot = Value::Object(serde_json::Map::new());
            }
            let Value::Object(fields) = slot else {
                return Err(err(format!("`{part}` is inside a value that is not a group of keys")));
            };
            slot = fields.entry(part.to_string()).or_insert(Value::Null);
        }
        *slot = candidate;
        match serde_json::from_value(next) {
            Ok(t) => {
                *target = t;
                return Ok(());
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    Err(err(first_error.map_or_else(String::new, |e| e.to_string())))
}

/// A value as `--set` reads it: JSON, else a comma-separated list, else a string.
fn parse_value(raw: &str) -> Value {
    let raw = raw.trim();
    if let Ok(v) = serde_json::from_str::<Value>(raw) {
        return v;
    }
    if raw.contains(',') {
        return Value::Array(raw.split(',').map(parse_value).collect());
    }
    Value::String(raw.to_string())
}

/// `spike-count` as `SpikeCount`.
fn pascal_case(s: &str) -> String {
    s.split(['-', '_'])
        .map(|w| {
            let mut c = w.chars();
            c.next().map(|f| f.to_uppercase().chain(c).collect::<String>()).unwrap_or_default()
        })
        .collect()
}

impl Error {
    /// The same error with its key's group named in front.
    fn under(self, group: &str) -> Error {
        match self {
            Error::Key { key, value, what } => Error::Key { key: format!("{group}{key}"), value, what },
            other => other,
        }
    }
}

/// The flags `braille train` took before its options became keys, where the key has another name:
/// each `--flag VALUE` reads as `--set key=VALUE`, a switch (`--bias`) as `key=true`.
const FLAG_KEYS: [(&str, &str); 13] = [
    ("words", "word_rows"),
    ("train-speeds", "train_speeds_mm_s"),
    ("train-depths", "train_depths_mm"),
    ("freeze-layers", "frozen_layers"),
    ("search-trials", "search.trials"),
    ("search-epochs", "search.epochs"),
    ("trial-seeds", "search.trial_seeds"),
    ("search-halving", "search.halving"),
    ("search-step-scale", "search.step_scale"),
    ("both-gradients", "search.both_gradients"),
    ("distill-from", "distill.from"),
    ("distill-weight", "distill.weight"),
    ("distill-temperature", "distill.temperature"),
];

/// A command's arguments with the earlier flags of its keys written as `--set KEY=VALUE`: every
/// long flag but `help` and the command's own (`run_flags`) names a key, renamed as the earlier
/// flags were, else with `-` read as `_` (a key that names nothing is refused by [`TrainSettings`],
/// naming it). A flag followed by another flag or nothing is a switch, `KEY=true`.
pub fn flags_as_keys(args: &[OsString], run_flags: &[String]) -> Vec<OsString> {
    let key_of = |flag: &str| -> Option<String> {
        if flag == "help" || run_flags.iter().any(|f| f == flag) {
            return None;
        }
        let renamed = FLAG_KEYS.iter().find(|(f, _)| *f == flag).map(|(_, k)| k.to_string());
        Some(renamed.unwrap_or_else(|| flag.replace('-', "_")))
    };
    let mut out = Vec::with_capacity(args.len());
    let mut rest = args.iter().peekable();
    while let Some(arg) = rest.next() {
        let Some(flag) = arg.to_str().and_then(|a| a.strip_prefix("--")) else {
            out.push(arg.clone());
            continue;
        };
        let (name, inline) = match flag.split_once('=') {
            Some((n, v)) => (n, Some(v.to_string())),
            None => (flag, None),
        };
        let Some(key) = key_of(name) else {
            out.push(arg.clone());
            continue;
        };
        let value = match inline {
            Some(v) => v,
            // the next argument is the value (`--bias true`), unless it is a flag or there is none
            None => match rest.next_if(|v| !v.to_str().is_some_and(|v| v.starts_with("--"))) {
                Some(v) => v.to_string_lossy().into_owned(),
                None => "true".into(),
            },
        };
        out.push("--set".into());
        out.push(format!("{key}={value}").into());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::train::recipe::NeuronChoice;

    fn settings(assignments: &[&str]) -> Result<TrainSettings> {
        let a: Vec<String> = assignments.iter().map(|s| s.to_string()).collect();
        TrainSettings::with(SnnRecipe::default(), &a)
    }

    #[test]
    fn keys_set_numbers_flags_lists_enums_and_groups() {
        let s = settings(&[
            "lr=0.001",
            "bias=true",
            "hidden=128,64",
            "train-speeds-mm-s=16",
            "neuron=lif",
            "reset=zero",
            "readout=spike-count",
            "crop_rows=30,90",
            "distill.from=a.safetensors,b.safetensors",
            "distill.temperature=2",
            "search.step_scale=1,2",
            "search.both_gradients=true",
            "val_seed=7",
        ])
        .unwrap();
        let r = &s.recipe;
        assert_eq!((r.lr, r.bias, &r.hidden[..], r.neuron), (0.001, true, &[128, 64][..], NeuronChoice::Lif));
        assert_eq!((r.reset, r.readout), (snn::neuron::Reset::Zero, snn::model_file::Readout::SpikeCount));
        assert_eq!((&r.train_speeds_mm_s[..], r.crop_rows, r.val_seed), (&[16.0][..], Some([30, 90]), Some(7)));
        let d = r.distill.as_ref().unwrap();
        assert_eq!((d.from.len(), d.weight, d.temperature), (2, 0.5, 2.0));
        assert_eq!(s.search.space().step_scale, vec![1.0, 2.0]);
        assert!(s.given("distill") && s.given("lr") && !s.given("epochs"));
        // the rest as the recipe had it
        assert_eq!(r.epochs, SnnRecipe::default().epochs);
    }

    #[test]
    fn the_envelopes_keys_take_levels_and_a_filter_by_name_or_in_full() {
        let s = settings(&["train_levels=0,0.5,1", "denoise=dv-lab"]).unwrap();
        assert_eq!(s.recipe.train_levels, [0.0, 0.5, 1.0]);
        assert_eq!(s.recipe.denoise, Some(encoders::denoise::NoiseFilterSettings::DV_LAB));
        let sweep = s.recipe.training_scans().sweep.unwrap();
        assert_eq!((&sweep.speeds_mm_s[..], &sweep.levels[..]), (&[8.0][..], &[0.0, 0.5, 1.0][..]));
        // written in full (a model's provenance), read back as written
        let json = serde_json::to_string(&s.recipe).unwrap();
        assert!(json.contains("\"window_us\":2000"), "{json}");
        assert_eq!(serde_json::from_str::<SnnRecipe>(&json).unwrap(), s.recipe);
        let s = settings(&["denoise=dv-processing:5000"]).unwrap();
        assert_eq!(s.recipe.denoise.unwrap().window_us, 5000);
        // without the keys a recipe's form is as before them
        let plain = serde_json::to_string(&SnnRecipe::default()).unwrap();
        assert!(!plain.contains("train_levels") && !plain.contains("denoise"), "{plain}");
        let e = settings(&["train_levels=0,2"]).unwrap_err().to_string();
        assert!(e.contains("train_levels") && e.contains("[0, 1]"), "{e}");
        let e = settings(&["train_levels=0.5", "realism=clean"]).unwrap_err().to_string();
        assert!(e.contains("train_levels") && e.contains("beyond clean"), "{e}");
        let e = settings(&["denoise=median"]).unwrap_err().to_string();
        assert!(e.contains("denoise") && e.contains("dv-lab"), "{e}");
    }

    #[test]
    fn a_key_or_value_that_does_not_fit_names_the_key_and_what_it_takes() {
        let e = settings(&["lr=fast"]).unwrap_err().to_string();
        assert!(e.contains("`lr`") && e.contains("fast") && e.contains("f64"), "{e}");
        let e = settings(&["learning_rate=0.1"]).unwrap_err().to_string();
        assert!(e.contains("learning_rate") && e.contains("unknown field") && e.contains("`lr`"), "{e}");
        let e = settings(&["search.rounds=3"]).unwrap_err().to_string();
        assert!(e.contains("search.rounds") && e.contains("unknown field"), "{e}");
        let e = settings(&["neuron=izhikevich"]).unwrap_err().to_string();
        assert!(e.contains("`neuron`") && e.contains("cuba-lif"), "{e}");
        let e = settings(&["lr"]).unwrap_err().to_string();
        assert!(e.contains("KEY=VALUE"), "{e}");
        // checked as a whole after the keys: a share outside 0..1
        let e = settings(&["class_balance=2"]).unwrap_err().to_string();
        assert!(e.contains("class_balance"), "{e}");
    }

    #[test]
    fn the_recipe_round_trips_through_its_keys_unchanged() {
        for name in crate::train::recipe::PRESETS {
            let r = SnnRecipe::preset(name).unwrap();
            let mut s = TrainSettings::new(r.clone());
            s.set("seed=1").unwrap();
            assert_eq!(s.recipe, SnnRecipe { seed: 1, ..r }, "{name}");
        }
    }
}
