//! [`Ctx`]: what every command gets besides its own arguments — the global
//! flags (`-q`, `-v`, `--json`), the output helpers that keep stdout clean,
//! and the progress-bar factory.
//!
//! # Output rules (every command follows them)
//!
//! * **stdout** carries the result only: a table or summary, or with `--json`
//!   exactly one JSON object ([`Ctx::emit`]) and nothing else.
//! * **stderr** carries notes ([`Ctx::note`], hidden by `-q`), verbose detail
//!   ([`Ctx::verbose`], shown with `-v`), warnings ([`Ctx::warn`], always) and
//!   progress bars. Bars are drawn only when stderr is a terminal and `-q` is
//!   not given; on a pipe or in a log file nothing but the result appears.
//! * Errors are returned as `anyhow::Error`; `main` prints them as one line
//!   `error: <file>: <problem>` and exits 1, or 2 for a [`UsageError`]
//!   (bad usage that clap could not see, e.g. an unknown output extension).
//!
//! # Progress bars
//!
//! [`Ctx::bar`] and [`Ctx::spinner`] create bars inside one shared
//! [`indicatif::MultiProgress`], so commands that work on several files in
//! parallel (`pqm encode a.obj b.obj …`) get one bar per file plus a total,
//! drawn together. When bars are disabled they return hidden bars, so
//! commands call them unconditionally.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use std::fmt::{self, Display};
use std::io::{IsTerminal, Write};
use std::time::Duration;

/// The global flags and shared output machinery (see the module docs).
pub struct Ctx {
    /// `-q`: no notes, no progress bars, no summaries of commands whose
    /// purpose is writing a file. Results of `stats`/`info` and errors still
    /// print.
    pub quiet: bool,
    /// `-v` count: 1 shows extra detail (timings, options in effect).
    pub verbose: u8,
    /// `--json`: the command prints one JSON object on stdout and nothing else.
    pub json: bool,
    progress: bool,
    multi: MultiProgress,
}

// Some helpers are for commands written on other branches (levels, remesh).
#[allow(dead_code)]
impl Ctx {
    /// A context for the given global flags. Progress bars are enabled when
    /// stderr is a terminal and `quiet` is false.
    pub fn new(quiet: bool, verbose: u8, json: bool) -> Ctx {
        let progress = !quiet && std::io::stderr().is_terminal();
        let multi = if progress {
            MultiProgress::with_draw_target(ProgressDrawTarget::stderr())
        } else {
            MultiProgress::with_draw_target(ProgressDrawTarget::hidden())
        };
        Ctx {
            quiet,
            verbose,
            json,
            progress,
            multi,
        }
    }

    /// True when progress bars are drawn.
    pub fn progress_enabled(&self) -> bool {
        self.progress
    }

    /// The shared multi-bar (to add bars of a custom style).
    pub fn multi(&self) -> &MultiProgress {
        &self.multi
    }

    /// A bar counting `len` units, labelled `prefix` (a file name, say).
    /// Hidden when bars are disabled. Call `finish_and_clear()` when done.
    pub fn bar(&self, len: u64, prefix: impl Into<String>) -> ProgressBar {
        if !self.progress {
            return ProgressBar::hidden();
        }
        let style = ProgressStyle::with_template(
            "{prefix:>20.bold} [{bar:30.cyan/blue}] {pos}/{len} {msg} ({elapsed})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
        let pb = self.multi.add(ProgressBar::new(len));
        pb.set_style(style);
        pb.set_prefix(prefix.into());
        // Keeps the elapsed time moving while the work reports rarely.
        pb.enable_steady_tick(Duration::from_millis(250));
        pb
    }

    /// A spinner for work of unknown length, labelled `prefix`.
    pub fn spinner(&self, prefix: impl Into<String>) -> ProgressBar {
        if !self.progress {
            return ProgressBar::hidden();
        }
        let style = ProgressStyle::with_template("{prefix:>20.bold} {spinner} {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_spinner());
        let pb = self.multi.add(ProgressBar::new_spinner());
        pb.set_style(style);
        pb.set_prefix(prefix.into());
        pb.enable_steady_tick(Duration::from_millis(120));
        pb
    }

    /// A note for the user on stderr (`pqm: …`), hidden by `-q`.
    pub fn note(&self, msg: impl Display) {
        if !self.quiet {
            self.eprint(&format!("note: {msg}"));
        }
    }

    /// Detail on stderr shown only with `-v`.
    pub fn verbose(&self, msg: impl Display) {
        if self.verbose > 0 && !self.quiet {
            self.eprint(&format!("{msg}"));
        }
    }

    /// A warning on stderr, shown even with `-q`.
    pub fn warn(&self, msg: impl Display) {
        self.eprint(&format!("warning: {msg}"));
    }

    /// An error line on stderr for a failure that does not stop the command
    /// (one input of a batch), in the same form `main` uses.
    pub fn error_line(&self, msg: impl Display) {
        self.eprint(&format!("error: {msg}"));
    }

    fn eprint(&self, line: &str) {
        // Suspend the bars so the line is not overdrawn.
        self.multi.suspend(|| eprintln!("{line}"));
    }

    /// Prints the result of a command whose purpose is to report (`stats`,
    /// `info`): `value` as one JSON object with `--json`, else `text()`.
    /// Printed even with `-q`.
    pub fn emit_result<T: Serialize>(
        &self,
        value: &T,
        text: impl FnOnce() -> String,
    ) -> anyhow::Result<()> {
        if self.json {
            self.print_json(value)
        } else {
            self.print_stdout(&text())
        }
    }

    /// Prints the summary of a command whose purpose is to write files:
    /// `value` as one JSON object with `--json` (even with `-q`), else
    /// `text()` unless `-q`.
    pub fn emit<T: Serialize>(
        &self,
        value: &T,
        text: impl FnOnce() -> String,
    ) -> anyhow::Result<()> {
        if self.json {
            self.print_json(value)
        } else if !self.quiet {
            self.print_stdout(&text())
        } else {
            Ok(())
        }
    }

    fn print_json<T: Serialize>(&self, value: &T) -> anyhow::Result<()> {
        let s = serde_json::to_string_pretty(value)?;
        self.print_stdout(&s)
    }

    fn print_stdout(&self, text: &str) -> anyhow::Result<()> {
        let mut out = std::io::stdout().lock();
        let r = self.multi.suspend(|| {
            out.write_all(text.as_bytes())?;
            if !text.ends_with('\n') {
                out.write_all(b"\n")?;
            }
            out.flush()
        });
        match r {
            // A closed pipe (`pqm info x.pqm | head -1`) is not an error.
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
            r => Ok(r?),
        }
    }
}

/// Bad usage found after argument parsing (an unknown output extension,
/// `-o` with several inputs, ...). `main` exits with code 2 for it, like
/// clap's own usage errors.
#[derive(Debug)]
pub struct UsageError(pub String);

impl Display for UsageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// An `anyhow::Error` carrying a [`UsageError`] (exit code 2).
pub fn usage(msg: impl Into<String>) -> anyhow::Error {
    anyhow::Error::new(UsageError(msg.into()))
}
