//! `ember check`: runs the hard-case suite and prints one table row per case.

use crate::embree::Device;
use crate::tools::check::{CaseResult, DEFAULT_SEED, Quality, catalog};
use crate::tools::out;
use clap::Args;
use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// Smaller images and fewer samples: the suite takes about 2 s instead of about 10 s (on 2
    /// cores).
    #[arg(long)]
    pub quick: bool,
    /// Seed of the cases' renders: another seed draws other samples, against the same
    /// tolerances (a sweep over seeds shows whether a check passes only by luck).
    #[arg(long, default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    /// List the cases and their promises instead of running them.
    #[arg(long)]
    pub list: bool,
    /// Run only these cases (default: all).
    pub cases: Vec<String>,
}

/// Exit code 0 when every case passes, 1 when one fails.
pub fn run(args: CheckArgs) -> anyhow::Result<ExitCode> {
    let all = catalog();
    if let Some(unknown) = args.cases.iter().find(|n| !all.iter().any(|c| c.name == n.as_str())) {
        let names: Vec<&str> = all.iter().map(|c| c.name).collect();
        anyhow::bail!("unknown case {unknown:?} (cases: {})", names.join(", "));
    }
    // The case column fits the longest name (cylinder-seen-from-afar).
    let width = all.iter().map(|c| c.name.len()).max().unwrap_or(0).max("case".len());
    if args.list {
        for c in &all {
            out!("{:<width$} {}", c.name, c.promise);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let quality = if args.quick { Quality::Quick } else { Quality::Full };
    let cases: Vec<_> =
        all.into_iter().filter(|c| args.cases.is_empty() || args.cases.iter().any(|n| n == c.name)).collect();
    let device = Device::new()?;
    out!(
        "ember {} hard cases ({} run, seed {}, {} on {} threads)",
        env!("CARGO_PKG_VERSION"),
        if args.quick { "quick" } else { "full" },
        args.seed,
        device.version(),
        rayon::current_num_threads()
    );
    drop(device);
    out!(
        "{:<width$} {:<6} {:>10} {:>10}  {:<17} {:>10}  detail",
        "case",
        "result",
        "error",
        "limit",
        "measure",
        "non-finite"
    );
    let start = Instant::now();
    let mut failed = Vec::new();
    for case in &cases {
        let r = case.run_seeded(quality, args.seed);
        out!("{}", table_row(&r, width));
        let _ = std::io::stdout().flush();
        if !r.pass {
            failed.push(r.name);
        }
    }
    out!(
        "{} cases, {} passed, {} failed{} in {:.1} s",
        cases.len(),
        cases.len() - failed.len(),
        failed.len(),
        if failed.is_empty() { String::new() } else { format!(" ({})", failed.join(", ")) },
        start.elapsed().as_secs_f64()
    );
    Ok(ExitCode::from(exit_code(failed.len())))
}

/// 0 when every case passed, 1 when any failed (2 is for errors that stop the run).
fn exit_code(failed: usize) -> u8 {
    if failed == 0 { 0 } else { 1 }
}

/// One row of the table, the case name padded to `width`.
fn table_row(r: &CaseResult, width: usize) -> String {
    format!(
        "{:<width$} {:<6} {:>10} {:>10}  {:<17} {:>10}  {} ({:.1} s)",
        r.name,
        if r.pass { "pass" } else { "FAIL" },
        short_number(r.worst_error),
        short_number(r.limit),
        r.metric,
        r.nonfinite,
        r.detail,
        r.elapsed.as_secs_f64()
    )
}

fn short_number(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else if x == 0.0 {
        "0".into()
    } else if (1e-2..1e4).contains(&x.abs()) {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_case_exits_1() {
        assert_eq!(exit_code(0), 0);
        assert_eq!(exit_code(1), 1);
        assert_eq!(exit_code(23), 1);
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(short_number(f64::NAN), "-");
        assert_eq!(short_number(0.0), "0");
        assert_eq!(short_number(2.475), "2.475");
        assert_eq!(short_number(1.19e-7), "1.19e-7");
    }
}
