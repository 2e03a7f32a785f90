//! Writing results and showing progress: every I/O failure is one line and exit status 1;
//! progress is drawn only on a terminal.

use std::fmt;
use std::io::{IsTerminal as _, Write as _};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A failure while a command runs (not a usage error): printed as one line `error: …`,
/// exit status 1.
#[derive(Debug)]
pub enum Failure {
    /// A file or directory could not be written.
    Write {
        /// The path.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// A file could not be read.
    Read {
        /// The path (`-` for standard input).
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// Anything else, already worded.
    Message(String),
    /// Bad input found after the command line was parsed (a script's syntax): exit 2, as
    /// clap's usage errors.
    Usage(String),
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Write { path, error } => write!(f, "cannot write {}: {error}", path.display()),
            Self::Read { path, error } => write!(f, "cannot read {}: {error}", path.display()),
            Self::Message(text) | Self::Usage(text) => f.write_str(text),
        }
    }
}

impl std::error::Error for Failure {}

/// The exit status of a command that ran to its end: 0 success, 1 otherwise (clap's usage
/// errors exit 2 before a command runs).
pub type Status = Result<bool, Failure>;

/// Prints a failure as the tool's one-line error, returns the exit code: 2 for
/// [`Failure::Usage`], 1 otherwise.
#[must_use]
pub fn report_failure(failure: &Failure) -> i32 {
    eprintln!("error: {failure}");
    if matches!(failure, Failure::Usage(_)) { 2 } else { 1 }
}

/// Writes `contents` to `path`, creating its parent directories.
///
/// # Errors
/// [`Failure::Write`].
pub fn write_file(path: &Path, contents: impl AsRef<[u8]>) -> Result<(), Failure> {
    let fail = |error| Failure::Write { path: path.to_owned(), error };
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|error| {
            // "File exists" says little when a folder on the way is a file: name it.
            match parent.ancestors().find(|a| a.is_file()) {
                Some(file) => Failure::Message(format!(
                    "cannot write {}: {} is a file, not a folder",
                    path.display(),
                    file.display()
                )),
                None => fail(error),
            }
        })?;
    }
    std::fs::write(path, contents).map_err(fail)
}

/// Writes a JSON document, pretty-printed.
///
/// # Errors
/// [`Failure::Write`].
pub fn write_json(path: &Path, doc: &serde_json::Value) -> Result<(), Failure> {
    let text = serde_json::to_string_pretty(doc).unwrap_or_else(|_| doc.to_string());
    write_file(path, text + "\n")
}

/// Creates directory `dir` (and its parents).
///
/// # Errors
/// [`Failure::Write`].
pub fn create_dir(dir: &Path) -> Result<(), Failure> {
    std::fs::create_dir_all(dir).map_err(|error| match dir.ancestors().find(|a| a.is_file()) {
        Some(file) => Failure::Message(format!(
            "cannot write {}: {} is a file, not a folder",
            dir.display(),
            file.display()
        )),
        None => Failure::Write { path: dir.to_owned(), error },
    })
}

/// Checks before a long run that `path` can be written (creates it empty), so a typo in an
/// output path fails in a second, not after an hour of simulation.
///
/// # Errors
/// [`Failure::Write`].
pub fn check_writable(path: &Path) -> Result<(), Failure> {
    write_file(path, [])
}

/// A progress counter on stderr, drawn only when stderr is a terminal (a log gets no
/// carriage returns): `[#####-----] 12/100 label`.
pub struct Progress {
    total: usize,
    done: AtomicUsize,
    label: String,
    terminal: bool,
    lock: Mutex<()>,
}

impl Progress {
    /// A counter of `total` items.
    #[must_use]
    pub fn new(total: usize, label: &str) -> Self {
        Self {
            total,
            done: AtomicUsize::new(0),
            label: label.to_owned(),
            terminal: std::io::stderr().is_terminal(),
            lock: Mutex::new(()),
        }
    }

    /// One more item done.
    pub fn step(&self) {
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if !self.terminal {
            return;
        }
        let _guard = self.lock.lock();
        let width = 40;
        let filled = done * width / self.total.max(1);
        let mut err = std::io::stderr().lock();
        let _ = write!(
            err,
            "\r[{}{}] {done}/{} {}",
            "#".repeat(filled.min(width)),
            "-".repeat(width - filled.min(width)),
            self.total,
            self.label
        );
        let _ = err.flush();
    }

    /// Ends the line (on a terminal).
    pub fn finish(&self) {
        if self.terminal {
            eprintln!();
        }
    }
}

/// Worker threads: `requested`, or the machine's cores.
#[must_use]
pub fn threads(requested: Option<u16>) -> usize {
    requested.map_or_else(
        || std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get),
        usize::from,
    )
}

/// Runs `job(i)` for `i` in `0..count` on `threads` threads, in any order, calling
/// `progress.step()` after each; returns the results in index order.
pub fn parallel<T: Send>(
    count: u64,
    threads: usize,
    progress: &Progress,
    job: &(dyn Fn(u64) -> T + Sync),
) -> Vec<T> {
    let next = std::sync::atomic::AtomicU64::new(0);
    let mut results: Vec<(u64, T)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads.max(1))
            .map(|_| {
                scope.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let index = next.fetch_add(1, Ordering::Relaxed);
                        if index >= count {
                            break;
                        }
                        mine.push((index, job(index)));
                        progress.step();
                    }
                    mine
                })
            })
            .collect();
        // A worker that panicked has hit a bug: its panic is re-raised here.
        workers
            .into_iter()
            .flat_map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    });
    results.sort_by_key(|(index, _)| *index);
    progress.finish();
    results.into_iter().map(|(_, r)| r).collect()
}
