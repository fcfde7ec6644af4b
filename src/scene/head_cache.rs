//! The head's derived data ([`Head`]: its BVH, distance grids, support
//! map and hull planes) kept on disk between runs. It depends only on the
//! head mesh and [`HeadConfig`], its build is a large part of `plan`'s
//! load time on a small part, and a process engineer plans part after
//! part with the same head.
//!
//! An entry is `head-<hash of the input>.bin` in the cache folder
//! ([`cache_dir`]). It holds the code's identity (`MAAMPLAN_SOURCE_ID`,
//! see `build.rs`), the input it was built from (compared byte for byte,
//! so a hash collision cannot mix heads up), the head's data and a
//! checksum. Anything that does not match, from another build, truncated
//! or corrupt, is rebuilt and rewritten; entries are written to a
//! temporary file and renamed, so concurrent runs never read half an
//! entry. A cache that cannot be read or written is no error: the head is
//! built as without one. Loaded data is the built data bit for bit, so
//! plans are the same with or without the cache.

use super::gpu_types::{GpuHeadParams, GpuNode, GpuTriangle};
use super::head::{decoded_support, Head, HeadConfig};
use super::SceneError;
use crate::geometry::{Mesh, V3};
use bytemuck::Pod;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Entry layout version; bump when the layout below changes.
const FORMAT: u32 = 1;
const MAGIC: &[u8; 8] = b"MAAMHEAD";
/// The code's identity (`build.rs`): entries from other code are rebuilt.
const SOURCE_ID: &str = env!("MAAMPLAN_SOURCE_ID");

/// Where the head's data came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheOutcome {
    /// No cache folder: built.
    Off,
    /// Read from this entry.
    Read(PathBuf),
    /// Built and written to this entry.
    Written(PathBuf),
    /// Built; the entry could not be written (the reason).
    Unwritable(PathBuf, String),
}

impl std::fmt::Display for CacheOutcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CacheOutcome::Off => write!(f, "head data built (no cache folder)"),
            CacheOutcome::Read(p) => write!(f, "head data read from {}", p.display()),
            CacheOutcome::Written(p) => write!(f, "head data built, cached in {}", p.display()),
            CacheOutcome::Unwritable(p, e) => {
                write!(
                    f,
                    "head data built; could not cache it in {}: {e}",
                    p.display()
                )
            }
        }
    }
}

/// The cache folder: `MAAMPLAN_CACHE_DIR` when set (empty: no cache),
/// else `$XDG_CACHE_HOME/maamplan`, else `$HOME/.cache/maamplan`.
pub fn cache_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("MAAMPLAN_CACHE_DIR") {
        return (!d.is_empty()).then(|| PathBuf::from(d));
    }
    let base = std::env::var_os("XDG_CACHE_HOME")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))?;
    Some(base.join("maamplan"))
}

/// [`Head::build`], read from the cache folder `dir` when an entry for
/// this mesh and configuration is there, else built and written there.
pub fn load_or_build(
    mesh: &Mesh,
    cfg: &HeadConfig,
    tol: f32,
    dir: Option<&Path>,
) -> Result<(Head, CacheOutcome), SceneError> {
    let Some(dir) = dir else {
        return Ok((Head::build(mesh, cfg, tol)?, CacheOutcome::Off));
    };
    let input = input_bytes(mesh, cfg);
    let path = dir.join(format!("head-{:016x}.bin", hash64(&input)));
    if let Some(mut head) = std::fs::read(&path).ok().and_then(|b| decode(&b, &input)) {
        head.set_tol(tol);
        return Ok((head, CacheOutcome::Read(path)));
    }
    let head = Head::build(mesh, cfg, tol)?;
    let outcome = match write_atomically(dir, &path, &encode(&head, &input)) {
        Ok(()) => CacheOutcome::Written(path),
        Err(e) => CacheOutcome::Unwritable(path, e.to_string()),
    };
    Ok((head, outcome))
}

/// What the head's data is built from, as bytes.
fn input_bytes(mesh: &Mesh, cfg: &HeadConfig) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&cfg.tip_clearance.to_bits().to_le_bytes());
    out.extend_from_slice(&cfg.grid_resolution.to_le_bytes());
    put(&mut out, &mesh.vertices);
    put(&mut out, &mesh.triangles);
    out
}

fn encode(head: &Head, input: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT.to_le_bytes());
    put(&mut out, SOURCE_ID.as_bytes());
    put(&mut out, input);
    put(&mut out, &head.mesh.vertices);
    put(&mut out, &head.mesh.triangles);
    put(&mut out, std::slice::from_ref(&head.params));
    put(&mut out, &head.nodes);
    put(&mut out, &head.triangles);
    put(&mut out, &head.ray_triangles);
    put(&mut out, &head.grid);
    let sum = hash64(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// The head in `bytes` when they are a whole entry of this format, from
/// this code, built from `input`.
fn decode(bytes: &[u8], input: &[u8]) -> Option<Head> {
    let (body, sum) = bytes.split_at(bytes.len().checked_sub(8)?);
    if hash64(body).to_le_bytes() != sum {
        return None;
    }
    let mut r = Reader(body);
    if r.take(8)? != MAGIC || r.take(4)? != FORMAT.to_le_bytes() {
        return None;
    }
    if r.vec::<u8>()? != SOURCE_ID.as_bytes() || r.vec::<u8>()? != input {
        return None;
    }
    let vertices = r.vec::<V3>()?;
    let triangles = r.vec::<[u32; 3]>()?;
    let params = *r.vec::<GpuHeadParams>()?.first()?;
    let nodes = r.vec::<GpuNode>()?;
    let head_triangles = r.vec::<GpuTriangle>()?;
    let ray_triangles = r.vec::<GpuTriangle>()?;
    let grid = r.vec::<f32>()?;
    if !r.0.is_empty() {
        return None;
    }
    Some(Head {
        mesh: Mesh {
            vertices,
            triangles,
        },
        params,
        nodes,
        triangles: head_triangles,
        ray_triangles,
        support: decoded_support(&grid, &params)?,
        grid,
    })
}

/// Append `items` with their count.
fn put<T: Pod>(out: &mut Vec<u8>, items: &[T]) {
    out.extend_from_slice(&(items.len() as u64).to_le_bytes());
    out.extend_from_slice(bytemuck::cast_slice(items));
}

/// Reads what [`put`] wrote, refusing anything short.
struct Reader<'a>(&'a [u8]);

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        if n > self.0.len() {
            return None;
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Some(head)
    }

    fn vec<T: Pod>(&mut self) -> Option<Vec<T>> {
        let n = u64::from_le_bytes(self.take(8)?.try_into().ok()?);
        let bytes = usize::try_from(n)
            .ok()?
            .checked_mul(std::mem::size_of::<T>())?;
        Some(bytemuck::pod_collect_to_vec(self.take(bytes)?))
    }
}

fn write_atomically(dir: &Path, path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut tmp = tempfile::NamedTempFile::new_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// A 64-bit hash that names entries and checks them (std's: not stable
/// across Rust releases, which costs a rebuild at most; not a defence
/// against tampering, the input itself is compared).
fn hash64(bytes: &[u8]) -> u64 {
    use std::hash::Hasher;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    h.write(bytes);
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::default_job::cone_head;

    fn cfg() -> HeadConfig {
        HeadConfig {
            grid_resolution: 32,
            ..HeadConfig::default()
        }
    }

    fn same(a: &Head, b: &Head) {
        assert_eq!(a.mesh.vertices, b.mesh.vertices);
        assert_eq!(a.mesh.triangles, b.mesh.triangles);
        assert_eq!(a.params, b.params);
        assert_eq!(a.nodes, b.nodes);
        assert_eq!(a.triangles, b.triangles);
        assert_eq!(a.ray_triangles, b.ray_triangles);
        let bits = |g: &[f32]| g.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.grid), bits(&b.grid));
    }

    /// The first call for `mesh` in `dir`, which builds the head and
    /// writes its entry: the head and the entry's path.
    fn first_written(mesh: &Mesh, dir: &Path) -> (Head, PathBuf) {
        let (built, first) = load_or_build(mesh, &cfg(), 1e-5, Some(dir)).unwrap();
        let CacheOutcome::Written(path) = first else {
            panic!("first call: {first:?}");
        };
        (built, path)
    }

    /// The second call reads what the first wrote, and what it reads is
    /// the built head bit for bit, at the caller's tolerance.
    #[test]
    fn reads_back_what_it_built() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = cone_head(5.0, 5.0, 12.0, 24);
        let (built, path) = first_written(&mesh, dir.path());
        let (read, second) = load_or_build(&mesh, &cfg(), 3e-5, Some(dir.path())).unwrap();
        assert_eq!(second, CacheOutcome::Read(path));
        same(&read, &Head::build(&mesh, &cfg(), 3e-5).unwrap());
        same(&built, &Head::build(&mesh, &cfg(), 1e-5).unwrap());
    }

    /// Another mesh or configuration is another entry; a corrupt or
    /// truncated entry is rebuilt and rewritten, never read.
    #[test]
    fn rebuilds_what_does_not_match() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = cone_head(5.0, 5.0, 12.0, 24);
        let (_, path) = first_written(&mesh, dir.path());
        let finer = HeadConfig {
            grid_resolution: 40,
            ..cfg()
        };
        let (_, o) = load_or_build(&mesh, &finer, 1e-5, Some(dir.path())).unwrap();
        assert!(matches!(o, CacheOutcome::Written(p) if p != path));
        let other = cone_head(5.0, 6.0, 12.0, 24);
        let (_, o) = load_or_build(&other, &cfg(), 1e-5, Some(dir.path())).unwrap();
        assert!(matches!(o, CacheOutcome::Written(p) if p != path));

        let good = std::fs::read(&path).unwrap();
        let mut flipped = good.clone();
        flipped[good.len() / 2] ^= 1;
        for bad in [flipped, good[..good.len() - 9].to_vec(), Vec::new()] {
            std::fs::write(&path, &bad).unwrap();
            let (head, o) = load_or_build(&mesh, &cfg(), 1e-5, Some(dir.path())).unwrap();
            assert_eq!(o, CacheOutcome::Written(path.clone()));
            same(&head, &Head::build(&mesh, &cfg(), 1e-5).unwrap());
            assert_eq!(std::fs::read(&path).unwrap(), good);
        }
    }

    /// An entry from other code (another source identity) is not read.
    #[test]
    fn entries_of_other_code_are_rebuilt() {
        let mesh = cone_head(5.0, 5.0, 12.0, 24);
        let input = input_bytes(&mesh, &cfg());
        let head = Head::build(&mesh, &cfg(), 1e-5).unwrap();
        let bytes = encode(&head, &input);
        assert!(decode(&bytes, &input).is_some());
        let id = SOURCE_ID.as_bytes();
        let at = bytes.windows(id.len()).position(|w| w == id).unwrap();
        let mut other = bytes[..bytes.len() - 8].to_vec();
        other[at] ^= 0x01;
        let sum = hash64(&other);
        other.extend_from_slice(&sum.to_le_bytes());
        assert!(decode(&other, &input).is_none());
    }

    /// A folder that cannot be written is no error.
    #[test]
    fn an_unwritable_folder_still_builds() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("not-a-folder");
        std::fs::write(&file, b"x").unwrap();
        let mesh = cone_head(5.0, 5.0, 12.0, 24);
        let (head, o) = load_or_build(&mesh, &cfg(), 1e-5, Some(&file)).unwrap();
        assert!(matches!(o, CacheOutcome::Unwritable(..)), "{o:?}");
        same(&head, &Head::build(&mesh, &cfg(), 1e-5).unwrap());
    }
}
