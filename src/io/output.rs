//! Atomic output: write to a temporary file beside the target and rename it
//! into place, so a failed run never leaves a half-written file.

use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file of an output folder: its path relative to the folder, and its
/// bytes.
pub type FolderFile = (PathBuf, Vec<u8>);

/// Write `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut tmp = tempfile::NamedTempFile::new_in(dir)?;
    tmp.write_all(bytes)?;
    // Temporary files are private (0600); outputs are ordinary files.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// Write a folder of files (paths relative to `dir`) as one step: everything
/// goes into a temporary folder beside `dir` first, so a failure leaves no
/// partial output. If `dir` exists, each top-level entry written replaces
/// the one of the same name (a stale `waypoint/` folder goes as a whole);
/// other entries are left alone.
pub fn write_folder_atomic(dir: &Path, files: &[FolderFile]) -> std::io::Result<()> {
    write_output_set(dir, files, &[])
}

/// [`write_folder_atomic`] for a command whose outputs are the top-level
/// entries `set` of `dir` (a file, or a folder such as `plots`): those of
/// them this run does not write (an earlier run's report beside a run
/// without one) are removed once the new ones are in place, so the folder
/// never holds two runs' outputs side by side. Other entries are left
/// alone.
pub fn write_output_set(dir: &Path, files: &[FolderFile], set: &[&str]) -> std::io::Result<()> {
    let parent = dir
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let tmp = tempfile::Builder::new()
        .prefix(".maamplan-")
        .tempdir_in(parent)?;
    write_files(tmp.path(), files)?;
    if !dir.exists() {
        let kept = tmp.keep();
        std::fs::rename(&kept, dir)?;
        return Ok(());
    }
    let mut tops: Vec<PathBuf> = files
        .iter()
        .filter_map(|(rel, _)| rel.components().next())
        .map(|c| PathBuf::from(c.as_os_str()))
        .collect();
    tops.sort();
    tops.dedup();
    for top in tops {
        let target = dir.join(&top);
        if target.is_dir() {
            std::fs::remove_dir_all(&target)?;
        } else if target.exists() {
            std::fs::remove_file(&target)?;
        }
        std::fs::rename(tmp.path().join(&top), &target)?;
    }
    for name in set {
        let target = dir.join(name);
        if files.iter().any(|(rel, _)| rel.starts_with(name)) {
            continue;
        }
        if target.is_dir() {
            std::fs::remove_dir_all(&target)?;
        } else if target.symlink_metadata().is_ok() {
            std::fs::remove_file(&target)?;
        }
    }
    Ok(())
}

/// Write `files` into the folder `root`: their folders first, then the
/// files on every core, largest first, each on its own (a plan's scenes and
/// program are tens of megabytes: copying them into the page cache is a
/// core's work, 0.43 s for 125 MB on one core of the CI-class machine, 0.22
/// on two). The error reported is that of the first file in `files`' order.
fn write_files(root: &Path, files: &[FolderFile]) -> std::io::Result<()> {
    let mut dirs: Vec<PathBuf> = files
        .iter()
        .filter_map(|(rel, _)| root.join(rel).parent().map(Path::to_path_buf))
        .collect();
    dirs.sort();
    dirs.dedup();
    for d in dirs {
        std::fs::create_dir_all(d)?;
    }
    let mut order: Vec<usize> = (0..files.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(files[i].1.len()));
    let mut written: Vec<(usize, std::io::Result<()>)> = order
        .into_par_iter()
        .with_max_len(1)
        .map(|i| (i, std::fs::write(root.join(&files[i].0), &files[i].1)))
        .collect();
    written.sort_by_key(|(i, _)| *i);
    written.into_iter().try_for_each(|(_, r)| r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_replaces_the_outputs_of_the_last_as_a_set() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("out");
        let set = ["a.txt", "plots", "b.txt"];
        let first: Vec<FolderFile> = vec![
            ("a.txt".into(), b"1".to_vec()),
            ("b.txt".into(), b"1".to_vec()),
            ("plots/p.svg".into(), b"1".to_vec()),
        ];
        write_output_set(&dir, &first, &set).unwrap();
        std::fs::write(dir.join("notes.md"), "mine").unwrap();
        write_output_set(&dir, &[("a.txt".into(), b"2".to_vec())], &set).unwrap();
        assert_eq!(std::fs::read(dir.join("a.txt")).unwrap(), b"2");
        assert!(!dir.join("b.txt").exists() && !dir.join("plots").exists());
        assert_eq!(std::fs::read(dir.join("notes.md")).unwrap(), b"mine");
        let left: Vec<_> = std::fs::read_dir(root.path()).unwrap().collect();
        assert_eq!(left.len(), 1, "no scratch folder is left beside the output");
    }
}
