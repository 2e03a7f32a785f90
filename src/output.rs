//! Writing results and showing progress. Every output file of every command goes through
//! [`Outputs`]: its paths are checked before the run (a bad one is a usage error naming its
//! option, exit status 2) and each file is written to a temporary file beside its target and
//! renamed into place only once every file of the invocation is written, so a failed or
//! interrupted run leaves the files of an earlier run as they were. Diagnostics go to
//! stderr through [`to_stderr`], which a closed stderr cannot turn into a panic; progress is
//! drawn only on a terminal.

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
    /// An output path that cannot be written, found before the run: exit 2, as clap's
    /// usage errors.
    Output {
        /// The option that names it (`--svg`).
        option: &'static str,
        /// The path as given.
        path: PathBuf,
        /// What is wrong with it.
        problem: BadOutput,
    },
    /// Standard output's reader is gone (`taut … | head -1`): no message, the exit status
    /// of a filter that `SIGPIPE` ended (141), as a `println!` into a closed pipe gives.
    ClosedStdout,
    /// Anything else, already worded.
    Message(String),
    /// Bad input found after the command line was parsed (a script's syntax): exit 2, as
    /// clap's usage errors.
    Usage(String),
}

/// Why an output path is refused before the run.
#[derive(Debug)]
pub enum BadOutput {
    /// The folder it would go in does not exist (the tool creates no folders on the way).
    NoFolder(PathBuf),
    /// A step of the way is a file, not a folder.
    NotAFolder(PathBuf),
    /// The path is an existing folder, or ends in a separator.
    IsAFolder,
    /// A folder of plots names an existing file.
    IsAFile,
    /// The same file as another option's output.
    SameAs(&'static str),
    /// In the folder of plots another option names.
    InFolderOf(&'static str),
    /// A folder of plots that holds another option's file.
    Holds(&'static str),
    /// The existing file is read-only.
    ReadOnly,
    /// A file cannot be created in its folder.
    CannotCreate(std::io::Error),
}

impl fmt::Display for BadOutput {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoFolder(dir) => write!(f, "the folder {} does not exist", dir.display()),
            Self::NotAFolder(file) => write!(f, "{} is a file, not a folder", file.display()),
            Self::IsAFolder => f.write_str("is a folder, not a file"),
            Self::IsAFile => f.write_str("is a file, not a folder"),
            Self::SameAs(other) => write!(f, "the same path as {other}'s"),
            Self::InFolderOf(other) => write!(f, "inside {other}'s folder of plots"),
            Self::Holds(other) => write!(f, "a folder of plots that holds {other}'s file"),
            Self::ReadOnly => f.write_str("the file is read-only"),
            Self::CannotCreate(error) => write!(f, "cannot create a file there: {error}"),
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Write { path, error } => write!(f, "cannot write {}: {error}", path.display()),
            Self::Read { path, error } => write!(f, "cannot read {}: {error}", path.display()),
            Self::Output { option, path, problem } => {
                write!(f, "{option} {}: {problem}", path.display())
            }
            Self::ClosedStdout => f.write_str("standard output is closed"),
            Self::Message(text) | Self::Usage(text) => f.write_str(text),
        }
    }
}

impl std::error::Error for Failure {}

/// The exit status of a command that ran to its end: 0 success, 1 otherwise (clap's usage
/// errors exit 2 before a command runs).
pub type Status = Result<bool, Failure>;

/// The exit status of a tool whose standard output's reader is gone: 128 + `SIGPIPE`, what
/// a shell reports for a filter that signal ended.
pub const CLOSED_STDOUT_STATUS: i32 = 141;

/// Prints a failure as the tool's one-line error, returns the exit code: 2 for a usage
/// error ([`Failure::Usage`], [`Failure::Output`]), [`CLOSED_STDOUT_STATUS`] with no message
/// for [`Failure::ClosedStdout`], 1 otherwise.
#[must_use]
pub fn report_failure(failure: &Failure) -> i32 {
    match failure {
        Failure::ClosedStdout => CLOSED_STDOUT_STATUS,
        Failure::Usage(_) | Failure::Output { .. } => {
            to_stderr(&format!("error: {failure}\n"));
            2
        }
        _ => {
            to_stderr(&format!("error: {failure}\n"));
            1
        }
    }
}

/// Writes `text` to stderr. A stderr that cannot be written (its reader gone: `taut 2>&1 |
/// head -1`) loses the text and nothing else: progress and diagnostics are not what a
/// command was asked for, so the run goes on and its files are written.
pub fn to_stderr(text: &str) {
    let mut err = std::io::stderr().lock();
    let _ = err.write_all(text.as_bytes());
    let _ = err.flush();
}

/// A JSON document as an output file's contents: pretty-printed, one newline at the end.
#[must_use]
pub fn json_bytes(doc: &serde_json::Value) -> Vec<u8> {
    let text = serde_json::to_string_pretty(doc).unwrap_or_else(|_| doc.to_string());
    (text + "\n").into_bytes()
}

/// What an output path names.
#[derive(Clone, Copy, Debug)]
enum Kind {
    /// A file.
    File,
    /// A file at the command's default path, whose one missing folder (`out/`) is created
    /// once every output is checked: the default works in a fresh checkout.
    DefaultFile,
    /// A folder the command writes its plots into (created if missing; its parent must
    /// exist).
    Folder,
}

/// The output files of one invocation, checked before the run and written together after
/// it.
#[derive(Debug, Default)]
pub struct Outputs {
    /// `(option, path as given, kind)` of every output given.
    planned: Vec<(&'static str, PathBuf, Kind)>,
}

impl Outputs {
    /// No outputs yet.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The file that `option` names, if given.
    #[must_use]
    pub fn file(mut self, option: &'static str, path: Option<&Path>) -> Self {
        if let Some(path) = path {
            self.planned.push((option, path.to_owned(), Kind::File));
        }
        self
    }

    /// The file that `option` names, or its default `path` when the option is not given
    /// (the folder the default names is created if it is missing and its parent exists).
    #[must_use]
    pub fn file_or_default(
        mut self,
        option: &'static str,
        given: Option<&Path>,
        path: &Path,
    ) -> Self {
        match given {
            Some(given) => self.planned.push((option, given.to_owned(), Kind::File)),
            None => self.planned.push((option, path.to_owned(), Kind::DefaultFile)),
        }
        self
    }

    /// The folder of plots that `option` names, if given.
    #[must_use]
    pub fn folder(mut self, option: &'static str, path: Option<&Path>) -> Self {
        if let Some(path) = path {
            self.planned.push((option, path.to_owned(), Kind::Folder));
        }
        self
    }

    /// Checks every path before the run: its folder exists and a file can be created in it,
    /// a file's path is not a folder (nor a read-only file), a folder's is not a file, no
    /// two options name the same path and no file is inside a folder of plots.
    ///
    /// # Errors
    /// [`Failure::Output`] for the first path refused.
    pub fn check(self) -> Result<Self, Failure> {
        // Every output's resolved path, its option and whether it is a folder of plots.
        let mut seen: Vec<(PathBuf, &'static str, bool)> = Vec::new();
        // The default paths' folders to create once every path is checked.
        let mut to_create = Vec::new();
        for (option, path, kind) in &self.planned {
            let refuse = |problem| Failure::Output { option, path: path.clone(), problem };
            let resolved = match kind {
                Kind::DefaultFile if !parent(path).exists() => {
                    let (dir, name) = split(path).map_err(refuse)?;
                    let (above, folder) = split(&dir).map_err(refuse)?;
                    check_folder(&above).map_err(refuse)?;
                    probe(&above).map_err(refuse)?;
                    to_create.push((option, path, dir.clone()));
                    canonical(&above).join(folder).join(name)
                }
                Kind::File | Kind::DefaultFile => {
                    let (dir, name) = split(path).map_err(refuse)?;
                    check_folder(&dir).map_err(refuse)?;
                    if let Ok(meta) = std::fs::metadata(path) {
                        if meta.is_dir() {
                            return Err(refuse(BadOutput::IsAFolder));
                        }
                        if meta.permissions().readonly() {
                            return Err(refuse(BadOutput::ReadOnly));
                        }
                    }
                    probe(&dir).map_err(refuse)?;
                    canonical(&dir).join(name)
                }
                Kind::Folder => match std::fs::metadata(path) {
                    Ok(meta) if meta.is_dir() => {
                        probe(path).map_err(refuse)?;
                        canonical(path)
                    }
                    Ok(_) => return Err(refuse(BadOutput::IsAFile)),
                    Err(_) => {
                        // `plots/` names a folder too: no `split`, which refuses it as a file.
                        let name = path
                            .file_name()
                            .ok_or_else(|| refuse(BadOutput::NoFolder(path.clone())))?;
                        let dir = parent(path).to_owned();
                        check_folder(&dir).map_err(refuse)?;
                        probe(&dir).map_err(refuse)?;
                        canonical(&dir).join(name)
                    }
                },
            };
            let folder = matches!(kind, Kind::Folder);
            for (other, other_option, other_folder) in &seen {
                if *other == resolved {
                    return Err(refuse(BadOutput::SameAs(other_option)));
                }
                if *other_folder && resolved.starts_with(other) {
                    return Err(refuse(BadOutput::InFolderOf(other_option)));
                }
                if folder && other.starts_with(&resolved) {
                    return Err(refuse(BadOutput::Holds(other_option)));
                }
            }
            seen.push((resolved, option, folder));
        }
        for (option, path, dir) in to_create {
            std::fs::create_dir(&dir).map_err(|error| Failure::Output {
                option,
                path: path.clone(),
                problem: BadOutput::CannotCreate(error),
            })?;
        }
        Ok(self)
    }

    /// Writes every file: each to a temporary file beside its target first, then, once all
    /// are written, each renamed onto its target. A folder output is created (its parent
    /// only was checked) when its first file is written. On a failure the temporary files
    /// are removed and every target not yet renamed is as it was.
    ///
    /// # Errors
    /// [`Failure::Write`] naming the target that could not be written.
    pub fn write(&self, files: &[(PathBuf, Vec<u8>)]) -> Result<(), Failure> {
        let mut staged: Vec<(PathBuf, &Path)> = Vec::new();
        let result = self.stage(files, &mut staged).and_then(|()| {
            for (temp, target) in &staged {
                std::fs::rename(temp, target)
                    .map_err(|error| Failure::Write { path: target.to_path_buf(), error })?;
            }
            Ok(())
        });
        if result.is_err() {
            for (temp, _) in &staged {
                let _ = std::fs::remove_file(temp);
            }
        }
        result
    }

    /// Writes each file's temporary copy, recording it in `staged`.
    fn stage<'a>(
        &self,
        files: &'a [(PathBuf, Vec<u8>)],
        staged: &mut Vec<(PathBuf, &'a Path)>,
    ) -> Result<(), Failure> {
        for (target, contents) in files {
            debug_assert!(self.planned_for(target), "{} was not checked", target.display());
            let fail = |error| Failure::Write { path: target.clone(), error };
            let dir = parent(target);
            let is_folder_output =
                self.planned.iter().any(|(_, p, k)| matches!(k, Kind::Folder) && p == dir);
            if is_folder_output && !dir.is_dir() {
                std::fs::create_dir(dir).map_err(fail)?;
            }
            let temp = temp_beside(target);
            let mut file = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&temp)
                .map_err(fail)?;
            staged.push((temp, target));
            file.write_all(contents).and_then(|()| file.sync_all()).map_err(fail)?;
        }
        Ok(())
    }

    /// Whether `target` is one of the checked outputs.
    fn planned_for(&self, target: &Path) -> bool {
        self.planned.iter().any(|(_, path, kind)| match kind {
            Kind::File | Kind::DefaultFile => path == target,
            Kind::Folder => parent(target) == path,
        })
    }
}

/// The folder a path is in (`.` for a bare name).
fn parent(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// `(folder, file name)` of a path that names a file.
fn split(path: &Path) -> Result<(PathBuf, &std::ffi::OsStr), BadOutput> {
    let text = path.as_os_str().to_string_lossy();
    if text.ends_with(std::path::MAIN_SEPARATOR) || text.ends_with('/') {
        return Err(BadOutput::IsAFolder);
    }
    match path.file_name() {
        Some(name) => Ok((parent(path).to_owned(), name)),
        None => Err(BadOutput::IsAFolder),
    }
}

/// Checks that `dir` exists and is a folder, naming the first step that is a file.
fn check_folder(dir: &Path) -> Result<(), BadOutput> {
    if dir.is_dir() {
        return Ok(());
    }
    match dir.ancestors().find(|a| a.is_file()) {
        Some(file) => Err(BadOutput::NotAFolder(file.to_owned())),
        None => Err(BadOutput::NoFolder(dir.to_owned())),
    }
}

/// Creates and removes a temporary file in `dir`: whether an output can be created there
/// (permissions, a read-only file system, `/proc`).
fn probe(dir: &Path) -> Result<(), BadOutput> {
    let temp = temp_beside(&dir.join("probe"));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(BadOutput::CannotCreate)?;
    let _ = std::fs::remove_file(&temp);
    Ok(())
}

/// `path` with its symbolic links and `..` resolved, when it exists.
fn canonical(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_owned())
}

/// A temporary file's path beside `target`: hidden, named after it and this process.
fn temp_beside(target: &Path) -> PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let name = target.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let unique = NEXT.fetch_add(1, Ordering::Relaxed);
    parent(target).join(format!(".{name}.{}-{unique}.taut-tmp", std::process::id()))
}
/// How often a progress line is written when stderr is not a terminal (a log, a pipe).
pub const PROGRESS_LINE_EVERY: std::time::Duration = std::time::Duration::from_secs(5);

/// How often [`parallel`]'s heartbeat looks at the clock (a terminal's bar is redrawn as
/// often).
pub const HEARTBEAT: std::time::Duration = std::time::Duration::from_millis(250);

/// A progress counter on stderr. On a terminal a bar redrawn in place with the time left,
/// `[#####-----] 12/100 runs, 0:34 elapsed, about 0:41 left`; otherwise (a log, a pipe)
/// the same figures as a line when the run starts, every [`PROGRESS_LINE_EVERY`] and when it
/// ends, so a long report is never silent for a minute. The lines come on time even while
/// no item finishes (a working-day session takes a minute): [`parallel`] keeps a heartbeat
/// beside its workers that calls [`Progress::tick`].
pub struct Progress {
    total: usize,
    done: AtomicUsize,
    label: String,
    terminal: bool,
    started: std::time::Instant,
    /// How often a line is written when stderr is not a terminal.
    every: std::time::Duration,
    /// When the last line was written (not on a terminal).
    last_line: Mutex<std::time::Instant>,
    /// Lines and redraws written so far.
    written: AtomicUsize,
}

impl Progress {
    /// A counter of `total` items.
    #[must_use]
    pub fn new(total: usize, label: &str) -> Self {
        Self::with_line_every(total, label, PROGRESS_LINE_EVERY)
    }

    /// A counter of `total` items that writes a line every `every` when stderr is not a
    /// terminal.
    #[must_use]
    pub fn with_line_every(total: usize, label: &str, every: std::time::Duration) -> Self {
        let progress = Self {
            total,
            done: AtomicUsize::new(0),
            label: label.to_owned(),
            terminal: std::io::stderr().is_terminal(),
            started: std::time::Instant::now(),
            every,
            last_line: Mutex::new(std::time::Instant::now()),
            written: AtomicUsize::new(0),
        };
        if !progress.terminal {
            progress.written.fetch_add(1, Ordering::Relaxed);
            to_stderr(&format!("{}\n", progress_text(0, total, label, std::time::Duration::ZERO)));
        }
        progress
    }

    /// One more item done.
    pub fn step(&self) {
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        self.show(done, done >= self.total);
    }

    /// The clock moved on: a line if one is due (the time elapsed and left change while an
    /// item runs); on a terminal the bar is redrawn.
    pub fn tick(&self) {
        self.show(self.done.load(Ordering::Relaxed), false);
    }

    /// Lines and redraws written so far.
    #[must_use]
    pub fn written(&self) -> usize {
        self.written.load(Ordering::Relaxed)
    }

    fn show(&self, done: usize, last: bool) {
        let Ok(mut last_line) = self.last_line.lock() else { return };
        let text = progress_text(done, self.total, &self.label, self.started.elapsed());
        if self.terminal {
            let width = 40;
            let filled = (done * width / self.total.max(1)).min(width);
            self.written.fetch_add(1, Ordering::Relaxed);
            to_stderr(&format!(
                "\r\x1b[2K[{}{}] {text}",
                "#".repeat(filled),
                "-".repeat(width - filled)
            ));
        } else if last || last_line.elapsed() >= self.every {
            *last_line = std::time::Instant::now();
            self.written.fetch_add(1, Ordering::Relaxed);
            to_stderr(&format!("{text}\n"));
        }
    }

    /// Ends the line (on a terminal).
    pub fn finish(&self) {
        if self.terminal {
            to_stderr("\n");
        }
    }
}

/// `12/100 runs, 0:34 elapsed, about 0:41 left` (the time left once an item is done, from
/// the mean time per item so far; `done` at the end).
#[must_use]
pub fn progress_text(
    done: usize,
    total: usize,
    label: &str,
    elapsed: std::time::Duration,
) -> String {
    let clock = |seconds: f64| {
        let s = seconds.max(0.0).round() as u64;
        format!("{}:{:02}", s / 60, s % 60)
    };
    let elapsed_s = elapsed.as_secs_f64();
    let left = if done >= total {
        ", done".to_owned()
    } else if done == 0 {
        String::new()
    } else {
        let per_item = elapsed_s / done as f64;
        format!(", about {} left", clock(per_item * (total - done) as f64))
    };
    format!("{done}/{total} {label}, {} elapsed{left}", clock(elapsed_s))
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
/// `progress.step()` after each and `progress.tick()` every [`HEARTBEAT`] while they run;
/// returns the results in index order.
pub fn parallel<T: Send>(
    count: u64,
    threads: usize,
    progress: &Progress,
    job: &(dyn Fn(u64) -> T + Sync),
) -> Vec<T> {
    let next = std::sync::atomic::AtomicU64::new(0);
    let finished = std::sync::atomic::AtomicBool::new(false);
    let mut results: Vec<(u64, T)> = std::thread::scope(|scope| {
        scope.spawn(|| {
            while !finished.load(Ordering::Relaxed) {
                std::thread::sleep(HEARTBEAT);
                progress.tick();
            }
        });
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
        let joined =
            workers.into_iter().map(std::thread::ScopedJoinHandle::join).collect::<Vec<_>>();
        finished.store(true, Ordering::Relaxed);
        joined
            .into_iter()
            .flat_map(|w| w.unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    });
    results.sort_by_key(|(index, _)| *index);
    progress.finish();
    results.into_iter().map(|(_, r)| r).collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::panic, reason = "a test: a panic is how it reports")]

    use super::*;

    /// An empty folder of this test's own.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("taut-output-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// The problem `outputs` is refused for, naming `option`.
    fn refused(outputs: Outputs, option: &str) -> BadOutput {
        match outputs.check() {
            Err(Failure::Output { option: named, problem, .. }) if named == option => problem,
            other => panic!("want {option} refused, got {other:?}"),
        }
    }

    #[test]
    fn a_missing_folder_is_refused_and_not_created() {
        let dir = scratch("missing");
        let path = dir.join("nowhere/deeper/x.svg");
        let problem = refused(Outputs::new().file("--svg", Some(&path)), "--svg");
        assert!(matches!(problem, BadOutput::NoFolder(ref d) if d == &dir.join("nowhere/deeper")));
        assert!(!dir.join("nowhere").exists(), "no folder created");
        let folder = dir.join("nowhere/plots");
        let problem = refused(Outputs::new().folder("--svg", Some(&folder)), "--svg");
        assert!(matches!(problem, BadOutput::NoFolder(_)), "{problem}");
        assert!(!dir.join("nowhere").exists());
    }

    #[test]
    fn a_folder_a_file_on_the_way_and_a_trailing_separator_are_refused() {
        let dir = scratch("kinds");
        std::fs::write(dir.join("file"), "x").unwrap();
        let problem = refused(Outputs::new().file("--json", Some(&dir)), "--json");
        assert!(matches!(problem, BadOutput::IsAFolder), "{problem}");
        let problem = refused(Outputs::new().file("--json", Some(&dir.join("new/"))), "--json");
        assert!(matches!(problem, BadOutput::IsAFolder), "{problem}");
        let problem = refused(Outputs::new().file("--svg", Some(&dir.join("file/x.svg"))), "--svg");
        assert!(matches!(problem, BadOutput::NotAFolder(ref f) if f == &dir.join("file")));
        let problem = refused(Outputs::new().folder("--svg", Some(&dir.join("file"))), "--svg");
        assert!(matches!(problem, BadOutput::IsAFile), "{problem}");
    }

    #[test]
    fn two_options_naming_one_path_are_refused() {
        let dir = scratch("same");
        let a = dir.join("a.out");
        let same = Outputs::new().file("--svg", Some(&a)).file("--json", Some(&a));
        assert!(matches!(refused(same, "--json"), BadOutput::SameAs("--svg")));
        // The same file by another spelling.
        let other = dir.join(".").join("a.out");
        let same = Outputs::new().file("--svg", Some(&a)).file("--csv", Some(&other));
        assert!(matches!(refused(same, "--csv"), BadOutput::SameAs("--svg")));
        let plots = dir.join("plots");
        std::fs::create_dir(&plots).unwrap();
        let inside = Outputs::new()
            .folder("--svg", Some(&plots))
            .file("--json", Some(&plots.join("a.json")));
        assert!(matches!(refused(inside, "--json"), BadOutput::InFolderOf("--svg")));
        let holds = Outputs::new()
            .file("--json", Some(&plots.join("a.json")))
            .folder("--svg", Some(&plots));
        assert!(matches!(refused(holds, "--svg"), BadOutput::Holds("--json")));
        let distinct = Outputs::new().file("--svg", Some(&a)).file("--json", Some(&dir.join("b")));
        assert!(distinct.check().is_ok());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_folder_no_file_can_be_created_in_is_refused() {
        let problem =
            refused(Outputs::new().file("--svg", Some(Path::new("/proc/x.svg"))), "--svg");
        assert!(matches!(problem, BadOutput::CannotCreate(_)), "{problem}");
    }

    #[test]
    fn checking_touches_no_file_and_writing_replaces_them_all_at_once() {
        let dir = scratch("write");
        let (svg, json) = (dir.join("a.svg"), dir.join("a.json"));
        std::fs::write(&svg, "old plot").unwrap();
        let outputs =
            Outputs::new().file("--svg", Some(&svg)).file("--json", Some(&json)).check().unwrap();
        assert_eq!(std::fs::read_to_string(&svg).unwrap(), "old plot", "checked, not emptied");
        assert!(!json.exists(), "checked, not created");
        outputs
            .write(&[(svg.clone(), b"new plot".to_vec()), (json.clone(), b"{}".to_vec())])
            .unwrap();
        assert_eq!(std::fs::read_to_string(&svg).unwrap(), "new plot");
        assert_eq!(std::fs::read_to_string(&json).unwrap(), "{}");
        let mut left: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["a.json", "a.svg"], "no temporary file left");
    }

    #[test]
    fn a_failed_write_leaves_every_target_as_it_was() {
        let dir = scratch("failed");
        let keep = dir.join("keep.svg");
        std::fs::write(&keep, "earlier plot").unwrap();
        std::fs::create_dir(dir.join("gone")).unwrap();
        let lost = dir.join("gone/a.json");
        let outputs =
            Outputs::new().file("--svg", Some(&keep)).file("--json", Some(&lost)).check().unwrap();
        // The second file's folder disappears during the run.
        std::fs::remove_dir(dir.join("gone")).unwrap();
        let result =
            outputs.write(&[(keep.clone(), b"new".to_vec()), (lost.clone(), b"{}".to_vec())]);
        assert!(
            matches!(result, Err(Failure::Write { ref path, .. }) if path == &lost),
            "{result:?}"
        );
        assert_eq!(std::fs::read_to_string(&keep).unwrap(), "earlier plot", "not replaced");
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(left.len(), 1, "the temporary file is removed");
    }

    #[test]
    fn a_folder_of_plots_is_created_when_written_and_only_then() {
        let dir = scratch("folder");
        let plots = dir.join("plots");
        let outputs = Outputs::new().folder("--svg", Some(&plots)).check().unwrap();
        assert!(!plots.exists());
        outputs.write(&[(plots.join("q.svg"), b"<svg/>".to_vec())]).unwrap();
        assert_eq!(std::fs::read_to_string(plots.join("q.svg")).unwrap(), "<svg/>");
    }

    #[test]
    fn progress_says_how_far_how_long_and_how_long_left() {
        let at = |seconds| std::time::Duration::from_secs(seconds);
        assert_eq!(progress_text(0, 100, "runs", at(0)), "0/100 runs, 0:00 elapsed");
        assert_eq!(
            progress_text(25, 100, "runs", at(30)),
            "25/100 runs, 0:30 elapsed, about 1:30 left"
        );
        assert_eq!(progress_text(100, 100, "runs", at(125)), "100/100 runs, 2:05 elapsed, done");
    }

    #[test]
    fn a_piped_progress_writes_on_time_while_a_long_item_runs() {
        // One item of 1.2 s, a line due every 0.3 s: ≥ 2 while it runs, and the end.
        let every = std::time::Duration::from_millis(300);
        let mut progress = Progress::with_line_every(1, "items", every);
        progress.terminal = false; // as when piped, whatever the test's stderr is
        let before = progress.written();
        let done = parallel(1, 1, &progress, &|_| {
            std::thread::sleep(std::time::Duration::from_millis(1_200));
            7
        });
        assert_eq!(done, [7]);
        let lines = progress.written() - before;
        assert!(lines >= 3, "{lines} lines: two or more while the item ran, and the end");
    }

    #[test]
    fn usage_errors_exit_2_and_a_closed_stdout_141() {
        let output = Failure::Output {
            option: "--svg",
            path: PathBuf::from("x/y.svg"),
            problem: BadOutput::NoFolder(PathBuf::from("x")),
        };
        assert_eq!(output.to_string(), "--svg x/y.svg: the folder x does not exist");
        assert_eq!(report_failure(&output), 2);
        assert_eq!(report_failure(&Failure::ClosedStdout), CLOSED_STDOUT_STATUS);
        assert_eq!(report_failure(&Failure::Message(String::new())), 1);
    }
}
