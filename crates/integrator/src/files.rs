//! Writing files all or nothing, for every file a render writes (images and films alike): each
//! file to a temporary beside it, checked (the buffered writer's final flush included) and
//! fsynced; only when all succeeded, each renamed into place; on any error every temporary is
//! removed and no output appears. A signal handler can call [`remove_pending_outputs`] to delete
//! the temporaries of a write in progress before exiting.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::error::{Error, Result};

/// Writes one file's content into the buffered temporary.
pub(crate) type Encoder<'a> = Box<dyn Fn(&mut BufWriter<File>) -> std::result::Result<(), String> + 'a>;

/// Write `bytes` to `path` atomically: a temporary beside it, checked, fsynced, renamed.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    write_all_or_nothing(&[(path, Box::new(|w: &mut BufWriter<File>| w.write_all(bytes).map_err(|e| e.to_string())))])
}

/// Write each `(path, bytes)`, all or nothing ([`write_all_or_nothing`]).
pub fn write_files_atomically(files: &[(&Path, &[u8])]) -> Result<()> {
    let encoders: Vec<(&Path, Encoder<'_>)> = files
        .iter()
        .map(|&(path, bytes)| -> (&Path, Encoder<'_>) {
            (path, Box::new(move |w: &mut BufWriter<File>| w.write_all(bytes).map_err(|e| e.to_string())))
        })
        .collect();
    write_all_or_nothing(&encoders)
}

/// Every file to a temporary beside it, checked and fsynced; then, only when all succeeded,
/// each renamed into place. On an error every temporary is removed and nothing is renamed.
pub(crate) fn write_all_or_nothing(files: &[(&Path, Encoder<'_>)]) -> Result<()> {
    let mut staged: Vec<(PathBuf, &Path)> = Vec::with_capacity(files.len());
    for (path, encode) in files {
        let result = temporary_path(path).and_then(|tmp| {
            register(&tmp).map_err(|message| Error::Write { path: path.to_path_buf(), message })?;
            staged.push((tmp.clone(), path));
            write_file(&tmp, encode).map_err(|message| Error::Write { path: path.to_path_buf(), message })
        });
        if let Err(e) = result {
            discard(&staged);
            return Err(e);
        }
    }
    // Every temporary is complete and on disk: rename them all. The registry stays locked
    // so that a signal handler's cleanup waits for the renames instead of racing them.
    let mut pending = lock_pending();
    for (i, (tmp, path)) in staged.iter().enumerate() {
        if let Err(e) = std::fs::rename(tmp, path) {
            drop(pending);
            // The ones already renamed are complete files; the rest are removed.
            discard(&staged[i..]);
            return Err(Error::Write { path: path.to_path_buf(), message: format!("rename: {e}") });
        }
        pending.paths.retain(|p| p != tmp);
    }
    drop(pending);
    // Make the renames themselves durable (the folder entries), best effort: not every
    // file system supports fsync on a folder.
    for (_, path) in &staged {
        if let Some(dir) = path.parent().map(|d| if d.as_os_str().is_empty() { Path::new(".") } else { d }) {
            let _ = File::open(dir).and_then(|d| d.sync_all());
        }
    }
    Ok(())
}

/// Refuse two outputs on one path (`-o x.exr --spectral-exr x.exr` silently replaced the RGB
/// EXR). Paths are compared after resolving their folder (symbolic links, `..`), so
/// `out/x.exr` and `out/../out/x.exr` clash too; a folder that does not exist is compared as
/// written (the write then fails on it anyway).
pub fn check_distinct_outputs(paths: &[&Path]) -> Result<()> {
    for (i, a) in paths.iter().enumerate() {
        for b in &paths[..i] {
            if entry_key(a) == entry_key(b) {
                return Err(Error::Write {
                    path: a.to_path_buf(),
                    message: format!("given for two outputs (also {}); each output needs its own file", b.display()),
                });
            }
        }
    }
    Ok(())
}

/// Refuse an output on the path of one of the command's inputs, each given with what it is for
/// the message (`the scene's file`, `a part being merged`): an output is renamed into place, so
/// it would replace the input (`-o tex.exr` wrote `tex.png` over the scene's texture, `--film
/// scene.mtl` replaced the MTL with film bytes). Also refuses two outputs on one path
/// ([`check_distinct_outputs`]). A path that does not exist yet is no input, and an input is
/// matched as its folder entry (what the rename replaces) and as the file a symbolic link leads
/// to.
pub fn check_outputs_spare_inputs(outputs: &[&Path], inputs: &[(&Path, &str)]) -> Result<()> {
    check_distinct_outputs(outputs)?;
    let inputs: Vec<(PathBuf, Option<PathBuf>, &Path, &str)> = inputs
        .iter()
        .filter(|(path, _)| path.exists())
        .map(|&(path, what)| (entry_key(path), std::fs::canonicalize(path).ok(), path, what))
        .collect();
    for output in outputs {
        let key = entry_key(output);
        let hit = inputs.iter().find(|(entry, target, ..)| *entry == key || target.as_ref() == Some(&key));
        if let Some((.., input, what)) = hit {
            return Err(Error::Write {
                path: output.to_path_buf(),
                message: format!("would overwrite {what} {}; write the output elsewhere", input.display()),
            });
        }
    }
    Ok(())
}

/// The folder entry `p` names: its folder resolved (symbolic links, `..`) and its file name; a
/// folder that does not exist is kept as written.
fn entry_key(p: &Path) -> PathBuf {
    let parent = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    match (std::fs::canonicalize(parent), p.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => p.to_owned(),
    }
}

/// Temporaries of writes in progress, for [`remove_pending_outputs`]. `closed` once a
/// cleanup ran: the process is exiting, so no new temporary may appear after it.
struct Pending {
    paths: Vec<PathBuf>,
    closed: bool,
}

static PENDING: Mutex<Pending> = Mutex::new(Pending { paths: Vec::new(), closed: false });

fn lock_pending() -> std::sync::MutexGuard<'static, Pending> {
    lock(&PENDING)
}

fn lock(registry: &Mutex<Pending>) -> std::sync::MutexGuard<'_, Pending> {
    // A panic while the lock was held leaves a list of paths that is still valid.
    registry.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn register(tmp: &Path) -> std::result::Result<(), String> {
    register_in(&PENDING, tmp)
}

fn register_in(registry: &Mutex<Pending>, tmp: &Path) -> std::result::Result<(), String> {
    let mut pending = lock(registry);
    if pending.closed {
        return Err("the process is exiting (interrupted)".to_owned());
    }
    pending.paths.push(tmp.to_owned());
    Ok(())
}

/// Remove the given temporaries and forget them.
fn discard(staged: &[(PathBuf, &Path)]) {
    let mut pending = lock_pending();
    for (tmp, _) in staged {
        let _ = std::fs::remove_file(tmp);
        pending.paths.retain(|p| p != tmp);
    }
}

/// Delete the temporary files of every write in progress and refuse new ones; for a SIGINT
/// or SIGTERM handler that is about to exit the process. If the final renames are under way
/// it waits for them (the outputs are then complete). Returns how many files it removed.
pub fn remove_pending_outputs() -> usize {
    remove_pending_in(&PENDING)
}

fn remove_pending_in(registry: &Mutex<Pending>) -> usize {
    let mut pending = lock(registry);
    pending.closed = true;
    let removed = pending.paths.iter().filter(|p| std::fs::remove_file(p).is_ok()).count();
    pending.paths.clear();
    removed
}

/// `.out.exr.<pid>.tmp` beside `out.exr`: the same folder, so the rename cannot cross file
/// systems.
fn temporary_path(path: &Path) -> Result<PathBuf> {
    let file_name = path
        .file_name()
        .ok_or_else(|| Error::Write { path: path.to_owned(), message: "not a file name".to_owned() })?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(file_name);
    tmp_name.push(format!(".{}.tmp", std::process::id()));
    Ok(path.with_file_name(tmp_name))
}

/// Create `tmp`, encode into it through a buffer whose final flush is checked, and fsync it.
/// (The `image` crate's `save_buffer` drops its `BufWriter`, and a drop ignores the flush
/// error: on a full disk a PNG that fitted in the 8 KiB buffer came out as 0 bytes with
/// success reported.)
fn write_file(
    tmp: &Path,
    encode: &dyn Fn(&mut BufWriter<File>) -> std::result::Result<(), String>,
) -> std::result::Result<(), String> {
    let file = File::create(tmp).map_err(|e| e.to_string())?;
    let file = encode_checked(file, encode)?;
    file.sync_all().map_err(|e| format!("fsync: {e}"))
}

/// Encode into `inner` through a buffer and return it after a checked flush.
pub(crate) fn encode_checked<W: Write>(
    inner: W,
    encode: impl FnOnce(&mut BufWriter<W>) -> std::result::Result<(), String>,
) -> std::result::Result<W, String> {
    let mut w = BufWriter::new(inner);
    encode(&mut w)?;
    w.into_inner().map_err(|e| e.error().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_signal_cleanup_removes_pending_temporaries_and_refuses_new_ones() {
        // A registry of its own: closing the process-wide one would fail the other tests
        // running in parallel.
        let registry = Mutex::new(Pending { paths: Vec::new(), closed: false });
        let dir = std::env::temp_dir().join(format!("spectrace-pending-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let tmp = dir.join(".x.exr.1.tmp");
        std::fs::write(&tmp, b"partial").unwrap();
        register_in(&registry, &tmp).unwrap();
        assert_eq!(remove_pending_in(&registry), 1);
        assert!(!tmp.exists());
        assert!(register_in(&registry, &dir.join(".y.tmp")).is_err(), "no new temporary after the cleanup");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_output_on_an_input_is_refused_naming_both() {
        let dir = std::env::temp_dir().join(format!("spectrace-inputs-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let texture = dir.join("tex.png");
        std::fs::write(&texture, b"texels").unwrap();
        let link = dir.join("link.png");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink(&texture, &link).unwrap();
        let inputs = [(link.as_path(), "the scene's file")];
        // The input by another spelling of its folder, and the file its link leads to.
        for output in [dir.join("sub/../link.png"), dir.join("tex.png")] {
            let e = check_outputs_spare_inputs(&[&dir.join("a.exr"), &output], &inputs).unwrap_err().to_string();
            assert_eq!(
                e,
                format!(
                    "{}: would overwrite the scene's file {}; write the output elsewhere",
                    output.display(),
                    link.display()
                )
            );
        }
        assert!(check_outputs_spare_inputs(&[&dir.join("tex.exr")], &inputs).is_ok());
        // An input that does not exist (yet) cannot be overwritten.
        let missing = dir.join("missing.film");
        assert!(check_outputs_spare_inputs(&[&missing], &[(&missing, "the film to resume")]).is_ok());
        // Two outputs on one path are still refused.
        let twice = check_outputs_spare_inputs(&[&missing, &missing], &[]).unwrap_err().to_string();
        assert!(twice.contains("given for two outputs"), "{twice}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
