//! The hard-case suite: named scenes and ray sets where floating point is at its worst (far
//! from the origin, tiny and huge scales, grazing and tangent rays, degenerate and thin
//! geometry, extreme materials and lights, awkward cameras). Each case builds its scene in
//! code and knows its own check: an analytic value, an energy bound, or agreement between
//! two renders (translated/scaled vs at the origin, Embree vs naive). Every case also
//! requires zero non-finite samples, pixels and hit values.
//!
//! `tests/hard_cases.rs` runs each case as a named test; `ember check` runs them all and
//! prints a table. The list of promises is in `docs/hard-cases.md`.

mod analytic;
mod case_run;
mod cases;
mod pixel;
mod scenes;
mod versus_f64;

pub use case_run::CaseRun;

use crate::accel::AccelError;
use crate::embree::EmbreeError;
use crate::integrator::RenderError;
use crate::scene::SceneError;
use std::time::{Duration, Instant};

/// How hard to look: `Quick` uses smaller images and fewer samples (seconds for the whole
/// suite); `Full` is the default of `ember check` and of the tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Quality {
    Quick,
    #[default]
    Full,
}

/// The seed of every case's renders unless `ember check --seed` gives another. The suite's
/// tolerances hold for any seed with high probability (docs/hard-cases.md: sweeps of 40
/// seeds); this one is what the tests run.
pub const DEFAULT_SEED: u64 = 7;

/// Why a case could not run at all (counted as a failure).
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error(transparent)]
    Embree(#[from] EmbreeError),
    #[error(transparent)]
    Accel(#[from] AccelError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("{0}")]
    Other(String),
}

/// A case's own verdict: its main error measure against its limit (pass when
/// `error <= limit`), plus any further requirement that failed.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    pub error: f64,
    pub limit: f64,
    /// What `error` measures, e.g. "max |px − 1|" or "% px off > 5%".
    pub metric: &'static str,
    pub detail: String,
    /// Further requirements that failed, each a sentence.
    pub failures: Vec<String>,
}

impl Verdict {
    pub fn new(error: f64, limit: f64, metric: &'static str, detail: impl Into<String>) -> Verdict {
        Verdict { error, limit, metric, detail: detail.into(), failures: Vec::new() }
    }

    /// Adds a further requirement: when `ok` is false, `what` is recorded as a failure.
    pub fn require(mut self, ok: bool, what: impl Into<String>) -> Verdict {
        if !ok {
            self.failures.push(what.into());
        }
        self
    }

    pub fn passes(&self) -> bool {
        self.error <= self.limit && self.failures.is_empty()
    }
}

/// One named hard case.
pub struct Case {
    pub name: &'static str,
    /// The promise, one line.
    pub promise: &'static str,
    check: fn(&CaseRun) -> Result<Verdict, CheckError>,
}

/// The outcome of running a case.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseResult {
    pub name: &'static str,
    pub pass: bool,
    /// The case's main error measure (NaN if it could not run).
    pub worst_error: f64,
    pub limit: f64,
    pub metric: &'static str,
    /// Non-finite samples, pixels or hit values seen (must be 0).
    pub nonfinite: u64,
    pub detail: String,
    pub elapsed: Duration,
}

impl Case {
    /// Runs the case with [`DEFAULT_SEED`]. A case that panics or cannot build its scene
    /// fails; it never aborts the caller.
    pub fn run(&self, quality: Quality) -> CaseResult {
        self.run_seeded(quality, DEFAULT_SEED)
    }

    /// [`Case::run`] with the renders' random numbers drawn from `seed`.
    pub fn run_seeded(&self, quality: Quality, seed: u64) -> CaseResult {
        let start = Instant::now();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let run = CaseRun::new(quality, seed)?;
            let v = (self.check)(&run)?;
            Ok::<_, CheckError>((v, run.nonfinite()))
        }));
        let elapsed = start.elapsed();
        let failed = |detail: String| CaseResult {
            name: self.name,
            pass: false,
            worst_error: f64::NAN,
            limit: f64::NAN,
            metric: "",
            nonfinite: 0,
            detail,
            elapsed,
        };
        match outcome {
            Ok(Ok((v, nonfinite))) => {
                let mut detail = v.detail.clone();
                for f in &v.failures {
                    detail = format!("FAILED: {f}; {detail}");
                }
                if nonfinite > 0 {
                    detail = format!("FAILED: {nonfinite} non-finite values; {detail}");
                }
                CaseResult {
                    name: self.name,
                    pass: v.passes() && nonfinite == 0,
                    worst_error: v.error,
                    limit: v.limit,
                    metric: v.metric,
                    nonfinite,
                    detail,
                    elapsed,
                }
            }
            Ok(Err(e)) => failed(format!("FAILED: could not run: {e}")),
            Err(panic) => {
                let msg = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                failed(format!("FAILED: panicked: {msg}"))
            }
        }
    }
}

/// Every case, in the order of `docs/hard-cases.md`.
pub fn catalog() -> Vec<Case> {
    cases::all()
}

/// The case called `name`.
pub fn find(name: &str) -> Option<Case> {
    catalog().into_iter().find(|c| c.name == name)
}
