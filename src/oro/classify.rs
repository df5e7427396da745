//! Region classifier: a random forest (Breiman 2001, "Random forests",
//! Machine Learning 45) over the orometric feature vectors of [`super::stats`],
//! trained on disks labelled by region, evaluated with repeated stratified
//! 80/20 splits and a confusion matrix, as Argudo et al. 2019 §4.3 do.
//!
//! The forest is smartcore's `RandomForestClassifier` (seeded: each tree
//! gets seed + its index, so a seed gives the same forest on every run and
//! machine). Calls into smartcore are guarded: a panic inside the crate comes
//! back as an `Error`, never as a crash.

use super::stats::{feature_names, DiskFeatures, SplitMix64};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use smartcore::ensemble::random_forest_classifier::{
    RandomForestClassifier, RandomForestClassifierParameters,
};
use smartcore::linalg::basic::matrix::DenseMatrix;
use std::path::Path;

type Forest = RandomForestClassifier<f64, u32, DenseMatrix<f64>, Vec<u32>>;

/// Labelled feature vectors.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Dataset {
    pub names: Vec<String>,
    pub labels: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

/// Largest feature file read in memory.
const MAX_CSV: u64 = 1 << 30;

impl Dataset {
    /// Feature vectors of [`super::stats::orostats`] disks.
    pub fn from_disks(disks: &[DiskFeatures]) -> Dataset {
        Dataset {
            names: feature_names(),
            labels: disks.iter().map(|d| d.label.clone()).collect(),
            rows: disks.iter().map(|d| d.values.clone()).collect(),
        }
    }

    /// Read a features CSV written by `orogen orostats` (columns `label,
    /// source, col, row, n_peaks`, then the features).
    pub fn read_csv(path: &Path) -> Result<Dataset> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > MAX_CSV {
            return Err(Error::too_large(
                path,
                "feature CSV over 1 GiB; split it into several files",
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let mut lines = text.lines();
        let header = lines
            .next()
            .ok_or_else(|| Error::corrupt(path, "empty file; expected a header line"))?;
        let cols: Vec<&str> = header.split(',').collect();
        if cols.len() < 6 || cols[..5] != ["label", "source", "col", "row", "n_peaks"] {
            return Err(Error::corrupt(
                path,
                "not a features CSV from `orogen orostats` (header must start label,source,col,row,n_peaks)",
            ));
        }
        let names: Vec<String> = cols[5..].iter().map(|s| s.to_string()).collect();
        let mut ds = Dataset {
            names,
            ..Default::default()
        };
        for (i, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            if f.len() != cols.len() {
                return Err(Error::corrupt(
                    path,
                    format!(
                        "line {}: {} fields, the header has {}",
                        i + 2,
                        f.len(),
                        cols.len()
                    ),
                ));
            }
            let mut row = Vec::with_capacity(f.len() - 5);
            for (j, v) in f[5..].iter().enumerate() {
                let x: f64 = v.trim().parse().map_err(|_| {
                    Error::corrupt(
                        path,
                        format!(
                            "line {}: {:?} in column {} is not a number",
                            i + 2,
                            v,
                            cols[5 + j]
                        ),
                    )
                })?;
                if !x.is_finite() {
                    return Err(Error::corrupt(
                        path,
                        format!(
                            "line {}: column {} is {x}; features must be finite",
                            i + 2,
                            cols[5 + j]
                        ),
                    ));
                }
                row.push(x);
            }
            ds.labels.push(f[0].to_string());
            ds.rows.push(row);
        }
        Ok(ds)
    }

    /// Append another dataset with the same features.
    pub fn extend(&mut self, other: Dataset) -> Result<()> {
        if self.names.is_empty() && self.rows.is_empty() {
            *self = other;
            return Ok(());
        }
        if self.names != other.names {
            return Err(Error::invalid(
                "feature files have different columns; compute them with the same orogen version",
            ));
        }
        self.labels.extend(other.labels);
        self.rows.extend(other.rows);
        Ok(())
    }

    /// Distinct labels, sorted.
    pub fn classes(&self) -> Vec<String> {
        let mut c = self.labels.clone();
        c.sort();
        c.dedup();
        c
    }

    fn check(&self) -> Result<()> {
        if self.rows.is_empty() {
            return Err(Error::invalid("no feature vectors: nothing to train on"));
        }
        if let Some(i) = self.labels.iter().position(|l| l.is_empty()) {
            return Err(Error::invalid(format!(
                "feature vector {i} has no label; give --label to `orogen orostats`"
            )));
        }
        if self.classes().len() < 2 {
            return Err(Error::invalid(format!(
                "only one region label ({:?}): a classifier needs at least two",
                self.labels[0]
            )));
        }
        for (i, r) in self.rows.iter().enumerate() {
            if r.len() != self.names.len() || r.iter().any(|v| !v.is_finite()) {
                return Err(Error::invalid(format!(
                    "feature vector {i} has {} values (expected {}) or a non-finite value",
                    r.len(),
                    self.names.len()
                )));
            }
        }
        Ok(())
    }
}

/// Random-forest parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ForestParams {
    pub n_trees: u16,
    pub seed: u64,
    /// Features tried per split (default √(number of features)).
    pub m: Option<usize>,
    pub max_depth: Option<u16>,
}

impl Default for ForestParams {
    fn default() -> Self {
        ForestParams {
            n_trees: 100,
            seed: 1,
            m: None,
            max_depth: None,
        }
    }
}

/// A trained classifier with its class names and feature names.
#[derive(Serialize, Deserialize)]
pub struct Model {
    /// Always "orogen-oroclassifier".
    pub format: String,
    pub version: u32,
    pub names: Vec<String>,
    pub classes: Vec<String>,
    pub params: ForestParams,
    forest: Forest,
}

fn guarded<T>(
    what: &str,
    f: impl FnOnce() -> std::result::Result<T, smartcore::error::Failed>,
) -> Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(Error::invalid(format!("random forest {what}: {e}"))),
        Err(_) => Err(Error::invalid(format!(
            "random forest {what} failed inside smartcore (degenerate data?)"
        ))),
    }
}

fn matrix(rows: &[Vec<f64>]) -> Result<DenseMatrix<f64>> {
    guarded("input", || DenseMatrix::from_2d_vec(&rows.to_vec()))
}

fn fit(rows: &[Vec<f64>], y: &[u32], p: &ForestParams) -> Result<Forest> {
    if p.n_trees == 0 {
        return Err(Error::invalid("random forest: give at least one tree"));
    }
    let x = matrix(rows)?;
    let mut params = RandomForestClassifierParameters::default()
        .with_n_trees(p.n_trees)
        .with_seed(p.seed);
    if let Some(m) = p.m {
        params = params.with_m(m.max(1));
    }
    if let Some(d) = p.max_depth {
        params = params.with_max_depth(d);
    }
    let y = y.to_vec();
    guarded("training", || Forest::fit(&x, &y, params))
}

/// Train on all of `ds`.
pub fn train(ds: &Dataset, params: &ForestParams) -> Result<Model> {
    ds.check()?;
    let classes = ds.classes();
    let y: Vec<u32> = ds
        .labels
        .iter()
        .map(|l| classes.binary_search(l).map(|i| i as u32).unwrap_or(0))
        .collect();
    let forest = fit(&ds.rows, &y, params)?;
    Ok(Model {
        format: "orogen-oroclassifier".into(),
        version: 1,
        names: ds.names.clone(),
        classes,
        params: params.clone(),
        forest,
    })
}

impl std::fmt::Debug for Model {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Model")
            .field("classes", &self.classes)
            .field("features", &self.names.len())
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

impl Model {
    /// Predicted label of each row (rows must have the model's features).
    pub fn predict(&self, rows: &[Vec<f64>]) -> Result<Vec<String>> {
        if rows.is_empty() {
            return Ok(Vec::new());
        }
        if let Some(i) = rows
            .iter()
            .position(|r| r.len() != self.names.len() || r.iter().any(|v| !v.is_finite()))
        {
            return Err(Error::invalid(format!(
                "feature vector {i}: expected {} finite values like the training data",
                self.names.len()
            )));
        }
        let x = matrix(rows)?;
        let y = guarded("prediction", || self.forest.predict(&x))?;
        Ok(y.iter()
            .map(|&k| self.classes.get(k as usize).cloned().unwrap_or_default())
            .collect())
    }

    /// Save as JSON.
    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string(self)
            .map_err(|e| Error::invalid(format!("model does not serialise: {e}")))?;
        crate::io::atomic::write_file_atomic(path, text.as_bytes())
    }

    /// Load a model saved by [`Model::save`].
    pub fn load(path: &Path) -> Result<Model> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > MAX_CSV {
            return Err(Error::too_large(path, "classifier model over 1 GiB"));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let m: Model = serde_json::from_str(&text).map_err(|e| {
            Error::corrupt(
                path,
                format!("not a classifier written by `orogen classify train`: {e}"),
            )
        })?;
        if m.format != "orogen-oroclassifier" || m.version != 1 {
            return Err(Error::unsupported(
                path,
                "unknown classifier format or version",
            ));
        }
        Ok(m)
    }
}

/// Result of [`evaluate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    pub classes: Vec<String>,
    pub test_fraction: f64,
    /// Accuracy of each repetition.
    pub accuracies: Vec<f64>,
    pub mean: f64,
    /// Sample standard deviation (n − 1) of the accuracies.
    pub sd: f64,
    /// `confusion[true][predicted]`, summed over the repetitions.
    pub confusion: Vec<Vec<u64>>,
}

/// Repeated stratified hold-out: `repeats` times, each class's vectors are
/// shuffled (seed + repetition) and `test_fraction` of them (rounded, at
/// least 1 when the class has ≥ 2) held out; a forest trained on the rest
/// labels them.
pub fn evaluate(
    ds: &Dataset,
    params: &ForestParams,
    repeats: usize,
    test_fraction: f64,
    seed: u64,
) -> Result<Evaluation> {
    ds.check()?;
    if !(test_fraction > 0.0 && test_fraction < 1.0) {
        return Err(Error::invalid(format!(
            "test fraction must be between 0 and 1, got {test_fraction}"
        )));
    }
    if repeats == 0 {
        return Err(Error::invalid("give at least one repetition"));
    }
    let classes = ds.classes();
    let k = classes.len();
    let y: Vec<u32> = ds
        .labels
        .iter()
        .map(|l| classes.binary_search(l).map(|i| i as u32).unwrap_or(0))
        .collect();
    let mut by_class: Vec<Vec<usize>> = vec![Vec::new(); k];
    for (i, &c) in y.iter().enumerate() {
        by_class[c as usize].push(i);
    }
    let mut confusion = vec![vec![0u64; k]; k];
    let mut accuracies = Vec::with_capacity(repeats);
    for rep in 0..repeats {
        let mut rng = SplitMix64(
            seed.wrapping_mul(0x2545_F491_4F6C_DD1D)
                .wrapping_add(rep as u64),
        );
        let (mut train_i, mut test_i) = (Vec::new(), Vec::new());
        for members in &by_class {
            let mut m = members.clone();
            for i in (1..m.len()).rev() {
                let j = rng.below(i as u64 + 1) as usize;
                m.swap(i, j);
            }
            let mut nt = (m.len() as f64 * test_fraction).round() as usize;
            if m.len() >= 2 {
                nt = nt.clamp(1, m.len() - 1);
            } else {
                nt = 0;
            }
            test_i.extend_from_slice(&m[..nt]);
            train_i.extend_from_slice(&m[nt..]);
        }
        if test_i.is_empty() {
            return Err(Error::invalid(
                "too few feature vectors to hold any out for testing",
            ));
        }
        let tr_rows: Vec<Vec<f64>> = train_i.iter().map(|&i| ds.rows[i].clone()).collect();
        let tr_y: Vec<u32> = train_i.iter().map(|&i| y[i]).collect();
        let p = ForestParams {
            seed: params.seed.wrapping_add(rep as u64 * 1000),
            ..params.clone()
        };
        let forest = fit(&tr_rows, &tr_y, &p)?;
        let te_rows: Vec<Vec<f64>> = test_i.iter().map(|&i| ds.rows[i].clone()).collect();
        let x = matrix(&te_rows)?;
        let pred = guarded("prediction", || forest.predict(&x))?;
        let mut right = 0usize;
        for (&i, &p) in test_i.iter().zip(&pred) {
            let t = y[i] as usize;
            let p = (p as usize).min(k - 1);
            confusion[t][p] += 1;
            right += usize::from(t == p);
        }
        accuracies.push(right as f64 / test_i.len() as f64);
    }
    let n = accuracies.len() as f64;
    let mean = accuracies.iter().sum::<f64>() / n;
    let sd = if accuracies.len() > 1 {
        (accuracies.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    Ok(Evaluation {
        classes,
        test_fraction,
        accuracies,
        mean,
        sd,
        confusion,
    })
}

impl Evaluation {
    /// Confusion matrix as CSV: header `true\predicted,<classes>`, one row per true class.
    pub fn confusion_csv(&self) -> String {
        let mut s = String::from("true\\predicted");
        for c in &self.classes {
            s.push(',');
            s.push_str(c);
        }
        s.push('\n');
        for (c, row) in self.classes.iter().zip(&self.confusion) {
            s.push_str(c);
            for v in row {
                s.push_str(&format!(",{v}"));
            }
            s.push('\n');
        }
        s
    }

    /// Human-readable summary: accuracy mean ± sd and the matrix.
    pub fn summary(&self) -> String {
        let w = self
            .classes
            .iter()
            .map(|c| c.len())
            .max()
            .unwrap_or(4)
            .max(6);
        let mut s = format!(
            "accuracy {:.3} ± {:.3} over {} repetitions ({:.0}% held out)\nconfusion (rows: true, columns: predicted)\n{:w$}",
            self.mean,
            self.sd,
            self.accuracies.len(),
            self.test_fraction * 100.0,
            ""
        );
        for c in &self.classes {
            s.push_str(&format!(" {c:>w$}"));
        }
        s.push('\n');
        for (c, row) in self.classes.iter().zip(&self.confusion) {
            s.push_str(&format!("{c:w$}"));
            for v in row {
                s.push_str(&format!(" {v:>w$}"));
            }
            s.push('\n');
        }
        s
    }
}
