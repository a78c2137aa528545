//! Outputs that go to object storage: written complete to a local temporary folder (by
//! the same writers as any output), then uploaded whole, so an object is complete or
//! absent as a local output is.

use std::path::{Path, PathBuf};

use heatrun::store::{self, Location};

/// Local stand-ins for the outputs of one command that go to a store.
#[derive(Default)]
pub struct Staging {
    /// Created at the first remote output; removed (with anything not uploaded) on drop,
    /// or by `heatrun::atomic::remove_incomplete` where the process is stopped by a signal
    /// (the guard notes it until the folder is dropped: fields drop in order).
    folder: Option<(tempfile::TempDir, heatrun::atomic::Incomplete)>,
    /// Each stand-in and the object it becomes.
    uploads: Vec<(PathBuf, Location)>,
}

impl Staging {
    /// Where to write an output named `destination`: the path itself when local, else a
    /// file in the temporary folder, remembered for [`Staging::upload`].
    pub fn local(&mut self, destination: &Path) -> anyhow::Result<PathBuf> {
        let location = Location::from_path(destination)?;
        if !location.is_remote() {
            return Ok(destination.to_owned());
        }
        if self.folder.is_none() {
            let folder = tempfile::Builder::new().prefix("heatrun-out").tempdir()?;
            let noted = heatrun::atomic::Incomplete::note(folder.path());
            self.folder = Some((folder, noted));
        }
        let folder = self
            .folder
            .as_ref()
            .map(|(f, _)| f.path())
            .unwrap_or(Path::new("."));
        let name = location.file_name().unwrap_or_else(|| "output".into());
        let local = folder.join(format!("{}-{name}", self.uploads.len()));
        self.uploads.push((local.clone(), location));
        Ok(local)
    }

    /// Uploads every output staged (those written; an output not asked for is absent).
    pub fn upload(self) -> anyhow::Result<()> {
        for (local, location) in &self.uploads {
            if local.exists() {
                store::upload(local, location)?;
            }
        }
        Ok(())
    }
}
