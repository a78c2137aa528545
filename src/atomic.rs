//! Outputs that are either complete or absent: written under a temporary name in
//! the destination's folder and renamed into place only when complete.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// A temporary file beside `destination`, removed on drop unless committed.
#[derive(Debug)]
pub struct PendingOutput {
    temporary: PathBuf,
    destination: PathBuf,
    committed: bool,
}

impl PendingOutput {
    /// Reserves a temporary name beside `destination` (nothing is created yet).
    pub fn new(destination: &Path) -> PendingOutput {
        let file_name = destination
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let temporary =
            destination.with_file_name(format!(".{file_name}.{}.partial", std::process::id()));
        PendingOutput {
            temporary,
            destination: destination.to_owned(),
            committed: false,
        }
    }

    /// Where to write.
    pub fn path(&self) -> &Path {
        &self.temporary
    }

    /// The final name.
    pub fn destination(&self) -> &Path {
        &self.destination
    }

    /// Renames the finished temporary file to its destination.
    pub fn commit(mut self) -> Result<()> {
        std::fs::rename(&self.temporary, &self.destination).map_err(|e| Error::WriteOutput {
            path: self.destination.clone(),
            message: e.to_string(),
        })?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for PendingOutput {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

/// Writes `bytes` to `destination` atomically.
pub fn write_atomically(destination: &Path, bytes: &[u8]) -> Result<()> {
    let pending = PendingOutput::new(destination);
    std::fs::write(pending.path(), bytes).map_err(|e| Error::WriteOutput {
        path: destination.to_owned(),
        message: e.to_string(),
    })?;
    pending.commit()
}
