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

/// Refuses (a [`Usage`] error, exit status 2) an output that is a folder, one of the
/// inputs, or that another output also names: the same name in the same folder, the folder taken
/// with its links followed (`./x` and `x`; `out/x` and `link-to-out/x`), and for an input
/// reached through symbolic links, the file they lead to.
pub fn distinct(reads: &[NamedFile<'_>], writes: &[NamedFile<'_>]) -> Result<(), Usage> {
    for (i, output) in writes.iter().enumerate() {
        // A folder would only be refused by the rename at the end, after the work.
        if output.path.is_dir() {
            return Err(Usage(format!(
                "{} {} is a folder: name a file in it",
                output.what,
                output.path.display()
            )));
        }
        if let Some(input) = reads.iter().find(|r| is_replaced_by(r.path, output.path)) {
            return Err(Usage(format!(
                "{} {} is {} {}: writing it would replace the input; name another file",
                output.what,
                output.path.display(),
                input.what,
                input.path.display()
            )));
        }
        if let Some(earlier) = writes[..i].iter().find(|w| same_place(w.path, output.path)) {
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

/// Whether writing `output` replaces the file `input` reads. The rename replaces the
/// directory entry `output` names: the input's own entry, or the file it leads to
/// through symbolic links. (Another hard link to the input, or a symbolic link to it, is
/// an entry of its own: replaced, it leaves the input as it was.)
fn is_replaced_by(input: &Path, output: &Path) -> bool {
    let entry = place(output);
    entry == place(input) || std::fs::canonicalize(input).is_ok_and(|file| file == entry)
}

/// Whether two outputs name one directory entry.
fn same_place(a: &Path, b: &Path) -> bool {
    place(a) == place(b)
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
        let dotted = dir.path().join(".").join("run.mcap");
        let reads = [NamedFile::new("the recording", &recording)];
        for path in [&recording, &dotted] {
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
        // A hard link is an entry of its own: replaced, it leaves the recording as it was.
        let linked = dir.path().join("linked.mcap");
        std::fs::hard_link(&recording, &linked).unwrap();
        assert!(distinct(&reads, &[NamedFile::new("--rrd", &linked)]).is_ok());
        #[cfg(unix)]
        {
            // So is a symbolic link to it; but a recording read through a link is
            // replaced by writing the file the link leads to, and the link itself.
            let link = dir.path().join("link.mcap");
            std::os::unix::fs::symlink(&recording, &link).unwrap();
            assert!(distinct(&reads, &[NamedFile::new("--rrd", &link)]).is_ok());
            let through_link = [NamedFile::new("the recording", &link)];
            for output in [&recording, &link] {
                assert!(distinct(&through_link, &[NamedFile::new("--rrd", output)]).is_err());
            }
            // A folder reached through a link is the folder.
            let folder_link = dir.path().join("here");
            std::os::unix::fs::symlink(dir.path(), &folder_link).unwrap();
            let via = folder_link.join("run.mcap");
            assert!(distinct(&reads, &[NamedFile::new("--rrd", &via)]).is_err());
        }
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
    fn an_output_that_is_a_folder_is_refused_before_the_work() {
        let dir = tempfile::tempdir().unwrap();
        let e = distinct(&[], &[NamedFile::new("--rrd", dir.path())]).unwrap_err();
        assert_eq!(
            e.0,
            format!(
                "--rrd {} is a folder: name a file in it",
                dir.path().display()
            )
        );
        let file = dir.path().join("run.rrd");
        assert!(distinct(&[], &[NamedFile::new("--rrd", &file)]).is_ok());
    }

    #[test]
    fn paths_in_folders_that_do_not_exist_compare_as_written() {
        let a = Path::new("/no/such/folder/x.rrd");
        let b = Path::new("s3://bucket/out/x.rrd");
        assert!(same_place(a, a) && same_place(b, b) && is_replaced_by(b, b));
        assert!(!same_place(a, b) && !is_replaced_by(a, b));
        assert!(!same_place(b, Path::new("s3://bucket/out/y.rrd")));
    }
}
