//! Outputs that are either complete or absent: written under a temporary name in
//! the destination's folder (so the final rename stays on one file system) and
//! renamed into place only when complete, by `tempfile`'s persist. Every temporary file
//! not yet renamed or removed is noted process-wide ([`Incomplete`]), so that a process
//! stopped by a signal removes them ([`remove_incomplete`]) rather than leaving them
//! beside their destinations.

use std::fs::File;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use tempfile::{Builder, NamedTempFile, TempPath};

/// An output could not be written (the folder is missing or read-only, the disk is full).
#[derive(Debug, thiserror::Error)]
#[error("{path}: cannot write: {message}")]
pub struct WriteError {
    /// The output file (its final name, not the temporary one).
    pub path: PathBuf,
    /// What went wrong.
    pub message: String,
}

impl WriteError {
    /// A failure to write `path`, with the operating system's (or a writer's) message.
    pub fn new(path: &Path, message: impl std::fmt::Display) -> WriteError {
        WriteError {
            path: path.to_owned(),
            message: message.to_string(),
        }
    }
}

type Result<T> = std::result::Result<T, WriteError>;

/// The temporary files and folders of outputs not yet complete, in the order noted.
static INCOMPLETE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn incomplete() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic elsewhere while the list was held leaves it as it was: still the list.
    INCOMPLETE
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A temporary file (or folder) of an output not yet complete, noted for
/// [`remove_incomplete`] from its creation until this is dropped (once the file is renamed
/// into place or removed).
#[derive(Debug)]
pub struct Incomplete(PathBuf);

impl Incomplete {
    /// Notes `path` as incomplete until the returned guard is dropped.
    pub fn note(path: &Path) -> Incomplete {
        incomplete().push(path.to_owned());
        Incomplete(path.to_owned())
    }
}

impl Drop for Incomplete {
    fn drop(&mut self) {
        let mut noted = incomplete();
        if let Some(i) = noted.iter().rposition(|p| *p == self.0) {
            noted.remove(i);
        }
    }
}

/// Removes every temporary file and folder of an output not yet complete ([`Incomplete`]).
/// For a process stopped by a signal (Ctrl-C), whose
/// destructors will not run: without it a replay stopped while its .rrd is written leaves
/// `.run.rrd.<random>.partial` beside the destination, hidden, as large as the .rrd had
/// grown (a week at 100 Hz: 370 MB), one more each time. A file the process renames into
/// place meanwhile is complete and stays; the list is left as it is, for the process to
/// exit.
pub fn remove_incomplete() {
    for path in incomplete().iter() {
        let _ = match std::fs::symlink_metadata(path) {
            Ok(m) if m.is_dir() => std::fs::remove_dir_all(path),
            Ok(_) => std::fs::remove_file(path),
            Err(e) => Err(e),
        };
    }
}

/// A temporary file beside `destination`, removed on drop unless committed.
#[derive(Debug)]
pub struct PendingOutput {
    /// The temporary file (removed when dropped), or why none could be made.
    temporary: std::io::Result<TempPath>,
    /// Where the caller writes: the temporary file's name.
    path: PathBuf,
    destination: PathBuf,
    /// The temporary file noted as incomplete while it exists (dropped after it is
    /// renamed or removed: fields drop in order).
    _noted: Option<Incomplete>,
}

impl PendingOutput {
    /// Creates an empty temporary file `.<name>.<random>.partial` beside `destination`
    /// for the caller to write at [`PendingOutput::path`] (by name: rerun's file sink and
    /// the MCAP writer open it themselves).
    ///
    /// Where the folder cannot take a file (missing, read-only), the caller's own attempt
    /// to write at [`PendingOutput::path`] meets the same failure and reports it, naming
    /// the destination; [`PendingOutput::commit`] would report it too.
    pub fn new(destination: &Path) -> PendingOutput {
        let (temporary, noted) = match temporary_file(destination) {
            Ok((file, noted)) => (Ok(file.into_temp_path()), Some(noted)),
            Err(e) => (Err(e), None),
        };
        let path = match &temporary {
            Ok(file) => file.to_path_buf(),
            Err(_) => folder_of(destination).join(format!(".{}.partial", file_name(destination))),
        };
        PendingOutput {
            temporary,
            path,
            destination: destination.to_owned(),
            _noted: noted,
        }
    }

    /// Whether the temporary file could be made: the error, naming the destination (not
    /// the temporary name), where its folder is missing or cannot take a file. For a
    /// caller whose writer would report the temporary name (rerun's file sink).
    pub fn made(&self) -> Result<()> {
        match &self.temporary {
            Ok(_) => Ok(()),
            Err(e) => Err(write_error(&self.destination, e)),
        }
    }

    /// The temporary file to write.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The final name, given only to a complete output.
    pub fn destination(&self) -> &Path {
        &self.destination
    }

    /// Starts the system writing what the temporary file holds so far to its disk, without
    /// waiting for it (Linux's `sync_file_range` with `SYNC_FILE_RANGE_WRITE`, the
    /// write-out git's batched fsync starts with; elsewhere, nothing).
    ///
    /// Why: where the rename of [`PendingOutput::commit`] replaces an older file, ext4
    /// writes the new file's data out first (its `auto_da_alloc`, so that a crash cannot
    /// leave an empty file in the old one's place), and the rename waits for that: 9 ms
    /// of W0's replay for its 15 MB .rrd. Started while the writer still finishes the
    /// file, that writing is mostly done by the rename. Nothing is promised by it: a
    /// failure is ignored (the rename then waits as before).
    pub fn start_writeback(&self) {
        #[cfg(target_os = "linux")]
        if let Ok(file) = File::open(&self.path) {
            use std::os::fd::AsRawFd as _;
            // SAFETY: the descriptor is open for this call's length (`file` lives to the end
            // of the block); offset 0 and length 0 name the whole file; the call reads and
            // writes no memory of ours.
            unsafe {
                libc::sync_file_range(file.as_raw_fd(), 0, 0, libc::SYNC_FILE_RANGE_WRITE);
            }
        }
    }

    /// Removes the file at the destination, if any, ahead of [`PendingOutput::commit`]:
    /// the output is then absent, never partial, until the commit renames it in place.
    ///
    /// Why: a rename that replaces a file also frees the old one (its blocks, its pages
    /// in the cache), inside the rename: 4–5 ms of W0's replay for its 15 MB .rrd, with a
    /// core idle. Removed while the writer still finishes the new file, the old one is
    /// freed beside that work. Called only once everything is sent, so that only a failure
    /// to write the last bytes can leave neither file. A failure is ignored (the rename
    /// then replaces the file as before); a folder is never removed.
    pub fn remove_destination(&self) {
        if std::fs::symlink_metadata(&self.destination).is_ok_and(|m| !m.is_dir()) {
            let _ = std::fs::remove_file(&self.destination);
        }
    }

    /// Renames the finished temporary file to its destination (replacing what was there).
    pub fn commit(self) -> Result<()> {
        match self.temporary {
            Ok(file) => file
                .persist(&self.destination)
                .map_err(|e| write_error(&self.destination, &e.error)),
            Err(e) => Err(write_error(&self.destination, &e)),
        }
    }
}

/// Whether `destination` can be written where it is: its folder exists and is a folder.
/// For outputs written only at the end of a long run (a replay's report and page), so
/// that a mistyped folder is found before the run rather than after it.
pub fn folder_exists(destination: &Path) -> Result<()> {
    let folder = folder_of(destination);
    if folder.is_dir() {
        return Ok(());
    }
    Err(WriteError::new(
        destination,
        format!("the folder {} does not exist", folder.display()),
    ))
}

/// Writes `bytes` to `destination` atomically.
pub fn write_atomically(destination: &Path, bytes: &[u8]) -> Result<()> {
    let (mut file, _noted) =
        temporary_file(destination).map_err(|e| write_error(destination, &e))?;
    file.write_all(bytes)
        .map_err(|e| write_error(destination, &e))?;
    file.persist(destination)
        .map_err(|e| write_error(destination, &e.error))?;
    Ok(())
}

/// A new, uniquely named file beside `destination`, noted as incomplete. Created with
/// `File::create_new` rather than tempfile's default so that it gets the usual
/// permissions (0666 less the umask), not 0600: the output is an ordinary file once
/// renamed.
fn temporary_file(destination: &Path) -> std::io::Result<(NamedTempFile, Incomplete)> {
    let file = Builder::new()
        .prefix(&format!(".{}.", file_name(destination)))
        .suffix(".partial")
        .make_in(folder_of(destination), |path| File::create_new(path))?;
    let noted = Incomplete::note(file.path());
    Ok((file, noted))
}

/// The folder an output goes to (`.` for a bare file name).
fn folder_of(destination: &Path) -> &Path {
    match destination.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

fn file_name(destination: &Path) -> String {
    destination
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn write_error(destination: &Path, e: &std::io::Error) -> WriteError {
    WriteError::new(destination, e)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `path` is noted as incomplete. (The tests never call
    /// [`remove_incomplete`]: the list is the process's, and the tests beside these write
    /// outputs of their own.)
    fn noted(path: &Path) -> bool {
        incomplete().iter().any(|p| p == path)
    }

    #[test]
    fn a_temporary_file_is_noted_as_incomplete_until_it_is_renamed_or_removed() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run.rrd");
        let pending = PendingOutput::new(&out);
        let temporary = pending.path().to_owned();
        assert!(noted(&temporary));
        std::fs::write(&temporary, b"complete").unwrap();
        pending.commit().unwrap();
        assert!(!noted(&temporary) && out.exists());
        let dropped = PendingOutput::new(&out);
        let temporary = dropped.path().to_owned();
        assert!(noted(&temporary));
        drop(dropped);
        assert!(!noted(&temporary) && !temporary.exists());
        // A folder that cannot take the file notes nothing.
        let nowhere = PendingOutput::new(&dir.path().join("missing/run.rrd"));
        assert!(!noted(nowhere.path()));
        // A staging folder, noted by its guard.
        let staging = dir.path().join("staging");
        let guard = Incomplete::note(&staging);
        assert!(noted(&staging));
        drop(guard);
        assert!(!noted(&staging));
    }

    fn names_in(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_committed_output_replaces_the_old_one_and_leaves_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("report.json");
        std::fs::write(&out, "old").unwrap();
        let pending = PendingOutput::new(&out);
        assert_eq!(pending.path().parent(), Some(dir.path()));
        let temporary = pending
            .path()
            .file_name()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        assert!(
            temporary.starts_with(".report.json.") && temporary.ends_with(".partial"),
            "{temporary}"
        );
        std::fs::write(pending.path(), "new").unwrap();
        assert_eq!(
            std::fs::read_to_string(&out).unwrap(),
            "old",
            "not before commit"
        );
        pending.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "new");
        assert_eq!(names_in(dir.path()), ["report.json"]);
    }

    #[test]
    fn a_missing_folder_is_named_by_the_destination_before_anything_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("missing").join("run.rrd");
        let e = PendingOutput::new(&out).made().unwrap_err();
        assert_eq!(e.path, out);
        assert!(e
            .to_string()
            .starts_with(&format!("{}: cannot write:", out.display())));
        assert!(PendingOutput::new(&dir.path().join("run.rrd"))
            .made()
            .is_ok());
    }

    #[test]
    fn an_output_in_a_missing_folder_is_found_before_it_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing").join("report.json");
        let e = folder_exists(&missing).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "{}: cannot write: the folder {} does not exist",
                missing.display(),
                dir.path().join("missing").display()
            )
        );
        std::fs::write(dir.path().join("file"), "").unwrap();
        assert!(folder_exists(&dir.path().join("file").join("x.json")).is_err());
        assert!(folder_exists(&dir.path().join("report.json")).is_ok());
        assert!(
            folder_exists(Path::new("report.json")).is_ok(),
            "the current folder"
        );
    }

    #[test]
    fn an_abandoned_output_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run.rrd");
        let pending = PendingOutput::new(&out);
        std::fs::write(pending.path(), "half a recording").unwrap();
        drop(pending);
        assert!(names_in(dir.path()).is_empty());
    }

    #[test]
    fn the_old_output_removed_ahead_is_absent_until_the_new_one_is_complete() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run.rrd");
        std::fs::write(&out, "old").unwrap();
        let pending = PendingOutput::new(&out);
        std::fs::write(pending.path(), "new").unwrap();
        pending.remove_destination();
        assert!(!out.exists(), "absent, not partial, before the commit");
        pending.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "new");
        assert_eq!(names_in(dir.path()), ["run.rrd"]);
        // Nothing there yet: nothing to remove, and the commit places the output.
        let fresh = dir.path().join("fresh.rrd");
        let pending = PendingOutput::new(&fresh);
        std::fs::write(pending.path(), "first").unwrap();
        pending.remove_destination();
        pending.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&fresh).unwrap(), "first");
        // A folder in the output's place is left to the rename, which refuses it.
        let folder = dir.path().join("folder.rrd");
        std::fs::create_dir(&folder).unwrap();
        std::fs::write(folder.join("inside"), "kept").unwrap();
        let pending = PendingOutput::new(&folder);
        pending.remove_destination();
        assert!(pending.commit().is_err());
        assert_eq!(
            std::fs::read_to_string(folder.join("inside")).unwrap(),
            "kept"
        );
    }

    #[test]
    fn two_pending_outputs_of_one_destination_do_not_collide() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("fleet-summary.csv");
        let (a, b) = (PendingOutput::new(&out), PendingOutput::new(&out));
        assert_ne!(a.path(), b.path());
    }

    #[cfg(unix)]
    #[test]
    fn an_output_gets_the_usual_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("report.json");
        write_atomically(&out, b"{}").unwrap();
        let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        // What `File::create` gives under this umask (0644 under the usual 022), not
        // tempfile's 0600 for its own files.
        let usual = {
            let probe = dir.path().join("probe");
            File::create(&probe).unwrap();
            std::fs::metadata(&probe).unwrap().permissions().mode() & 0o777
        };
        assert_eq!(mode, usual);
        assert_eq!(std::fs::read(&out).unwrap(), b"{}");
        assert_eq!(names_in(dir.path()), ["probe", "report.json"]);
    }

    #[test]
    fn a_missing_folder_is_an_error_naming_the_destination() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("no/such/folder/report.json");
        let err = write_atomically(&out, b"{}").unwrap_err().to_string();
        assert!(err.starts_with(&out.display().to_string()), "{err}");
        assert!(err.contains("cannot write"), "{err}");
        // The pending form reports it when written and committed, not before.
        let pending = PendingOutput::new(&out);
        assert!(std::fs::write(pending.path(), "x").is_err());
        assert!(pending.commit().is_err());
    }
}
