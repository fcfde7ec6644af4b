//! Gives the library an identity for the code that builds derived data
//! (`MAAMPLAN_SOURCE_ID`): a hash of every file under `src/` and
//! `shaders/` and of `Cargo.lock`. The head cache (`scene::head_cache`)
//! stores it with each entry and rebuilds entries written by other code,
//! so a changed algorithm never reads a stale grid.

use std::fs;
use std::hash::Hasher;
use std::path::{Path, PathBuf};

fn main() {
    let mut files = Vec::new();
    for dir in ["src", "shaders"] {
        collect(Path::new(dir), &mut files);
        println!("cargo:rerun-if-changed={dir}");
    }
    files.push(PathBuf::from("Cargo.lock"));
    println!("cargo:rerun-if-changed=Cargo.lock");
    files.sort();
    // Each path and its contents (std's hasher: a new toolchain may give
    // another identity, which costs one rebuild of each entry).
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for f in &files {
        h.write(f.to_string_lossy().as_bytes());
        h.write(&fs::read(f).unwrap_or_default());
    }
    println!("cargo:rustc-env=MAAMPLAN_SOURCE_ID={:016x}", h.finish());
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect(&p, out);
        } else {
            out.push(p);
        }
    }
}
