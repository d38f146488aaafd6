//! Progress on stderr with `indicatif`: a bar per job (a scene's structures, an image's rows)
//! and a spinner naming the current step with its elapsed time, so that every step that takes
//! over a second (building, ray generation, each timed pass) shows. Nothing is drawn when
//! stderr is not a terminal (a pipe, a file, CI): indicatif hides its bars there, and no other
//! progress text is printed, so redirected stderr holds only errors and results.

use std::sync::OnceLock;
use std::time::Duration;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Redraws per second of the spinner (it shows the step's elapsed time).
const TICK: Duration = Duration::from_millis(120);

/// The bars of the process: one spinner for the current step, bars for jobs above it.
struct Bars {
    multi: MultiProgress,
    step: ProgressBar,
}

fn bars() -> &'static Bars {
    static BARS: OnceLock<Bars> = OnceLock::new();
    BARS.get_or_init(|| {
        let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr());
        let step = multi.add(ProgressBar::new_spinner());
        step.set_style(
            ProgressStyle::with_template("{spinner} {msg} ({elapsed})").expect("a valid template"),
        );
        if !multi.is_hidden() {
            step.enable_steady_tick(TICK);
        }
        Bars { multi, step }
    })
}

/// Names the current step (`bunny: aabb/pns: building`); its elapsed time restarts.
pub fn step(message: impl Into<String>) {
    let step = &bars().step;
    step.reset_elapsed();
    step.set_message(message.into());
}

/// A bar of `len` units above the step spinner, prefixed with `what`; dropped (cleared) by
/// [`Job::finish`].
pub struct Job {
    bar: ProgressBar,
}

impl Job {
    /// Starts a job of `len` units.
    pub fn start(what: impl Into<String>, len: u64, unit: &'static str) -> Self {
        let Bars { multi, step } = bars();
        let bar = multi.insert_before(step, ProgressBar::new(len));
        let template =
            format!("{{prefix}} [{{bar:30}}] {{pos}}/{{len}} {unit} ({{elapsed}}, eta {{eta}})");
        bar.set_style(ProgressStyle::with_template(&template).expect("a valid template"));
        bar.set_prefix(what.into());
        Self { bar }
    }

    /// One more unit done.
    pub fn advance(&self) {
        self.bar.inc(1);
    }

    /// Removes the bar (and clears the step line).
    pub fn finish(self) {
        self.bar.finish_and_clear();
        bars().step.set_message("");
    }
}

/// Runs `print` (output on stdout) with the bars lifted, so that a terminal showing both
/// gets the text whole.
pub fn suspend<R>(print: impl FnOnce() -> R) -> R {
    bars().multi.suspend(print)
}

/// Clears the step line, before a command prints its result on stderr.
pub fn done() {
    bars().step.finish_and_clear();
}
