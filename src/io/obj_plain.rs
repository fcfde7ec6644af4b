//! Plain OBJ: the subset the layer surfaces of a toolpath use — `v x y z`
//! and `f i j k` with positive indices, comments and ignored statements —
//! read in one pass over the bytes, with exactly the mesh `tobj` makes of
//! the same text (`triangulate`, multi-index): vertices in the order faces
//! first use them, unused ones dropped, coordinates parsed by the same
//! `f32` parser. Anything else in the file (texture coordinates, normals,
//! objects, groups, materials, polygons, `a/b/c` or relative indices, a
//! fourth coordinate, non-ASCII text) makes it answer `None`, and the
//! caller reads the file with `tobj`.
//!
//! Why: `tobj` reads a line into a `String` and looks every face corner
//! up in a SipHash map, which dominates loading a toolpath of many layer
//! surfaces (millions of lines). Here the bytes are read directly, and
//! short decimals are converted without the general parser
//! ([`super::number::parse_f32`]).

use super::number::parse_f32;
use crate::geometry::Mesh;

/// Statements `tobj` acts on besides `v` and `f`: a file with any of them
/// is left to it. Every other statement is ignored by both.
const LEFT_TO_TOBJ: [&str; 7] = ["vt", "vn", "l", "o", "g", "mtllib", "usemtl"];

/// `true` for the ASCII characters Rust's `char::is_whitespace` (which
/// `tobj`'s `split_whitespace` uses) counts as white space.
fn is_space(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\n' | b'\x0b' | b'\x0c' | b'\r')
}

/// The mesh `tobj` reads from `text`, if `text` is plain OBJ (module
/// comment); `None` otherwise. Read as bytes (the text is ASCII), with
/// numbers in the common short form converted directly ([`parse_f32`]).
pub fn parse(text: &str) -> Option<Mesh> {
    if !text.is_ascii() {
        return None;
    }
    let mut positions: Vec<[f32; 3]> = Vec::with_capacity(text.len() / 64);
    let mut corners: Vec<u32> = Vec::with_capacity(text.len() / 16);
    for line in text.as_bytes().split(|&b| b == b'\n') {
        let mut words = line.split(|&b| is_space(b)).filter(|w| !w.is_empty());
        let Some(first) = words.next() else { continue };
        match first {
            b"v" => {
                let mut p = [0.0f32; 3];
                for x in &mut p {
                    *x = parse_f32(words.next()?)?;
                }
                if words.next().is_some() {
                    return None;
                }
                positions.push(p);
            }
            b"f" => {
                for _ in 0..3 {
                    let i = parse_u32(words.next()?)?;
                    corners.push(i.checked_sub(1)?);
                }
                if words.next().is_some() {
                    return None;
                }
            }
            s if LEFT_TO_TOBJ.iter().any(|t| t.as_bytes() == s) => return None,
            _ => {}
        }
    }
    first_use_order(&positions, &corners)
}

/// The `u32` that `str::parse` makes of `word`, `None` where it fails.
fn parse_u32(word: &[u8]) -> Option<u32> {
    let digits = word.strip_prefix(b"+").unwrap_or(word);
    if digits.is_empty() {
        return None;
    }
    digits.iter().try_fold(0u32, |v, &b| {
        if !b.is_ascii_digit() {
            return None;
        }
        v.checked_mul(10)?.checked_add((b - b'0') as u32)
    })
}

/// The mesh of faces `corners` (zero-based, three per face) over
/// `positions`, its vertices renumbered in the order the faces first use
/// them (unused ones dropped), as `tobj` does; `None` when a corner is
/// out of range.
fn first_use_order(positions: &[[f32; 3]], corners: &[u32]) -> Option<Mesh> {
    const UNSEEN: u32 = u32::MAX;
    let mut new_index = vec![UNSEEN; positions.len()];
    let mut mesh = Mesh::default();
    let mut renumbered = Vec::with_capacity(corners.len());
    for &c in corners {
        let slot = new_index.get_mut(c as usize)?;
        if *slot == UNSEEN {
            *slot = mesh.vertices.len() as u32;
            mesh.vertices.push(positions[c as usize]);
        }
        renumbered.push(*slot);
    }
    mesh.triangles = renumbered
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    Some(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::number::tests::number;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn by_tobj(text: &str) -> Mesh {
        crate::io::mesh::read_with_tobj(text).expect("tobj reads it")
    }

    fn same(a: &Mesh, b: &Mesh) -> bool {
        let bits =
            |m: &Mesh| -> Vec<u32> { m.vertices.iter().flatten().map(|x| x.to_bits()).collect() };
        bits(a) == bits(b) && a.triangles == b.triangles
    }

    /// A random plain OBJ: unused vertices, faces before the vertices they
    /// use, comments, ignored statements, tabs, CRLF, blank lines.
    fn plain_obj(rng: &mut ChaCha8Rng) -> String {
        let nv = rng.random_range(3..60);
        let nf = rng.random_range(1..80);
        let mut lines = Vec::new();
        for _ in 0..nv {
            let [x, y, z] = [number(rng), number(rng), number(rng)];
            lines.push(format!("v {x} {y} {z}"));
        }
        for _ in 0..nf {
            let f = [0; 3].map(|_| rng.random_range(1..=nv));
            lines.push(format!("f {} {} {}", f[0], f[1], f[2]));
        }
        // Shuffle a little: tobj resolves absolute indices at the end.
        for _ in 0..nf / 4 {
            let (i, j) = (
                rng.random_range(0..lines.len()),
                rng.random_range(0..lines.len()),
            );
            lines.swap(i, j);
        }
        let extras = [
            "# a comment",
            "#tight comment",
            "s off",
            "",
            "   ",
            "vp 0.5",
        ];
        for _ in 0..rng.random_range(0..6) {
            let at = rng.random_range(0..=lines.len());
            lines.insert(at, extras[rng.random_range(0..extras.len())].to_string());
        }
        let mut text = String::new();
        for l in lines {
            let l = if rng.random_bool(0.2) {
                l.replace(' ', "\t  ")
            } else {
                l
            };
            text.push_str(&l);
            text.push_str(if rng.random_bool(0.3) { "\r\n" } else { "\n" });
        }
        text
    }

    #[test]
    fn face_indices_convert_as_the_standard_parser_converts_them() {
        for w in [
            "0",
            "1",
            "+7",
            "-1",
            "4294967295",
            "4294967296",
            "",
            "+",
            "1a",
            "０",
        ] {
            assert_eq!(parse_u32(w.as_bytes()), w.parse().ok(), "{w:?}");
        }
    }

    #[test]
    fn plain_files_read_to_the_mesh_tobj_makes() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for case in 0..2000 {
            let text = plain_obj(&mut rng);
            let fast = parse(&text).unwrap_or_else(|| panic!("case {case} not plain:\n{text}"));
            assert!(same(&fast, &by_tobj(&text)), "case {case}:\n{text}");
        }
    }

    #[test]
    fn what_tobj_reads_differently_is_left_to_it() {
        let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n";
        for extra in [
            "f 1 2 3 4\n",        // a quad: tobj triangulates it
            "f 1/1 2/2 3/3\n",    // texture indices
            "f 1//1 2//1 3//1\n", // normal indices
            "f -1 -2 -3\n",       // relative indices
            "f 1 2\n",            // a short face: an error to name
            "f 0 1 2\n",          // index 0: an error to name
            "f 1 2 9\n",          // out of range: an error to name
            "vn 0 0 1\nf 1 2 3\n",
            "vt 0 0\nf 1 2 3\n",
            "o part\nf 1 2 3\n",
            "g part\nf 1 2 3\n",
            "usemtl steel\nf 1 2 3\n",
            "mtllib part.mtl\nf 1 2 3\n",
            "l 1 2\nf 1 2 3\n",
            "v 1 2 3 0.5\nf 1 2 3\n",   // w scales the vertex
            "v 1 2 3 1 0 0\nf 1 2 3\n", // a vertex colour
            "v 1 2\nf 1 2 3\n",
            "v 1 2 x\nf 1 2 3\n",
            "# café\nf 1 2 3\n",
        ] {
            assert!(parse(&format!("{base}{extra}")).is_none(), "{extra:?}");
        }
        // The same files with a triangle are plain.
        assert!(parse(&format!("{base}f 1 2 3\n")).is_some());
    }
}
