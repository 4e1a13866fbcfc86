//! Writing files so that an existing output is never left half-written: the
//! bytes go to a temporary file beside the target, which is then renamed over
//! it; and a set of files is written all or none, optionally replacing what
//! an earlier run left in a folder.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` atomically (temporary file in the same directory, then rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = temporary_path(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// A file of a [`FileSet`] that could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{}: could not write: {error}", path.display())]
pub struct FileSetError {
    /// The file.
    pub path: PathBuf,
    /// Why (in the message, not a separate cause, so it is said once).
    pub error: std::io::Error,
}

/// Files written together: each goes to a temporary file first, and only
/// when every temporary is written are they renamed over their targets, so a
/// failure (a full disk, a missing folder) leaves every old file as it was
/// and no temporary behind.
#[derive(Debug, Default)]
pub struct FileSet {
    files: Vec<(PathBuf, Vec<u8>)>,
}

impl FileSet {
    /// An empty set.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `bytes` to be written to `path`.
    pub fn add(&mut self, path: impl Into<PathBuf>, bytes: Vec<u8>) {
        self.files.push((path.into(), bytes));
    }

    /// Writes every file, or (as far as the file system allows) none.
    pub fn commit(self) -> Result<(), FileSetError> {
        let mut written: Vec<(PathBuf, &Path)> = vec![];
        for (path, bytes) in &self.files {
            let tmp = temporary_path(path);
            if let Err(source) = write_synced(&tmp, bytes) {
                let _ = std::fs::remove_file(&tmp);
                remove_all(&written);
                return Err(FileSetError { path: path.clone(), error: source });
            }
            written.push((tmp, path));
        }
        // Renames within a folder do not run out of space; one that fails
        // still leaves the rest of the old files, and no temporaries.
        for (k, (tmp, path)) in written.iter().enumerate() {
            if let Err(source) = std::fs::rename(tmp, path) {
                remove_all(&written[k..]);
                return Err(FileSetError { path: path.to_path_buf(), error: source });
            }
        }
        Ok(())
    }
}

impl FileSet {
    /// [`Self::commit`], then removes the files directly in `dir` that
    /// `earlier_output` claims (by name) and this set did not write, so a
    /// folder of reports describes this run alone. Files it does not claim
    /// are left, so a folder shared with other files loses none of them.
    pub fn commit_replacing(self, dir: &Path, earlier_output: impl Fn(&str) -> bool) -> Result<(), FileSetError> {
        let written: Vec<PathBuf> = self.files.iter().map(|(path, _)| path.clone()).collect();
        self.commit()?;
        let Ok(entries) = std::fs::read_dir(dir) else { return Ok(()) };
        for path in entries.filter_map(|e| e.ok()).map(|e| e.path()) {
            let claimed = path.file_name().and_then(|n| n.to_str()).is_some_and(&earlier_output);
            if claimed && path.is_file() && !written.contains(&path) {
                std::fs::remove_file(&path).map_err(|error| FileSetError { path: path.clone(), error })?;
            }
        }
        Ok(())
    }
}

fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = std::fs::File::create(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

fn remove_all(temporaries: &[(PathBuf, &Path)]) {
    for (tmp, _) in temporaries {
        let _ = std::fs::remove_file(tmp);
    }
}

/// `dir/.name.PID.tmp` beside `path`: same file system, so the rename is atomic.
fn temporary_path(path: &Path) -> PathBuf {
    let name = path.file_name().map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_is_written_whole_or_not_at_all() {
        let dir = std::env::temp_dir().join(format!("blobtrace-fileset-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (dir.join("a.txt"), dir.join("b.txt"));
        write_atomic(&a, b"old a").unwrap();
        write_atomic(&b, b"old b").unwrap();
        // The second file's folder is missing: its temporary cannot be made.
        let mut set = FileSet::new();
        set.add(&a, b"new a".to_vec());
        set.add(&b, b"new b".to_vec());
        set.add(dir.join("missing").join("c.txt"), b"c".to_vec());
        let err = set.commit().unwrap_err();
        assert!(err.to_string().contains("c.txt"), "{err}");
        assert_eq!(std::fs::read(&a).unwrap(), b"old a");
        assert_eq!(std::fs::read(&b).unwrap(), b"old b");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2, "no temporaries are left");
        let mut set = FileSet::new();
        set.add(&a, b"new a".to_vec());
        set.add(&b, b"new b".to_vec());
        set.commit().unwrap();
        assert_eq!((std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap()), (b"new a".to_vec(), b"new b".to_vec()));
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn replacing_a_folder_removes_what_an_earlier_run_left_and_nothing_else() {
        let dir = std::env::temp_dir().join(format!("blobtrace-replacing-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for name in ["old-a.png", "old-b.png", "notes.txt"] {
            write_atomic(&dir.join(name), b"earlier").unwrap();
        }
        let mut set = FileSet::new();
        set.add(dir.join("old-a.png"), b"now".to_vec());
        set.add(dir.join("new.png"), b"now".to_vec());
        set.commit_replacing(&dir, |name| name.ends_with(".png")).unwrap();
        let mut left: Vec<String> =
            std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        left.sort();
        assert_eq!(left, ["new.png", "notes.txt", "old-a.png"]);
        assert_eq!(std::fs::read(dir.join("old-a.png")).unwrap(), b"now");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn replaces_content_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("blobtrace-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        // A target in a missing directory fails without creating anything.
        assert!(write_atomic(&dir.join("missing/b.txt"), b"x").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
