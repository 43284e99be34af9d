//! Progress bars for long stages (indicatif), hidden with `--quiet` or when stderr is not a
//! terminal.

use indicatif::{ProgressBar, ProgressStyle};

#[derive(Clone, Copy, Debug, Default)]
pub struct Progress {
    pub quiet: bool,
}

impl Progress {
    pub fn quiet() -> Self {
        Progress { quiet: true }
    }

    pub fn bar(&self, len: u64, stage: &str) -> ProgressBar {
        if self.quiet {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::new(len);
        let style = ProgressStyle::with_template("{msg:>16} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
        bar.set_style(style);
        bar.set_message(stage.to_string());
        bar
    }
}
