//! Writing files: every file hsph writes is opened here, so that it never truncates or
//! renames over a path that is not a regular file (a device, a FIFO, a directory), and whole
//! files go to disk atomically (a temporary file, then a rename). Below the run directory
//! ([`crate::output`]) and checkpoints ([`crate::checkpoint`]), which both write through it;
//! depends on nothing but [`crate::error`].

use crate::error::{Error, Result};
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::Path;

/// Refuse to write over `path` if it is there and is not a regular file (a device such as
/// `/dev/full`, a FIFO, a directory): hsph never truncates or renames over one.
pub fn refuse_non_regular(path: &Path) -> Result<()> {
    match fs::metadata(path) {
        Ok(m) if !m.is_file() => Err(Error::input(
            path.display().to_string(),
            "exists and is not a regular file (a device, FIFO or directory); hsph writes only \
             regular files: choose another path",
        )),
        _ => Ok(()),
    }
}

/// Open `path` for writing. The test-only switch `HSPH_TEST_FULL_DISK=SUFFIX` sends a file
/// whose name ends with SUFFIX to `/dev/full`, so that tests see what a full disk does.
pub(crate) fn create_file(path: &Path) -> Result<File> {
    let full = std::env::var("HSPH_TEST_FULL_DISK")
        .ok()
        .is_some_and(|suffix| !suffix.is_empty() && path.to_string_lossy().ends_with(&suffix));
    if !full {
        refuse_non_regular(path)?;
    }
    let target = if full { Path::new("/dev/full") } else { path };
    let f = if full {
        fs::OpenOptions::new().write(true).open(target)
    } else {
        File::create(target)
    };
    f.map_err(|e| Error::io(path, e))
}

/// [`create_file`], buffered.
pub(crate) fn create(path: &Path) -> Result<BufWriter<File>> {
    Ok(BufWriter::new(create_file(path)?))
}

/// Write `bytes` as the whole file `path`, atomically, never over a non-regular file: the one
/// way commands other than the step loop write a file (plans, reports, charts' markdown,
/// validation tables, job scripts).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |f| f.write_all(bytes))
}

/// Write a whole file atomically: into `<path>.tmp`, then renamed over `path`. On any failure
/// the temporary file is removed and `path` is left as it was (never truncated).
pub(crate) fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<()> {
    let mut tmp_name = path.file_name().unwrap_or_default().to_os_string();
    tmp_name.push(".tmp");
    let tmp = path.with_file_name(tmp_name);
    refuse_non_regular(path)?;
    let result = create(&tmp).and_then(|mut f| {
        write(&mut f)
            .and_then(|_| f.flush())
            .and_then(|_| f.get_ref().sync_data().or(Ok(())))
            .map_err(|e| Error::io(path, e))
    });
    match result {
        Ok(()) => fs::rename(&tmp, path).map_err(|e| Error::io(path, e)),
        Err(e) => {
            let _ = fs::remove_file(&tmp);
            Err(e)
        }
    }
}
