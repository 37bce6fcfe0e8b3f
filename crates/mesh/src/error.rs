//! [`MeshError`]: why a mesh file was refused, with its place in the file.

use std::fmt;

/// A place in a mesh file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pos {
    /// A text file's line and column (both 1-based; the column counts bytes).
    Line {
        /// 1-based line.
        line: usize,
        /// 1-based byte column.
        col: usize,
    },
    /// A binary file's byte offset (0-based).
    Byte(usize),
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Pos::Line { line, col } => write!(f, "line {line}, column {col}"),
            Pos::Byte(b) => write!(f, "byte {b}"),
        }
    }
}

/// A problem reading a mesh file. Every variant that comes from a place in the file says
/// where ([`MeshError::at`]) and what was there ([`MeshError::text`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// A binary STL whose triangle count (bytes 80–83) disagrees with its size.
    #[error("binary STL says {count} triangles, but its {len} bytes hold {fits} (84 + 50 per triangle{rest})")]
    Count {
        /// Count from the header.
        count: u32,
        /// File size in bytes.
        len: usize,
        /// Whole triangles the bytes after the header hold.
        fits: usize,
        /// `", and N bytes over"` when the size is not a whole number of triangles.
        rest: String,
    },
    /// Text that is not what the format wants there.
    #[error("{at}: {why}")]
    Syntax {
        /// Where.
        at: Pos,
        /// The offending text (a token or line).
        text: String,
        /// What is wrong.
        why: String,
    },
    /// A vertex coordinate that is NaN or infinite (or overflows `f64`).
    #[error("{at}: vertex coordinate `{text}` is not a finite number")]
    NotFinite {
        /// Where.
        at: Pos,
        /// The coordinate as written.
        text: String,
    },
    /// A face naming a vertex that is not there.
    #[error("{at}: face index `{text}` {why}")]
    Index {
        /// Where.
        at: Pos,
        /// The index as written.
        text: String,
        /// What is wrong.
        why: String,
    },
    /// A 3MF package (ZIP) or its model part (XML) that cannot be read.
    #[error("{place}: {why}")]
    Package {
        /// Where: `byte N` of the package, or the part with its line and column.
        place: String,
        /// The offending text (empty where there is none).
        text: String,
        /// What is wrong.
        why: String,
    },
    /// The file holds no triangles.
    #[error("the mesh has no triangles")]
    Empty,
    /// A file this crate cannot read (its format named).
    #[error("{0}")]
    Unsupported(String),
}

impl MeshError {
    /// Where in the file, when the problem has a place.
    pub fn at(&self) -> Option<Pos> {
        match self {
            MeshError::Count { .. } => Some(Pos::Byte(80)),
            MeshError::Syntax { at, .. }
            | MeshError::NotFinite { at, .. }
            | MeshError::Index { at, .. } => Some(*at),
            MeshError::Empty | MeshError::Unsupported(_) | MeshError::Package { .. } => None,
        }
    }

    /// The offending text, when there is one.
    pub fn text(&self) -> Option<&str> {
        match self {
            MeshError::Syntax { text, .. }
            | MeshError::NotFinite { text, .. }
            | MeshError::Index { text, .. }
            | MeshError::Package { text, .. } => Some(text),
            _ => None,
        }
    }

    /// What to do about it.
    pub fn hint(&self) -> &'static str {
        match self {
            MeshError::Count { .. } => {
                "the file is truncated or padded: export the binary STL again"
            }
            MeshError::Syntax { .. } => "check the file's format (STL, OBJ or OFF) at that place",
            MeshError::NotFinite { .. } => {
                "every vertex needs three finite coordinates: repair the mesh in the CAD system"
            }
            MeshError::Index { .. } => {
                "faces name vertices 1..n in OBJ (negative: counted back from the last), 0..n-1 in OFF"
            }
            MeshError::Package { .. } => {
                "export the 3MF again (a ZIP package holding 3D/3dmodel.model), or give STL, OBJ or OFF"
            }
            MeshError::Empty => "the file holds no faces: export the solid, not a sketch",
            MeshError::Unsupported(_) => "give an STL (ASCII or binary), OBJ, OFF or 3MF file",
        }
    }
}
