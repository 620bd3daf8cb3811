//! The terminal progress bar of a render, fed by the renderer's progress reports: it counts
//! samples, so its percentage and ETA follow the work done, not the tiles (cheap tiles of sky
//! finish first). Drawn only when stderr is a terminal.

use crate::integrator::Progress;
use std::io::IsTerminal;

/// A bar on stderr, or nothing when stderr is not a terminal.
pub struct ProgressBar(Option<indicatif::ProgressBar>);

impl ProgressBar {
    /// A bar labelled `label` (e.g. `reference`), or none if stderr is not a terminal.
    pub fn new(label: &str) -> ProgressBar {
        if !std::io::stderr().is_terminal() {
            return ProgressBar(None);
        }
        let bar = indicatif::ProgressBar::new(1);
        let template = format!("{label}{{bar:40.cyan/blue}} {{percent:>3}}% samples  ETA {{eta}}  {{msg}}");
        bar.set_style(
            indicatif::ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        ProgressBar(Some(bar))
    }

    /// Shows a progress report.
    pub fn update(&self, p: Progress) {
        let Some(bar) = &self.0 else { return };
        bar.set_length(p.samples_planned.max(1));
        // Reports come from several worker threads and may arrive out of order: the bar never
        // goes back.
        bar.set_position(p.samples_done.min(p.samples_planned).max(bar.position()));
        let rate = p.rays as f64 / p.elapsed.as_secs_f64().max(1e-9) / 1e6;
        let round = if p.rounds > 1 { format!("round {}/{}  ", p.round, p.rounds) } else { String::new() };
        bar.set_message(format!("{round}{rate:.1} Mrays/s"));
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(bar) = &self.0 {
            bar.finish_and_clear();
        }
    }
}
