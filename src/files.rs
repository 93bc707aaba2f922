//! Every file lockstep writes goes through this module, so that what a user can rely on
//! holds for every command:
//!
//! - **Atomic**: a file is written to a temporary file in its directory and renamed over
//!   the target, so a reader never sees half a file and a failure leaves the old file (or
//!   nothing). The outputs of one command that belong together (a measurement and its side
//!   file) are renamed together under an exclusive lock of their directory, so two runs on
//!   the same output never leave one run's measurement beside the other's side file.
//! - **Regular files only**: a target that is a directory, a FIFO, a device or a socket is
//!   refused before anything is computed. A symbolic link is followed deliberately: its
//!   target is replaced and the link kept (as `cp` and editors do).
//! - **Checked first**: [`check_writable`] resolves each output and creates and removes a
//!   probe file beside it, so a command refuses an unwritable output before a long
//!   computation rather than after it.
//! - **All or nothing** under [`all_or_nothing`]: a command's outputs (report, figures,
//!   CSVs) are staged as it runs and renamed together when it succeeds; a failure part way
//!   (a diverging simulation, a bad gain set) leaves none of them.
//! - **No debris**: temporary files are removed on error, on a panic (drop) and, through
//!   [`remove_staged_files`] called from the binary's Ctrl-C handler, on SIGINT.

use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Temporary files not yet renamed or removed (for the Ctrl-C handler).
static STAGED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static COUNTER: AtomicUsize = AtomicUsize::new(0);
/// Staged files held back until the end of an [`all_or_nothing`] run.
static DEFERRED: Mutex<Option<Vec<Staged>>> = Mutex::new(None);

/// Run `body` with every commit held back: the files it writes are renamed into place
/// together when it returns `Ok`, and removed when it returns an error, so a command that
/// fails part way leaves none of its outputs. Not for long runs that must keep each
/// completed step's results (the identification sequences).
///
/// # Errors
/// `body`'s error (its files removed), or a rename that fails at the end.
pub fn all_or_nothing<T>(body: impl FnOnce() -> Result<T>) -> Result<T> {
    *locked(&DEFERRED) = Some(Vec::new());
    let result = body();
    let staged = locked(&DEFERRED).take().unwrap_or_default();
    match result {
        Ok(v) => {
            commit_now(staged)?;
            Ok(v)
        }
        Err(e) => {
            drop(staged);
            Err(e)
        }
    }
}

/// The guarded value of `m`, also after a panic elsewhere poisoned it (the lists here stay
/// valid whatever a panicking writer did).
fn locked<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Remove every temporary file of an unfinished write (called on SIGINT by the binary).
pub fn remove_staged_files() {
    let staged = locked(&STAGED).clone();
    for p in staged {
        let _ = std::fs::remove_file(p);
    }
}

/// What kind of file system object `meta` is, for messages.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// The file an output to `path` replaces: `path` itself, or the end of its chain of
/// symbolic links. The result is a regular file or does not exist yet.
///
/// # Errors
/// The path (or a link's target) is a directory, FIFO, device or socket; a chain of more
/// than 40 links; an unreadable link.
pub fn resolve_target(path: &Path) -> Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        let meta = match std::fs::symlink_metadata(&p) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(p),
            Err(e) => bail!("{}: cannot inspect: {e}", path.display()),
        };
        if meta.file_type().is_symlink() {
            let link = std::fs::read_link(&p)
                .with_context(|| format!("{}: cannot read the link", p.display()))?;
            p = if link.is_absolute() {
                link
            } else {
                p.parent().unwrap_or(Path::new("")).join(link)
            };
            continue;
        }
        if meta.is_file() {
            return Ok(p);
        }
        let through = if p == path {
            String::new()
        } else {
            format!(" (the link's target {})", p.display())
        };
        bail!(
            "{}{through} is {}: lockstep writes only regular files; give a file path",
            path.display(),
            kind_of(&meta)
        );
    }
    bail!("{}: more than 40 symbolic links", path.display())
}

/// A file being written: a temporary file beside its target, renamed over the target by
/// [`commit`] and removed if dropped uncommitted.
#[derive(Debug)]
pub struct Staged {
    tmp: PathBuf,
    target: PathBuf,
    /// The path the user gave (for messages).
    given: PathBuf,
    done: bool,
}

impl Staged {
    /// Resolve `path` ([`resolve_target`]), create its directory and an empty temporary
    /// file beside the target.
    ///
    /// # Errors
    /// As [`resolve_target`]; the directory or the temporary file cannot be created.
    pub fn new(path: &Path) -> Result<Staged> {
        let target = resolve_target(path)?;
        let dir = parent_dir(&target).to_path_buf();
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        // Keep the extension last: some writers choose the format by it.
        let ext = target
            .extension()
            .map(|e| format!(".{}", e.to_string_lossy()))
            .unwrap_or_default();
        let tmp = dir.join(format!(
            ".{name}.tmp{}-{}{ext}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        locked(&STAGED).push(tmp.clone());
        let staged = Staged {
            tmp,
            target,
            given: path.to_path_buf(),
            done: false,
        };
        std::fs::File::create(&staged.tmp)
            .with_context(|| format!("{}: cannot write in {}", path.display(), dir.display()))?;
        Ok(staged)
    }

    /// [`Staged::new`] filled with `bytes`.
    ///
    /// # Errors
    /// As [`Staged::new`] and [`Staged::fill`].
    pub fn with_bytes(path: &Path, bytes: &[u8]) -> Result<Staged> {
        let s = Staged::new(path)?;
        s.fill(|w| w.write_all(bytes).map_err(Into::into))?;
        Ok(s)
    }

    /// The temporary file (to be filled by a writer that takes a path).
    pub fn tmp_path(&self) -> &Path {
        &self.tmp
    }

    /// Fill the temporary file through a buffered writer.
    ///
    /// # Errors
    /// The callback's error or an I/O error, with the path.
    pub fn fill(
        &self,
        fill: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<()>,
    ) -> Result<()> {
        let f = std::fs::File::create(&self.tmp)
            .with_context(|| format!("cannot create {}", self.tmp.display()))?;
        let mut w = std::io::BufWriter::new(f);
        fill(&mut w).with_context(|| format!("cannot write {}", self.given.display()))?;
        w.flush()
            .with_context(|| format!("cannot write {}", self.given.display()))?;
        Ok(())
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if !self.done {
            let _ = std::fs::remove_file(&self.tmp);
        }
        locked(&STAGED).retain(|p| p != &self.tmp);
    }
}

fn parent_dir(p: &Path) -> &Path {
    p.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// Rename every staged file over its target, together (at the end of an [`all_or_nothing`]
/// run when inside one): under an exclusive lock of each
/// target directory, so concurrent commits to the same outputs do not interleave.
///
/// # Errors
/// A rename fails (the path is named); the files renamed before it stay.
pub fn commit(staged: Vec<Staged>) -> Result<()> {
    if let Some(held) = locked(&DEFERRED).as_mut() {
        held.extend(staged);
        return Ok(());
    }
    commit_now(staged)
}

fn commit_now(staged: Vec<Staged>) -> Result<()> {
    let mut dirs: Vec<PathBuf> = staged
        .iter()
        .map(|s| parent_dir(&s.target).to_path_buf())
        .collect();
    dirs.sort();
    dirs.dedup();
    // An advisory lock on the directory itself: no lock file to leave behind. Where the
    // platform cannot lock a directory the renames go ahead unlocked.
    let locks: Vec<std::fs::File> = dirs
        .iter()
        .filter_map(|d| std::fs::File::open(d).ok())
        .filter(|f| f.lock().is_ok())
        .collect();
    let mut result = Ok(());
    for mut s in staged {
        // Re-check: the target may have become a FIFO or a directory since it was staged.
        if let Err(e) = resolve_target(&s.given) {
            result = Err(e);
            break;
        }
        if let Err(e) = std::fs::rename(&s.tmp, &s.target) {
            result = Err(anyhow::anyhow!("cannot write {}: {e}", s.given.display()));
            break;
        }
        s.done = true;
    }
    drop(locks);
    result
}

/// Read back a file this command wrote: inside [`all_or_nothing`] the staged (not yet
/// renamed) version, else the file itself (a report inlines the figures it drew).
///
/// # Errors
/// Neither exists or can be read.
pub fn read_output(path: &Path) -> std::io::Result<String> {
    let staged = locked(&DEFERRED).as_ref().and_then(|held| {
        held.iter()
            .rev()
            .find(|s| s.given == path || same_file(&s.given, path))
            .map(|s| s.tmp.clone())
    });
    std::fs::read_to_string(staged.as_deref().unwrap_or(path))
}

/// Check that files can be made in `dir` without creating anything that stays: the
/// nearest existing ancestor must be a directory in which a probe file can be made (and is
/// removed). `what` is the output named in messages.
fn probe_dir(dir: &Path, what: &Path) -> Result<()> {
    let mut d = dir.to_path_buf();
    while !d.as_os_str().is_empty() && std::fs::symlink_metadata(&d).is_err() {
        d = d.parent().map(Path::to_path_buf).unwrap_or_default();
    }
    if d.as_os_str().is_empty() {
        d = PathBuf::from(".");
    }
    if !d.is_dir() {
        bail!(
            "{}: cannot be written: {} is not a directory",
            what.display(),
            d.display()
        );
    }
    let probe = d.join(format!(
        ".lockstep-probe{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::File::create(&probe)
        .with_context(|| format!("{}: cannot write in {}", what.display(), d.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Check, before any computation, that each of `paths` can be written: resolved
/// ([`resolve_target`]) and its directory (or the nearest existing ancestor) writable; no
/// directory is created. Two outputs that are the same file are refused.
///
/// # Errors
/// As [`resolve_target`]; an unwritable directory; two outputs resolve to the same file.
pub fn check_writable(paths: &[&Path]) -> Result<()> {
    let mut seen: Vec<(PathBuf, &Path)> = Vec::new();
    for p in paths {
        let target = resolve_target(p)?;
        probe_dir(parent_dir(&target), p)?;
        let key = canonical_or_absolute(&target);
        if let Some((_, first)) = seen.iter().find(|(k, _)| *k == key) {
            bail!(
                "{} and {} are the same file: give two different outputs",
                first.display(),
                p.display()
            );
        }
        seen.push((key, p));
    }
    Ok(())
}

/// Check, before any computation, that files can be written into the directory `dir`:
/// it is a directory or can be created, and a probe file can be made in it.
///
/// # Errors
/// `dir` exists and is not a directory (what it is is named); it cannot be created or
/// written.
pub fn check_output_dir(dir: &Path) -> Result<()> {
    if let Ok(meta) = std::fs::metadata(dir) {
        if !meta.is_dir() {
            bail!(
                "{} is {}: expected an output directory",
                dir.display(),
                if meta.is_file() {
                    "a file"
                } else {
                    kind_of(&meta)
                }
            );
        }
    }
    probe_dir(dir, dir)
}

/// `p` made absolute with its directory resolved, for comparing paths that may not exist.
fn canonical_or_absolute(p: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(p) {
        return c;
    }
    let dir = std::fs::canonicalize(parent_dir(p)).unwrap_or_else(|_| parent_dir(p).to_path_buf());
    match p.file_name() {
        Some(n) => dir.join(n),
        None => dir,
    }
}

/// Whether `a` and `b` name the same file (after links), existing or not.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let ra = resolve_target(a).unwrap_or_else(|_| a.to_path_buf());
    let rb = resolve_target(b).unwrap_or_else(|_| b.to_path_buf());
    canonical_or_absolute(&ra) == canonical_or_absolute(&rb)
}

/// Write `bytes` to `path` atomically (see the module documentation).
///
/// # Errors
/// As [`Staged::new`] and [`commit`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    commit(vec![Staged::with_bytes(path, bytes)?])
}

/// Like [`write_atomic`] with a writer callback; the temporary file is removed on error.
///
/// # Errors
/// As [`write_atomic`], or the callback's error.
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<()>,
) -> Result<()> {
    let s = Staged::new(path)?;
    s.fill(fill)?;
    commit(vec![s])
}

/// Write several files that belong together, each atomically and all renamed together.
///
/// # Errors
/// As [`write_atomic`]; nothing is renamed if any file cannot be staged.
pub fn write_all_atomic(files: &[(PathBuf, Vec<u8>)]) -> Result<()> {
    let staged = files
        .iter()
        .map(|(p, bytes)| Staged::with_bytes(p, bytes))
        .collect::<Result<Vec<_>>>()?;
    commit(staged)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_symlink_is_followed_and_kept() {
        let d = tempfile::tempdir().unwrap();
        let real = d.path().join("real.csv");
        std::fs::write(&real, "old").unwrap();
        let link = d.path().join("link.csv");
        std::os::unix::fs::symlink("real.csv", &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
        // A dangling link creates its target.
        let dangling = d.path().join("dangling.csv");
        std::os::unix::fs::symlink("made.csv", &dangling).unwrap();
        write_atomic(&dangling, b"x").unwrap();
        assert_eq!(
            std::fs::read_to_string(d.path().join("made.csv")).unwrap(),
            "x"
        );
        assert_eq!(
            std::fs::read_dir(d.path()).unwrap().count(),
            4,
            "no temporary left"
        );
    }

    #[test]
    fn directories_and_the_same_output_twice_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let e = write_atomic(d.path(), b"x").unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        let a = d.path().join("a.csv");
        let e = check_writable(&[&a, &d.path().join("./a.csv")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("same file"), "{e}");
        check_writable(&[&a, &d.path().join("b.csv")]).unwrap();
        assert_eq!(
            std::fs::read_dir(d.path()).unwrap().count(),
            0,
            "probes removed"
        );
    }

    #[test]
    fn a_dropped_stage_leaves_nothing() {
        let d = tempfile::tempdir().unwrap();
        let s = Staged::new(&d.path().join("x.toml")).unwrap();
        s.fill(|w| w.write_all(b"partial").map_err(Into::into))
            .unwrap();
        assert!(s.tmp_path().exists());
        drop(s);
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
    }
}
