//! Mesh readers: STL (ASCII and binary), OBJ (`v`/`f`, polygons fan-triangulated, negative
//! indices), OFF, and 3MF (`crate::threemf`). Each returns an exactly welded [`Mesh`] ([`crate::weld::weld_exact`]);
//! every refusal is a [`MeshError`] with its place in the file.

use crate::error::{MeshError, Pos};
use crate::{Mesh, P3};

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// STL, ASCII or binary (told apart by content).
    Stl,
    /// Wavefront OBJ.
    Obj,
    /// Object File Format (Geomview).
    Off,
    /// 3D Manufacturing Format (read in millimetres: the file says its units).
    ThreeMf,
}

impl Format {
    /// The format a file name's extension names (case-insensitive), if any.
    pub fn from_path(path: &str) -> Option<Format> {
        let ext = path.rsplit_once('.')?.1.to_ascii_lowercase();
        match ext.as_str() {
            "stl" => Some(Format::Stl),
            "obj" => Some(Format::Obj),
            "off" => Some(Format::Off),
            "3mf" => Some(Format::ThreeMf),
            _ => None,
        }
    }

    /// The format of a file's bytes: a ZIP (3MF), an `OFF` header, OBJ `v`/`f` lines, else
    /// STL.
    pub fn sniff(bytes: &[u8]) -> Format {
        if bytes.starts_with(b"PK\x03\x04") {
            return Format::ThreeMf;
        }
        let head = text_start(&bytes[..bytes.len().min(4096)]);
        let first = head
            .split(|&b| b == b'\n')
            .map(trim_ascii)
            .find(|l| !l.is_empty() && !l.starts_with(b"#"));
        match first {
            Some(l) if off_header(l).is_some() => Format::Off,
            Some(l) if l.starts_with(b"solid") => Format::Stl,
            Some(l)
                if [
                    &b"v "[..],
                    b"vn ",
                    b"vt ",
                    b"f ",
                    b"o ",
                    b"g ",
                    b"mtllib ",
                    b"usemtl ",
                ]
                .iter()
                .any(|p| l.starts_with(p)) =>
            {
                Format::Obj
            }
            _ => Format::Stl,
        }
    }
}

fn trim_ascii(l: &[u8]) -> &[u8] {
    let s = l
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(l.len());
    let e = l
        .iter()
        .rposition(|b| !b.is_ascii_whitespace())
        .map_or(s, |e| e + 1);
    &l[s..e.max(s)]
}

/// Read a mesh in the given format.
pub fn read(bytes: &[u8], format: Format) -> Result<Mesh, MeshError> {
    match format {
        Format::Stl => read_stl(bytes),
        Format::Obj => read_obj(bytes),
        Format::Off => read_off(bytes),
        // In millimetres: a 3MF says its units.
        Format::ThreeMf => {
            let t = crate::threemf::read_3mf(bytes)?;
            Ok(if t.mm_per_unit == 1.0 {
                t.mesh
            } else {
                t.mesh.scaled(t.mm_per_unit)
            })
        }
    }
}

/// Lines of a text file with their 1-based numbers (`\n`, `\r\n`; a stray `\r` is
/// whitespace).
fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l))
}

/// An OBJ file's lines, a line ending in `\\` joined to the next (the format's line
/// continuation: Rhino writes long faces so), each with the number of its first line.
fn obj_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, std::borrow::Cow<'_, [u8]>)> {
    let mut phys = lines(bytes).peekable();
    std::iter::from_fn(move || {
        let (ln, first) = phys.next()?;
        let continued = |l: &[u8]| l.trim_ascii_end().ends_with(b"\\");
        if !continued(first) {
            return Some((ln, std::borrow::Cow::Borrowed(first)));
        }
        let mut joined = Vec::new();
        let mut line = first;
        loop {
            let body = line.trim_ascii_end();
            if !continued(line) {
                joined.extend_from_slice(line);
                break;
            }
            joined.extend_from_slice(&body[..body.len() - 1]);
            joined.push(b' ');
            match phys.next() {
                Some((_, next)) => line = next,
                None => break,
            }
        }
        Some((ln, std::borrow::Cow::Owned(joined)))
    })
}

/// Whitespace-separated tokens of a line with their 1-based byte columns.
fn tokens(line: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    let mut i = 0;
    std::iter::from_fn(move || {
        while i < line.len() && line[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= line.len() {
            return None;
        }
        let s = i;
        while i < line.len() && !line[i].is_ascii_whitespace() {
            i += 1;
        }
        Some((s + 1, &line[s..i]))
    })
}

fn text(t: &[u8]) -> String {
    let s = String::from_utf8_lossy(t);
    if s.chars().count() > 80 {
        let cut: String = s.chars().take(80).collect();
        format!("{cut}…")
    } else {
        s.into_owned()
    }
}

/// A coordinate: a number that must be finite.
fn coord(
    tok: Option<(usize, &[u8])>,
    line: usize,
    end_col: usize,
    what: &str,
) -> Result<f64, MeshError> {
    let Some((col, t)) = tok else {
        return Err(MeshError::Syntax {
            at: Pos::Line { line, col: end_col },
            text: String::new(),
            why: format!("{what}: a coordinate is missing (three numbers wanted)"),
        });
    };
    let at = Pos::Line { line, col };
    let v: f64 = std::str::from_utf8(t)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| MeshError::Syntax {
            at,
            text: text(t),
            why: format!("{what}: `{}` is not a number", text(t)),
        })?;
    if !v.is_finite() {
        return Err(MeshError::NotFinite { at, text: text(t) });
    }
    Ok(v)
}

/// Read an STL file's bytes, ASCII or binary. A file that starts with `solid` is ASCII
/// unless its size is exactly that of the binary triangle count in bytes 80–83 (binary
/// files whose 80-byte header begins with `solid` exist).
pub fn read_stl(bytes: &[u8]) -> Result<Mesh, MeshError> {
    let binary_size_fits = bytes.len() >= 84 && {
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        count > 0 && (bytes.len() - 84) % 50 == 0 && (bytes.len() - 84) / 50 == count
    };
    // A text editor's byte-order mark, blank lines or spaces may come first.
    let text = text_start(bytes);
    let starts_solid = text.len() >= 5 && text[..5].eq_ignore_ascii_case(b"solid");
    if starts_solid && !binary_size_fits {
        read_ascii_stl(bytes)
    } else {
        read_binary_stl(bytes)
    }
}

/// `bytes` after a UTF-8 byte-order mark and leading white space.
fn text_start(bytes: &[u8]) -> &[u8] {
    bytes
        .strip_prefix(b"\xEF\xBB\xBF")
        .unwrap_or(bytes)
        .trim_ascii_start()
}

fn read_binary_stl(bytes: &[u8]) -> Result<Mesh, MeshError> {
    if bytes.len() < 84 {
        return Err(MeshError::Count {
            count: 0,
            len: bytes.len(),
            fits: 0,
            rest: ", and the header alone is 84 bytes".to_string(),
        });
    }
    let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]);
    let body = bytes.len() - 84;
    let fits = body / 50;
    // A count of 0 over whole triangles is an exporter's that never filled it in.
    let unfilled = count == 0 && fits > 0;
    if (count as usize != fits && !unfilled) || body % 50 != 0 {
        let over = body % 50;
        return Err(MeshError::Count {
            count,
            len: bytes.len(),
            fits,
            rest: if over == 0 {
                String::new()
            } else {
                format!(", and {over} bytes over")
            },
        });
    }
    let mut verts = Vec::with_capacity(fits * 3);
    for i in 0..fits {
        for k in 0..3 {
            let o = 84 + i * 50 + 12 + 12 * k;
            let mut p = [0.0; 3];
            for (j, c) in p.iter_mut().enumerate() {
                let b = o + 4 * j;
                let v = f32::from_le_bytes([bytes[b], bytes[b + 1], bytes[b + 2], bytes[b + 3]]);
                if !v.is_finite() {
                    return Err(MeshError::NotFinite {
                        at: Pos::Byte(b),
                        text: format!("{v} (triangle {i}, corner {k})"),
                    });
                }
                *c = f64::from(v);
            }
            verts.push(P3::new(p[0], p[1], p[2]));
        }
    }
    soup(verts)
}

fn soup(corners: Vec<P3>) -> Result<Mesh, MeshError> {
    if corners.is_empty() {
        return Err(MeshError::Empty);
    }
    let n = corners.len() / 3;
    let triangles = (0..n)
        .map(|i| {
            let b = u32::try_from(3 * i).unwrap_or(u32::MAX);
            [b, b + 1, b + 2]
        })
        .collect();
    Ok(crate::weld::weld_exact(&Mesh {
        vertices: corners,
        triangles,
    }))
}

fn read_ascii_stl(bytes: &[u8]) -> Result<Mesh, MeshError> {
    let mut corners: Vec<P3> = Vec::new();
    let mut in_loop = 0usize;
    let mut loop_start = (0usize, 0usize);
    // Between an `outer loop` and its `endloop`.
    let mut inside = false;
    for (ln, line) in lines(bytes) {
        let mut toks = tokens(line);
        let Some((col, word)) = toks.next() else {
            continue;
        };
        // Keywords in any case, as exporters write them (`VERTEX`, `Facet`).
        let word = word.to_ascii_lowercase();
        match word.as_slice() {
            b"vertex" => {
                let x = coord(toks.next(), ln, line.len() + 1, "vertex")?;
                let y = coord(toks.next(), ln, line.len() + 1, "vertex")?;
                let z = coord(toks.next(), ln, line.len() + 1, "vertex")?;
                if let Some((c, t)) = toks.next() {
                    return Err(MeshError::Syntax {
                        at: Pos::Line { line: ln, col: c },
                        text: text(t),
                        why: "`vertex x y z` takes three numbers".into(),
                    });
                }
                corners.push(P3::new(x, y, z));
                in_loop += 1;
            }
            b"outer" => {
                in_loop = 0;
                inside = true;
                loop_start = (ln, col);
            }
            b"endloop" => {
                if in_loop != 3 {
                    return Err(MeshError::Syntax {
                        at: Pos::Line { line: ln, col },
                        text: text(line),
                        why: format!(
                            "the facet's loop (from line {}) has {in_loop} vertices, not 3",
                            loop_start.0
                        ),
                    });
                }
                in_loop = 0;
                inside = false;
            }
            // Inside a facet's loop only vertices stand: another line there would drop
            // the facet without a word.
            _ if inside => {
                return Err(MeshError::Syntax {
                    at: Pos::Line { line: ln, col },
                    text: text(line),
                    why: format!(
                        "a facet's loop (from line {}) holds only `vertex x y z` lines",
                        loop_start.0
                    ),
                });
            }
            _ => {}
        }
    }
    if corners.len() % 3 != 0 {
        let last = lines(bytes).count();
        return Err(MeshError::Syntax {
            at: Pos::Line { line: last, col: 1 },
            text: String::new(),
            why: "the file ends inside a facet (a vertex count that is not a multiple of 3)".into(),
        });
    }
    soup(corners)
}

/// One face index as written, resolved later against the vertex count.
struct FaceRef {
    at: Pos,
    raw: i64,
    text: String,
}

/// Read a Wavefront OBJ: `v x y z [w]` and `f i j k …` (`i`, `i/t`, `i//n`, `i/t/n`;
/// 1-based, negative counted back from the last vertex read so far); polygons are
/// fan-triangulated from their first corner. Other statements are ignored.
pub fn read_obj(bytes: &[u8]) -> Result<Mesh, MeshError> {
    let mut vertices: Vec<P3> = Vec::new();
    let mut faces: Vec<[FaceRef; 3]> = Vec::new();
    for (ln, line) in obj_lines(bytes) {
        let line: &[u8] = &line;
        let body = match line.iter().position(|&b| b == b'#') {
            Some(h) => &line[..h],
            None => line,
        };
        let mut toks = tokens(body);
        let Some((col, word)) = toks.next() else {
            continue;
        };
        match word {
            b"v" => {
                let x = coord(toks.next(), ln, body.len() + 1, "v")?;
                let y = coord(toks.next(), ln, body.len() + 1, "v")?;
                let z = coord(toks.next(), ln, body.len() + 1, "v")?;
                vertices.push(P3::new(x, y, z));
            }
            b"f" => {
                let mut refs = Vec::new();
                for (c, t) in toks {
                    let at = Pos::Line { line: ln, col: c };
                    let first = t.split(|&b| b == b'/').next().unwrap_or(t);
                    let raw: i64 = std::str::from_utf8(first)
                        .ok()
                        .and_then(|s| s.parse().ok())
                        .ok_or_else(|| MeshError::Syntax {
                            at,
                            text: text(t),
                            why: format!("`{}` is not a vertex index", text(t)),
                        })?;
                    let resolved = if raw < 0 {
                        // Relative: -1 is the last vertex read so far.
                        let r = vertices.len() as i64 + raw + 1;
                        if r < 1 {
                            return Err(MeshError::Index {
                                at,
                                text: text(t),
                                why: format!(
                                    "counts back before the first vertex ({} read so far)",
                                    vertices.len()
                                ),
                            });
                        }
                        r
                    } else if raw == 0 {
                        return Err(MeshError::Index {
                            at,
                            text: text(t),
                            why: "is 0 (OBJ counts vertices from 1)".into(),
                        });
                    } else {
                        raw
                    };
                    refs.push(FaceRef {
                        at,
                        raw: resolved,
                        text: text(t),
                    });
                }
                if refs.len() < 3 {
                    return Err(MeshError::Syntax {
                        at: Pos::Line { line: ln, col },
                        text: text(line),
                        why: format!(
                            "a face needs 3 or more vertices, this one has {}",
                            refs.len()
                        ),
                    });
                }
                let mut it = refs.into_iter();
                let (Some(a), Some(mut b)) = (it.next(), it.next()) else {
                    continue;
                };
                for c in it {
                    let a2 = FaceRef {
                        at: a.at,
                        raw: a.raw,
                        text: a.text.clone(),
                    };
                    let next_b = FaceRef {
                        at: c.at,
                        raw: c.raw,
                        text: c.text.clone(),
                    };
                    faces.push([a2, b, c]);
                    b = next_b;
                }
            }
            _ => {}
        }
    }
    indexed(vertices, faces, 1)
}

/// Faces resolved against the vertices (`base`: the number of the first vertex).
fn indexed(vertices: Vec<P3>, faces: Vec<[FaceRef; 3]>, base: i64) -> Result<Mesh, MeshError> {
    if faces.is_empty() {
        return Err(MeshError::Empty);
    }
    let n = vertices.len() as i64;
    let mut triangles = Vec::with_capacity(faces.len());
    for f in faces {
        let mut t = [0u32; 3];
        for (k, r) in f.iter().enumerate() {
            let i = r.raw - base;
            if i < 0 || i >= n {
                return Err(MeshError::Index {
                    at: r.at,
                    text: r.text.clone(),
                    why: format!(
                        "names a vertex that is not there (the file has {n} vertices, numbered from {base})"
                    ),
                });
            }
            t[k] = u32::try_from(i).map_err(|_| MeshError::Index {
                at: r.at,
                text: r.text.clone(),
                why: "is beyond 2^32 vertices".into(),
            })?;
        }
        triangles.push(t);
    }
    Ok(crate::weld::weld_exact(&Mesh {
        vertices,
        triangles,
    }))
}

/// `OFF`, `COFF`, `NOFF`, `CNOFF`, `STOFF`… header keyword (not `4OFF`/`nOFF`), and the
/// rest of the line. The vertex count may follow the keyword with no blank between
/// (`OFF8 6 12`, as ModelNet's files have it, and as readers that take the keyword's
/// three bytes and then numbers read it).
fn off_header(line: &[u8]) -> Option<&[u8]> {
    let (_, word) = tokens(line).next()?;
    let end = word.windows(3).position(|w| w == b"OFF")? + 3;
    let ok = word[..end - 3]
        .iter()
        .all(|b| matches!(b, b'C' | b'N' | b'S' | b'T'))
        && word[end..].iter().all(u8::is_ascii_digit);
    if !ok {
        return None;
    }
    let p = line.windows(3).position(|w| w == b"OFF")?;
    Some(&line[p + 3..])
}

/// A line's number and its tokens with their columns.
type Row<'a> = (usize, Vec<(usize, &'a [u8])>);

/// Read an OFF file: the `OFF` keyword, `nv nf ne`, `nv` vertices (`x y z`, colour and
/// other values after them ignored), `nf` faces (`n i1 … in`, 0-based, colour after
/// them ignored), fan-triangulated. `#` starts a comment.
pub fn read_off(bytes: &[u8]) -> Result<Mesh, MeshError> {
    // Tokens of the whole file with their places, comments removed, the header keyword
    // consumed.
    let mut rows: Vec<Row> = Vec::new();
    let mut seen_header = false;
    for (ln, line) in lines(bytes) {
        let body = match line.iter().position(|&b| b == b'#') {
            Some(h) => &line[..h],
            None => line,
        };
        if !seen_header {
            if tokens(body).next().is_none() {
                continue;
            }
            let Some(rest) = off_header(body) else {
                let (col, t) = tokens(body).next().unwrap_or((1, body));
                return Err(MeshError::Syntax {
                    at: Pos::Line { line: ln, col },
                    text: text(t),
                    why: "an OFF file starts with `OFF` (4OFF and nOFF are not read)".into(),
                });
            };
            seen_header = true;
            let off = body.len() - rest.len();
            let toks: Vec<_> = tokens(rest).map(|(c, t)| (c + off, t)).collect();
            if !toks.is_empty() {
                rows.push((ln, toks));
            }
            continue;
        }
        let toks: Vec<_> = tokens(body).collect();
        if !toks.is_empty() {
            rows.push((ln, toks));
        }
    }
    let last_line = lines(bytes).count();
    let mut rows = rows.into_iter();
    let count = |row: Option<&Row>, k: usize, what: &str| -> Result<usize, MeshError> {
        let Some((ln, toks)) = row else {
            return Err(MeshError::Syntax {
                at: Pos::Line {
                    line: last_line,
                    col: 1,
                },
                text: String::new(),
                why: format!("the file ends before the {what}"),
            });
        };
        let Some(&(col, t)) = toks.get(k) else {
            return Err(MeshError::Syntax {
                at: Pos::Line { line: *ln, col: 1 },
                text: String::new(),
                why: format!("the {what} is missing"),
            });
        };
        std::str::from_utf8(t)
            .ok()
            .and_then(|s| s.parse::<usize>().ok())
            .ok_or_else(|| MeshError::Syntax {
                at: Pos::Line { line: *ln, col },
                text: text(t),
                why: format!("the {what} `{}` is not a count", text(t)),
            })
    };
    let head = rows.next();
    let nv = count(head.as_ref(), 0, "vertex count")?;
    let nf = count(head.as_ref(), 1, "face count")?;
    // The file bounds what can be reserved: each vertex or face takes 2 bytes at least.
    let room = bytes.len() / 2 + 1;
    let mut vertices = Vec::with_capacity(nv.min(room));
    for _ in 0..nv {
        let Some((ln, toks)) = rows.next() else {
            return Err(MeshError::Syntax {
                at: Pos::Line {
                    line: last_line,
                    col: 1,
                },
                text: String::new(),
                why: format!(
                    "the header says {nv} vertices, the file ends after {}",
                    vertices.len()
                ),
            });
        };
        let end = toks.last().map_or(1, |(c, t)| c + t.len());
        let mut it = toks.iter().copied();
        let x = coord(it.next(), ln, end, "OFF vertex")?;
        let y = coord(it.next(), ln, end, "OFF vertex")?;
        let z = coord(it.next(), ln, end, "OFF vertex")?;
        vertices.push(P3::new(x, y, z));
    }
    let mut faces: Vec<[FaceRef; 3]> = Vec::with_capacity(nf.min(room));
    for done in 0..nf {
        let Some((ln, toks)) = rows.next() else {
            return Err(MeshError::Syntax {
                at: Pos::Line {
                    line: last_line,
                    col: 1,
                },
                text: String::new(),
                why: format!("the header says {nf} faces, the file ends after {done}"),
            });
        };
        let (c0, t0) = toks[0];
        let n: usize = std::str::from_utf8(t0)
            .ok()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| MeshError::Syntax {
                at: Pos::Line { line: ln, col: c0 },
                text: text(t0),
                why: format!("`{}` is not a face's vertex count", text(t0)),
            })?;
        if n < 3 || toks.len() - 1 < n {
            return Err(MeshError::Syntax {
                at: Pos::Line { line: ln, col: c0 },
                text: text(t0),
                why: format!(
                    "a face needs 3 or more vertices and that many indices (says {n}, gives {})",
                    toks.len() - 1
                ),
            });
        }
        let mut refs = Vec::with_capacity(n);
        for &(c, t) in &toks[1..=n] {
            let at = Pos::Line { line: ln, col: c };
            let raw: i64 = std::str::from_utf8(t)
                .ok()
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| MeshError::Syntax {
                    at,
                    text: text(t),
                    why: format!("`{}` is not a vertex index", text(t)),
                })?;
            refs.push((at, raw, text(t)));
        }
        let (a_at, a_raw, a_text) = refs[0].clone();
        for w in refs[1..].windows(2) {
            let mk = |r: &(Pos, i64, String)| FaceRef {
                at: r.0,
                raw: r.1,
                text: r.2.clone(),
            };
            faces.push([
                FaceRef {
                    at: a_at,
                    raw: a_raw,
                    text: a_text.clone(),
                },
                mk(&w[0]),
                mk(&w[1]),
            ]);
        }
    }
    indexed(vertices, faces, 0)
}
