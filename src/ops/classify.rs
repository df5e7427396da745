//! `orogen classify`: a region classifier, a random forest over `orostats`
//! feature vectors ([`crate::oro::classify`]): train, predict, evaluate.

use crate::error::{Error, Result};
use crate::ops::note::{Note, Notify};
use crate::oro::classify::{self, Dataset, Evaluation, ForestParams, Model};
use std::path::{Path, PathBuf};

/// Forest options of `orogen classify train` and `evaluate`.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ForestOptions {
    /// Number of trees.
    pub trees: u16,
    /// Seed of the forest.
    pub seed: u64,
    /// Features tried per split (default √features).
    pub mtry: Option<usize>,
    /// Maximum tree depth.
    pub max_depth: Option<u16>,
}

impl Default for ForestOptions {
    fn default() -> Self {
        ForestOptions {
            trees: 100,
            seed: 1,
            mtry: None,
            max_depth: None,
        }
    }
}

impl ForestOptions {
    /// The forest's parameters.
    pub fn params(&self) -> ForestParams {
        ForestParams {
            n_trees: self.trees,
            seed: self.seed,
            m: self.mtry,
            max_depth: self.max_depth,
        }
    }
}

/// Options of `orogen classify evaluate`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvaluateOptions {
    /// The forest.
    #[serde(flatten)]
    pub forest: ForestOptions,
    /// Repetitions.
    pub repeats: usize,
    /// Fraction held out for testing.
    pub test_fraction: f64,
}

impl Default for EvaluateOptions {
    fn default() -> Self {
        EvaluateOptions {
            forest: ForestOptions::default(),
            repeats: 10,
            test_fraction: 0.2,
        }
    }
}

/// The feature vectors of several CSV files, as one dataset.
pub fn load_all(files: &[PathBuf]) -> Result<Dataset> {
    let mut ds = Dataset::default();
    for f in files {
        ds.extend(Dataset::read_csv(f)?)
            .map_err(|e| Error::invalid(format!("{}: {e}", f.display())))?;
    }
    Ok(ds)
}

/// Train a forest on the feature files and save the model to `output`;
/// returns the model and the dataset it was trained on.
pub fn train(
    features: &[PathBuf],
    opts: &ForestOptions,
    output: &Path,
) -> Result<(Model, Dataset)> {
    let ds = load_all(features)?;
    let m = classify::train(&ds, &opts.params())?;
    m.save(output)?;
    Ok((m, ds))
}

/// Predict the class of every vector of the feature files with the model
/// saved at `model`; returns the model, the dataset and one class per vector.
pub fn predict(model: &Path, features: &[PathBuf]) -> Result<(Model, Dataset, Vec<String>)> {
    let m = Model::load(model)?;
    let ds = load_all(features)?;
    if ds.names != m.names {
        return Err(Error::invalid(
            "the feature files do not have the columns the model was trained on",
        ));
    }
    let pred = m.predict(&ds.rows)?;
    Ok((m, ds, pred))
}

/// The `label,predicted` CSV of a prediction.
pub fn predictions_csv(labels: &[String], pred: &[String]) -> String {
    let mut s = String::from("label,predicted\n");
    for (l, q) in labels.iter().zip(pred) {
        s.push_str(&format!("{l},{q}\n"));
    }
    s
}

/// Cross-validate a forest on the feature files (repeated stratified splits).
pub fn evaluate(features: &[PathBuf], opts: &EvaluateOptions) -> Result<Evaluation> {
    let ds = load_all(features)?;
    classify::evaluate(
        &ds,
        &opts.forest.params(),
        opts.repeats,
        opts.test_fraction,
        opts.forest.seed,
    )
}

/// [`train`], noting the summary line (trees, vectors, classes) and the
/// model written.
pub fn train_noted(
    features: &[PathBuf],
    opts: &ForestOptions,
    output: &Path,
    notify: Notify<'_>,
) -> Result<Model> {
    let (m, ds) = train(features, opts, output)?;
    notify(Note::Message(format!(
        "trained {} trees on {} vectors of {} classes: {}",
        opts.trees,
        ds.rows.len(),
        m.classes.len(),
        m.classes.join(", ")
    )));
    notify(Note::Wrote(output.to_path_buf()));
    Ok(m)
}

/// [`predict`], writing the `label,predicted` CSV to `output`, or without
/// one printing (as [`Note::Print`]) each class with its count.
pub fn predict_noted(
    model: &Path,
    features: &[PathBuf],
    output: Option<&Path>,
    notify: Notify<'_>,
) -> Result<()> {
    let (m, ds, pred) = predict(model, features)?;
    match output {
        Some(p) => {
            let s = predictions_csv(&ds.labels, &pred);
            crate::io::atomic::write_file_atomic(p, s.as_bytes())?;
            notify(Note::Wrote(p.to_path_buf()));
        }
        None => {
            let mut s = String::new();
            for c in &m.classes {
                let n = pred.iter().filter(|q| *q == c).count();
                s.push_str(&format!("{c}\t{n}\n"));
            }
            notify(Note::Print(s));
        }
    }
    Ok(())
}

/// [`evaluate`], printing (as [`Note::Print`]) its summary and writing the
/// confusion matrix CSV to `output`, if given.
pub fn evaluate_noted(
    features: &[PathBuf],
    opts: &EvaluateOptions,
    output: Option<&Path>,
    notify: Notify<'_>,
) -> Result<Evaluation> {
    let ev = evaluate(features, opts)?;
    notify(Note::Print(ev.summary()));
    if let Some(p) = output {
        crate::io::atomic::write_file_atomic(p, ev.confusion_csv().as_bytes())?;
        notify(Note::Wrote(p.to_path_buf()));
    }
    Ok(ev)
}
