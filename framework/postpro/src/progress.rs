//! The main job's progress bar: drawn on standard error only when it is a terminal, and only once
//! the run has taken a second (short runs stay quiet); it advances with how far each of the job's
//! passes has read the CL file.

use std::cell::{Cell, RefCell};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// How long a run goes before the bar is drawn.
const DELAY: Duration = Duration::from_secs(1);

/// How many items a pass reads between two updates of the bar.
const ITEMS_PER_UPDATE: u32 = 1024;

/// The progress of a job that reads a text of some length a number of times.
pub(crate) struct Progress {
    /// The bar (`None`: nowhere to draw it) and where it is drawn once shown.
    bar: Option<(ProgressBar, Cell<Option<ProgressDrawTarget>>)>,
    started: Instant,
    delay: Duration,
    len: Cell<u64>,
    /// How long each pass takes per byte, about (relative).
    weights: RefCell<Vec<u64>>,
    /// Where the current pass starts on the bar and its weight.
    pass: Cell<(u64, u64)>,
    items: Cell<u32>,
}

impl Progress {
    /// The progress of readings of a text, each pass taking time in proportion to its weight,
    /// drawn on standard error if it is a terminal.
    pub(crate) fn on_stderr(weights: &[u64]) -> Progress {
        let target = std::io::stderr().is_terminal().then(ProgressDrawTarget::stderr);
        Progress::new(weights, target, DELAY)
    }

    /// The progress drawn to `target` (if any) once `delay` has passed.
    pub(crate) fn new(weights: &[u64], target: Option<ProgressDrawTarget>, delay: Duration) -> Progress {
        let bar = target.map(|target| {
            let bar = ProgressBar::with_draw_target(Some(weights.iter().sum()), ProgressDrawTarget::hidden());
            let style = ProgressStyle::with_template("{msg:22} [{bar:30}] {percent:>3}% {elapsed} (about {eta} to go)")
                .map_or_else(|_| ProgressStyle::default_bar(), |s| s.progress_chars("=> "));
            bar.set_style(style);
            (bar, Cell::new(Some(target)))
        });
        let (len, weights) = (Cell::new(1), RefCell::new(weights.to_vec()));
        Progress { bar, started: Instant::now(), delay, len, weights, pass: Cell::new((0, 1)), items: Cell::new(0) }
    }

    /// The length of the text read (bytes).
    pub(crate) fn set_len(&self, len: u64) {
        self.len.set(len.max(1));
        if let Some((bar, _)) = &self.bar {
            bar.set_length(self.len.get() * self.weights.borrow().iter().sum::<u64>());
        }
    }

    /// The passes' weights from now on (the job learnt how many passes it makes).
    pub(crate) fn set_weights(&self, weights: &[u64]) {
        *self.weights.borrow_mut() = weights.to_vec();
        self.set_len(self.len.get());
    }

    /// One more pass after pass `index`, as long as it (the job found it has to read the text
    /// once more).
    pub(crate) fn repeat_pass(&self, index: usize) {
        let mut weights = self.weights.borrow().clone();
        let weight = weights.get(index).copied().unwrap_or(1);
        weights.insert((index + 1).min(weights.len()), weight);
        self.set_weights(&weights);
    }

    /// Pass `index` (from 0) starts, doing `what`.
    pub(crate) fn pass(&self, index: usize, what: &str) {
        let weights = self.weights.borrow();
        let before: u64 = weights.iter().take(index).sum();
        self.pass.set((before * self.len.get(), weights.get(index).copied().unwrap_or(1)));
        if let Some((bar, _)) = &self.bar {
            bar.set_message(what.to_string());
            bar.set_position(self.pass.get().0);
            self.show_when_due();
            // A new pass is drawn at once (updates within a pass are drawn 20 times a second).
            bar.force_draw();
        }
    }

    /// The current pass has read an item that ends at `offset` of the text (the bar moves every
    /// [`ITEMS_PER_UPDATE`] items).
    pub(crate) fn item(&self, offset: u64) {
        let Some((bar, _)) = &self.bar else { return };
        let items = self.items.get().wrapping_add(1);
        self.items.set(items);
        if items.is_multiple_of(ITEMS_PER_UPDATE) {
            let (start, weight) = self.pass.get();
            bar.set_position(start + weight * offset.min(self.len.get()));
            self.show_when_due();
        }
    }

    /// Runs `f` (which prints) with the bar off the screen.
    pub(crate) fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match &self.bar {
            Some((bar, _)) => bar.suspend(f),
            None => f(),
        }
    }

    /// The job is over: the bar is cleared.
    pub(crate) fn finish(&self) {
        if let Some((bar, _)) = &self.bar {
            bar.finish_and_clear();
        }
    }

    /// Draws the bar once the delay has passed.
    fn show_when_due(&self) {
        let Some((bar, target)) = &self.bar else { return };
        if self.started.elapsed() < self.delay {
            return;
        }
        if let Some(target) = target.take() {
            bar.set_draw_target(target);
            bar.enable_steady_tick(Duration::from_millis(250));
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use indicatif::TermLike;

    use super::*;

    /// A terminal that keeps what is written to it.
    #[derive(Debug, Default, Clone)]
    struct Screen(Arc<Mutex<String>>);

    impl Screen {
        fn text(&self) -> String {
            self.0.lock().map(|s| s.clone()).unwrap_or_default()
        }
    }

    impl TermLike for Screen {
        fn width(&self) -> u16 {
            100
        }
        fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn write_line(&self, s: &str) -> std::io::Result<()> {
            self.write_str(&format!("{s}\n"))
        }
        fn write_str(&self, s: &str) -> std::io::Result<()> {
            if let Ok(mut text) = self.0.lock() {
                text.push_str(s);
            }
            Ok(())
        }
        fn clear_line(&self) -> std::io::Result<()> {
            Ok(())
        }
        fn flush(&self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn run(progress: &Progress) {
        progress.pass(0, "reading");
        for k in 0..4 * ITEMS_PER_UPDATE {
            progress.item(u64::from(k));
        }
        progress.pass(1, "writing the program");
        for k in 0..ITEMS_PER_UPDATE {
            progress.item(u64::from(k));
        }
    }

    #[test]
    fn a_run_past_the_delay_draws_the_pass_and_how_far_it_is() {
        let screen = Screen::default();
        let target = ProgressDrawTarget::term_like(Box::new(screen.clone()));
        let progress = Progress::new(&[1, 3], Some(target), Duration::ZERO);
        progress.set_len(4 * u64::from(ITEMS_PER_UPDATE));
        run(&progress);
        let drawn = screen.text();
        assert!(drawn.contains("reading") && drawn.contains("  0%"), "{drawn:?}");
        assert!(drawn.contains("writing the program") && drawn.contains(" 25%"), "the second pass starts: {drawn:?}");
        progress.finish();
    }

    #[test]
    fn a_pass_repeated_makes_room_and_the_passes_after_it_move_on() {
        let screen = Screen::default();
        let target = ProgressDrawTarget::term_like(Box::new(screen.clone()));
        let progress = Progress::new(&[1, 2, 1], Some(target), Duration::ZERO);
        progress.set_len(100);
        progress.pass(1, "predicting the feed");
        // The blocks in working planes: the prediction once more, as long as the first.
        progress.repeat_pass(1);
        progress.pass(2, "predicting in the planes");
        progress.pass(3, "writing the program");
        let drawn = screen.text();
        // Weights 1, 2, 2, 1: the second prediction starts at 3/6, the writing at 5/6.
        assert!(drawn.contains("predicting in the planes") && drawn.contains(" 50%"), "{drawn:?}");
        assert!(drawn.contains("writing the program") && drawn.contains(" 83%"), "{drawn:?}");
        progress.finish();
    }

    #[test]
    fn a_short_run_and_a_run_without_a_terminal_draw_nothing() {
        let screen = Screen::default();
        let target = ProgressDrawTarget::term_like(Box::new(screen.clone()));
        let progress = Progress::new(&[1, 1], Some(target), Duration::from_secs(3600));
        progress.set_len(4 * u64::from(ITEMS_PER_UPDATE));
        run(&progress);
        progress.finish();
        assert_eq!(screen.text(), "");
        let silent = Progress::new(&[1, 1], None, Duration::ZERO);
        run(&silent);
        silent.finish();
    }
}
