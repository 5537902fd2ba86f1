//! Writing output files without ever losing data.
//!
//! * [`write_atomic`]: every file rotorid writes goes to a temporary file in
//!   the same folder and is renamed over the destination only once it is
//!   complete, so a failed write (disk full, file size limit, I/O error)
//!   leaves the previous file as it was, or no file at all.
//! * [`refuse_inputs_as_outputs`]: an output path that is one of the
//!   command's inputs (the same file after resolving the path, or, on Unix,
//!   another name of it: a symbolic or hard link) is refused before
//!   anything runs.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use thiserror::Error;

/// Error writing an output file.
#[derive(Debug, Error)]
pub enum OutputError {
    /// The file (or its temporary) could not be written or renamed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The destination.
        path: String,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// An output is one of the inputs.
    #[error("{output_flag} {output} is the input {input_flag} {input}: refusing to overwrite an input (choose another output path)")]
    OutputIsInput {
        /// The option naming the output (e.g. `--json`).
        output_flag: String,
        /// The output path as given.
        output: String,
        /// The option naming the input (e.g. `--measurements`).
        input_flag: String,
        /// The input path as given.
        input: String,
    },
}

/// Distinguishes the temporaries of concurrent writes in one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// The temporary beside `path`: `.NAME.tmp-PID-N` in the same folder (so
/// that the final rename stays on one file system and is atomic).
fn temporary_for(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{name}.tmp-{}-{n}", std::process::id()))
}

/// Writes `bytes` to `path` atomically: into a new temporary file in the
/// same folder, flushed to disk, then renamed over `path`. On any error the
/// temporary is removed and `path` is untouched (its old content, or no
/// file).
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), OutputError> {
    let path = path.as_ref();
    let err = |source| OutputError::Io {
        path: path.display().to_string(),
        source,
    };
    let tmp = temporary_for(path);
    let written = (|| {
        let mut f = File::options().write(true).create_new(true).open(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        Ok(())
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(e));
    }
    // Keep the permissions of a file being replaced.
    if let Ok(meta) = std::fs::metadata(path) {
        let _ = std::fs::set_permissions(&tmp, meta.permissions());
    }
    if let Err(e) = std::fs::rename(&tmp, path) {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(e));
    }
    Ok(())
}

/// Whether `a` and `b` name the same file: equal after resolving `.`, `..`
/// and symbolic links (for a path that does not exist yet, its folder is
/// resolved), or, on Unix, the same device and inode (hard links).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    match (resolve(a), resolve(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// `path` made absolute with its links resolved; a path that does not
/// exist is resolved through its folder.
fn resolve(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Some(parent.canonicalize().ok()?.join(name))
}

/// Refuses the command when an output is one of its inputs. `inputs` and
/// `outputs` are `(option, path)` pairs; an input that does not exist (a
/// built-in model name) never matches.
pub fn refuse_inputs_as_outputs(
    inputs: &[(&str, &Path)],
    outputs: &[(&str, &Path)],
) -> Result<(), OutputError> {
    for (out_flag, out) in outputs {
        for (in_flag, input) in inputs {
            if input.exists() && same_file(input, out) {
                return Err(OutputError::OutputIsInput {
                    output_flag: (*out_flag).to_string(),
                    output: out.display().to_string(),
                    input_flag: (*in_flag).to_string(),
                    input: input.display().to_string(),
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rotorid-output-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp-"))
            .collect()
    }

    #[test]
    fn replaces_whole_files_and_leaves_no_temporary() {
        let d = scratch("replace");
        let p = d.join("a.txt");
        write_atomic(&p, b"first\n").unwrap();
        write_atomic(&p, b"second\n").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second\n");
        assert!(leftovers(&d).is_empty());
        // A destination that cannot be written: error, nothing left.
        let bad = d.join("no-such-dir").join("b.txt");
        assert!(write_atomic(&bad, b"x").is_err());
        // A folder in the way of the rename: the temporary is removed.
        std::fs::create_dir_all(d.join("sub")).unwrap();
        std::fs::write(d.join("sub").join("keep"), b"k").unwrap();
        assert!(write_atomic(d.join("sub"), b"x").is_err());
        assert!(leftovers(&d).is_empty());
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn same_file_sees_through_paths_and_links() {
        let d = scratch("same");
        let a = d.join("a.csv");
        std::fs::write(&a, b"x").unwrap();
        assert!(same_file(&a, &d.join(".").join("a.csv")));
        assert!(!same_file(&a, &d.join("b.csv")));
        #[cfg(unix)]
        {
            std::fs::hard_link(&a, d.join("hard.csv")).unwrap();
            std::os::unix::fs::symlink(&a, d.join("soft.csv")).unwrap();
            assert!(same_file(&a, &d.join("hard.csv")));
            assert!(same_file(&a, &d.join("soft.csv")));
        }
        let err = refuse_inputs_as_outputs(&[("--measurements", &a)], &[("--json", &a)])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("--json") && err.contains("--measurements"),
            "{err}"
        );
        assert!(
            refuse_inputs_as_outputs(&[("--model", Path::new("paper"))], &[("--out", &a)]).is_ok()
        );
        std::fs::remove_dir_all(&d).ok();
    }
}
