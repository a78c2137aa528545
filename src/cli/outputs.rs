//! A command's outputs never replace its inputs or each other.
//!
//! Every output is written under a temporary name and renamed over its destination
//! (`heatrun::atomic`), so `--rrd run.mcap` would replace the recording just read, and
//! `--report out.json --html out.json` would leave only the page: each run would succeed
//! and a file would be lost. Both are refused here, before anything is read.

use std::path::{Path, PathBuf};

use super::Usage;

/// A file a command reads or writes, with what names it on the command line (`--rrd`,
/// `the recording`, `the .rrd of a/run.mcap`).
#[derive(Debug, Clone)]
pub struct NamedFile<'a> {
    /// How the command line names it, for the message.
    pub what: String,
    /// The path as given.
    pub path: &'a Path,
}

impl<'a> NamedFile<'a> {
    /// A file named `what` at `path`.
    pub fn new(what: impl Into<String>, path: &'a Path) -> NamedFile<'a> {
        NamedFile {
            what: what.into(),
            path,
        }
    }
}

/// Refuses (a [`Usage`] error, exit status 2) an output that is one of the inputs, or
/// that another output also names. Paths name the same file when they reach the same
/// inode (a hard or symbolic link, `./x` and `x`), or, for a file not yet there, the
/// same name in the same folder.
pub fn distinct(reads: &[NamedFile<'_>], writes: &[NamedFile<'_>]) -> Result<(), Usage> {
    for (i, output) in writes.iter().enumerate() {
        if let Some(input) = reads.iter().find(|r| same_file(r.path, output.path)) {
            return Err(Usage(format!(
                "{} {} is {} {}: writing it would replace the input; name another file",
                output.what,
                output.path.display(),
                input.what,
                input.path.display()
            )));
        }
        if let Some(earlier) = writes[..i].iter().find(|w| same_file(w.path, output.path)) {
            return Err(Usage(format!(
                "{} and {} both name {}: one would replace the other; give each output its \
                 own name",
                earlier.what,
                output.what,
                output.path.display()
            )));
        }
    }
    Ok(())
}

/// Whether `a` and `b` name one file: for two that exist, the same device and inode;
/// else the same name in the same (canonical) folder.
fn same_file(a: &Path, b: &Path) -> bool {
    if let (Ok(a), Ok(b)) = (std::fs::metadata(a), std::fs::metadata(b)) {
        return same_inode(&a, &b);
    }
    place(a) == place(b)
}

#[cfg(unix)]
fn same_inode(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt as _;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_inode(_: &std::fs::Metadata, _: &std::fs::Metadata) -> bool {
    false
}

/// Where a path names a file: its folder made canonical, joined with its name; as given
/// where the folder does not exist (or the path is a URL), which then compares as text.
fn place(path: &Path) -> PathBuf {
    let (Some(folder), Some(name)) = (path.parent(), path.file_name()) else {
        return path.to_owned();
    };
    let folder = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    std::fs::canonicalize(folder)
        .map(|f| f.join(name))
        .unwrap_or_else(|_| path.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_over_an_input_is_refused_by_any_of_its_names() {
        let dir = tempfile::tempdir().unwrap();
        let recording = dir.path().join("run.mcap");
        std::fs::write(&recording, "recording").unwrap();
        let linked = dir.path().join("linked.mcap");
        std::fs::hard_link(&recording, &linked).unwrap();
        let dotted = dir.path().join(".").join("run.mcap");
        let reads = [NamedFile::new("the recording", &recording)];
        for path in [&recording, &linked, &dotted] {
            let e = distinct(&reads, &[NamedFile::new("--rrd", path)]).unwrap_err();
            assert!(
                e.0.starts_with(&format!("--rrd {} is the recording", path.display()))
                    && e.0.contains("replace the input"),
                "{}",
                e.0
            );
        }
        let other = dir.path().join("run.rrd");
        assert!(distinct(&reads, &[NamedFile::new("--rrd", &other)]).is_ok());
    }

    #[test]
    fn two_outputs_of_one_name_are_refused_whether_or_not_the_file_exists() {
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("out.json");
        let same = dir.path().join(".").join("out.json");
        let page = dir.path().join("out.html");
        for exists in [false, true] {
            if exists {
                std::fs::write(&report, "{}").unwrap();
            }
            let writes = [
                NamedFile::new("--report", &report),
                NamedFile::new("--html", &page),
                NamedFile::new("--rrd", &same),
            ];
            let e = distinct(&[], &writes).unwrap_err();
            assert!(
                e.0.starts_with("--report and --rrd both name"),
                "{exists}: {}",
                e.0
            );
            assert!(distinct(&[], &writes[..2]).is_ok());
        }
    }

    #[test]
    fn paths_in_folders_that_do_not_exist_compare_as_written() {
        let a = Path::new("/no/such/folder/x.rrd");
        let b = Path::new("s3://bucket/out/x.rrd");
        assert!(same_file(a, a) && same_file(b, b));
        assert!(!same_file(a, b));
        assert!(!same_file(b, Path::new("s3://bucket/out/y.rrd")));
    }
}
