//! 3MF (3D Manufacturing Format) reader: a ZIP package whose model part (`3D/3dmodel.model`,
//! or the part `_rels/.rels` names) is XML holding objects (a mesh, or components that
//! place other objects) and a build (items that place objects). Read without a ZIP crate:
//! the central directory names the parts, each stored or DEFLATE-compressed (RFC 1951,
//! inflated here, its CRC-32 checked); the XML by `roxmltree`, so that every refusal in
//! the model says its part, line and column.
//!
//! Units come from the model's `unit` attribute (millimeter when absent, as the
//! specification says). Every build item is placed with its transform (and components
//! with theirs, composed); a transform that mirrors (negative determinant) reverses the
//! triangles so that they stay outward. ZIP64, encrypted parts and methods other than
//! stored and DEFLATE are refused, as is a part that inflates beyond [`MAX_PART`] bytes.

use crate::error::MeshError;
use crate::{Mesh, P3};

/// The largest part inflated (bytes).
pub const MAX_PART: usize = 1 << 30;

/// Most bytes a DEFLATE part may inflate to per compressed byte once it passes
/// [`RATIO_FREE`]: a 3MF model's XML compresses some 3 to 20 times; a part that says it
/// inflates 200 times is a ZIP bomb (a megabyte of compressed blanks is a gigabyte of
/// XML to parse).
pub const MAX_RATIO: usize = 200;

/// Parts up to this size (16 MiB) are inflated whatever their ratio.
const RATIO_FREE: usize = 16 << 20;

/// Deepest nesting of components.
const MAX_DEPTH: usize = 32;

/// Most objects placed, vertices transformed and triangles read over the whole build
/// (components can place an object many times over: a few bytes of XML nesting two
/// components per level would otherwise place one 2^32 times). Ten million: a mesh of
/// three million triangles, at most about 4 million triangles (300 MB) placed.
pub const MAX_WORK: usize = 10_000_000;

/// A refusal at a byte of the package.
fn at_byte(b: usize, text: impl Into<String>, why: impl Into<String>) -> MeshError {
    MeshError::Package {
        place: format!("byte {b}"),
        text: text.into(),
        why: why.into(),
    }
}

fn u16le(b: &[u8], at: usize) -> Option<usize> {
    let s = b.get(at..at + 2)?;
    Some(usize::from(u16::from_le_bytes([s[0], s[1]])))
}

fn u32le(b: &[u8], at: usize) -> Option<usize> {
    let s = b.get(at..at + 4)?;
    usize::try_from(u32::from_le_bytes([s[0], s[1], s[2], s[3]])).ok()
}

/// One part of the package, as the central directory lists it.
struct Entry {
    name: String,
    method: usize,
    flags: usize,
    crc: usize,
    compressed: usize,
    size: usize,
    local: usize,
}

/// The central directory's entries.
fn entries(b: &[u8]) -> Result<Vec<Entry>, MeshError> {
    // The end-of-central-directory record: 22 bytes and a comment of up to 65,535.
    let lo = b.len().saturating_sub(22 + 65_535);
    let end = (lo..b.len().saturating_sub(21))
        .rev()
        .find(|&i| b.get(i..i + 4) == Some(&b"PK\x05\x06"[..]))
        .ok_or_else(|| {
            at_byte(
                b.len(),
                "",
                "no ZIP end-of-central-directory record: the file is not a complete 3MF package",
            )
        })?;
    let count = u16le(b, end + 10).unwrap_or(0);
    let size = u32le(b, end + 12).unwrap_or(0);
    let start = u32le(b, end + 16).unwrap_or(usize::MAX);
    if count == 0xFFFF || size == 0xFFFF_FFFF || start == 0xFFFF_FFFF {
        return Err(at_byte(
            end,
            "",
            "a ZIP64 package (not read): save the 3MF again",
        ));
    }
    if start.checked_add(size).is_none_or(|e| e > end) {
        return Err(at_byte(
            end + 16,
            start.to_string(),
            "the central directory lies outside the file",
        ));
    }
    let mut out = Vec::with_capacity(count);
    let mut p = start;
    for _ in 0..count {
        if b.get(p..p + 4) != Some(&b"PK\x01\x02"[..]) {
            return Err(at_byte(p, "", "not a central directory entry"));
        }
        let field = |off: usize, four: bool| {
            if four {
                u32le(b, p + off)
            } else {
                u16le(b, p + off)
            }
            .ok_or_else(|| at_byte(p, "", "a central directory entry cut short"))
        };
        let (n, x, c) = (field(28, false)?, field(30, false)?, field(32, false)?);
        let name = b
            .get(p + 46..p + 46 + n)
            .ok_or_else(|| at_byte(p, "", "a part name cut short"))?;
        out.push(Entry {
            name: String::from_utf8_lossy(name).into_owned(),
            flags: field(8, false)?,
            method: field(10, false)?,
            crc: field(16, true)?,
            compressed: field(20, true)?,
            size: field(24, true)?,
            local: field(42, true)?,
        });
        p += 46 + n + x + c;
    }
    Ok(out)
}

/// A part's bytes: inflated (or stored), length and CRC-32 checked.
fn part_bytes(b: &[u8], e: &Entry) -> Result<Vec<u8>, MeshError> {
    let bad = |why: &str| MeshError::Package {
        place: e.name.clone(),
        text: String::new(),
        why: why.to_string(),
    };
    if e.flags & 1 != 0 {
        return Err(bad("the part is encrypted"));
    }
    if e.size > MAX_PART || e.compressed == 0xFFFF_FFFF {
        return Err(bad(&format!(
            "the part is larger than {MAX_PART} bytes (or a ZIP64 part)"
        )));
    }
    if e.method == 8 && e.size > RATIO_FREE && e.size / e.compressed.max(1) > MAX_RATIO {
        return Err(bad(&format!(
            "the part says it inflates from {} to {} bytes, more than {MAX_RATIO} times: a ZIP bomb, not a model (a 3MF model's XML compresses 3 to 20 times)",
            e.compressed, e.size
        )));
    }
    let l = e.local;
    if b.get(l..l + 4) != Some(&b"PK\x03\x04"[..]) {
        return Err(at_byte(l, "", "not a local file header"));
    }
    let data_at = l + 30 + u16le(b, l + 26).unwrap_or(0) + u16le(b, l + 28).unwrap_or(0);
    let data = b
        .get(data_at..data_at.saturating_add(e.compressed))
        .ok_or_else(|| at_byte(data_at, "", format!("part {} is cut short", e.name)))?;
    let out = match e.method {
        0 => data.to_vec(),
        8 => inflate(data, e.size).map_err(|why| bad(&format!("corrupt DEFLATE data: {why}")))?,
        m => {
            return Err(bad(&format!(
                "compression method {m} (only stored and DEFLATE are read)"
            )))
        }
    };
    if out.len() != e.size {
        return Err(bad(&format!(
            "inflates to {} bytes, the directory says {}",
            out.len(),
            e.size
        )));
    }
    if crc32(&out) as usize != e.crc {
        return Err(bad("CRC-32 mismatch: the part is corrupt"));
    }
    Ok(out)
}

/// CRC-32 (IEEE, reflected).
pub(crate) fn crc32(data: &[u8]) -> u32 {
    const TABLE: [u32; 256] = {
        let mut t = [0u32; 256];
        let mut i = 0;
        while i < 256 {
            let mut c = i as u32;
            let mut k = 0;
            while k < 8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
                k += 1;
            }
            t[i] = c;
            i += 1;
        }
        t
    };
    let mut c = !0u32;
    for &x in data {
        c = TABLE[((c ^ u32::from(x)) & 0xFF) as usize] ^ (c >> 8);
    }
    !c
}

/// DEFLATE's bit reader (least significant bit first).
struct Bits<'a> {
    data: &'a [u8],
    pos: usize,
    buf: u32,
    have: u32,
}

impl Bits<'_> {
    fn bits(&mut self, n: u32) -> Result<u32, &'static str> {
        while self.have < n {
            let byte = *self.data.get(self.pos).ok_or("the data ends early")?;
            self.pos += 1;
            self.buf |= u32::from(byte) << self.have;
            self.have += 8;
        }
        let v = self.buf & ((1u32 << n) - 1);
        self.buf >>= n;
        self.have -= n;
        Ok(v)
    }
}

/// A canonical Huffman code: how many codes of each length, and the symbols in order.
struct Huffman {
    count: [u16; 16],
    symbol: Vec<u16>,
}

impl Huffman {
    fn new(lengths: &[u8]) -> Result<Huffman, &'static str> {
        let mut count = [0u16; 16];
        for &l in lengths {
            count[usize::from(l)] += 1;
        }
        // Over-subscribed codes are refused; incomplete ones decode what they hold.
        let mut left: i32 = 1;
        for &c in &count[1..] {
            left = left * 2 - i32::from(c);
            if left < 0 {
                return Err("an over-subscribed Huffman code");
            }
        }
        let mut offs = [0u16; 16];
        for l in 1..15 {
            offs[l + 1] = offs[l] + count[l];
        }
        let mut symbol = vec![0u16; lengths.len()];
        for (s, &l) in lengths.iter().enumerate() {
            if l != 0 {
                symbol[usize::from(offs[usize::from(l)])] = s as u16;
                offs[usize::from(l)] += 1;
            }
        }
        count[0] = 0;
        Ok(Huffman { count, symbol })
    }

    fn decode(&self, b: &mut Bits) -> Result<u16, &'static str> {
        let (mut code, mut first, mut index) = (0i32, 0i32, 0i32);
        for len in 1..16 {
            code |= b.bits(1)? as i32;
            let count = i32::from(self.count[len]);
            if code - count < first {
                return self
                    .symbol
                    .get((index + code - first) as usize)
                    .copied()
                    .ok_or("a bad Huffman code");
            }
            index += count;
            first = (first + count) << 1;
            code <<= 1;
        }
        Err("a code the Huffman table does not hold")
    }
}

const LEN_BASE: [u16; 29] = [
    3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99, 115, 131,
    163, 195, 227, 258,
];
const LEN_EXTRA: [u8; 29] = [
    0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0,
];
const DIST_BASE: [u16; 30] = [
    1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025, 1537,
    2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577,
];
const DIST_EXTRA: [u8; 30] = [
    0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13,
    13,
];

/// Inflate a raw DEFLATE stream (RFC 1951) of at most `limit` bytes.
pub(crate) fn inflate(data: &[u8], limit: usize) -> Result<Vec<u8>, &'static str> {
    let mut b = Bits {
        data,
        pos: 0,
        buf: 0,
        have: 0,
    };
    let mut out: Vec<u8> = Vec::with_capacity(limit.min(1 << 24));
    loop {
        let last = b.bits(1)?;
        match b.bits(2)? {
            0 => {
                b.buf = 0;
                b.have = 0;
                let head = data
                    .get(b.pos..b.pos + 4)
                    .ok_or("a stored block cut short")?;
                let len = usize::from(u16::from_le_bytes([head[0], head[1]]));
                let nlen = u16::from_le_bytes([head[2], head[3]]);
                if nlen != !(len as u16) {
                    return Err("a stored block's length check fails");
                }
                b.pos += 4;
                let bytes = data
                    .get(b.pos..b.pos + len)
                    .ok_or("a stored block cut short")?;
                if out.len() + len > limit {
                    return Err("more data than the directory says");
                }
                out.extend_from_slice(bytes);
                b.pos += len;
            }
            1 => {
                let mut l = [0u8; 288];
                l[..144].fill(8);
                l[144..256].fill(9);
                l[256..280].fill(7);
                l[280..].fill(8);
                let lit = Huffman::new(&l)?;
                let dist = Huffman::new(&[5u8; 30])?;
                codes(&mut b, &mut out, &lit, &dist, limit)?;
            }
            2 => {
                let nlen = b.bits(5)? as usize + 257;
                let ndist = b.bits(5)? as usize + 1;
                let ncode = b.bits(4)? as usize + 4;
                if nlen > 286 || ndist > 30 {
                    return Err("a dynamic block with too many codes");
                }
                const ORDER: [usize; 19] = [
                    16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15,
                ];
                let mut cl = [0u8; 19];
                for &k in &ORDER[..ncode] {
                    cl[k] = b.bits(3)? as u8;
                }
                let lencode = Huffman::new(&cl)?;
                let mut lengths = vec![0u8; nlen + ndist];
                let mut i = 0;
                while i < nlen + ndist {
                    let sym = lencode.decode(&mut b)?;
                    let (val, rep) = match sym {
                        0..=15 => (sym as u8, 1),
                        16 => (
                            *lengths
                                .get(i.wrapping_sub(1))
                                .ok_or("a repeat with nothing before it")?,
                            3 + b.bits(2)? as usize,
                        ),
                        17 => (0, 3 + b.bits(3)? as usize),
                        _ => (0, 11 + b.bits(7)? as usize),
                    };
                    if i + rep > nlen + ndist {
                        return Err("code lengths run past their count");
                    }
                    lengths[i..i + rep].fill(val);
                    i += rep;
                }
                if lengths[256] == 0 {
                    return Err("no end-of-block code");
                }
                let lit = Huffman::new(&lengths[..nlen])?;
                let dist = Huffman::new(&lengths[nlen..])?;
                codes(&mut b, &mut out, &lit, &dist, limit)?;
            }
            _ => return Err("block type 3 (reserved)"),
        }
        if last == 1 {
            return Ok(out);
        }
    }
}

/// One compressed block's literals and copies, to its end-of-block code.
fn codes(
    b: &mut Bits,
    out: &mut Vec<u8>,
    lit: &Huffman,
    dist: &Huffman,
    limit: usize,
) -> Result<(), &'static str> {
    loop {
        let sym = usize::from(lit.decode(b)?);
        if sym < 256 {
            if out.len() >= limit {
                return Err("more data than the directory says");
            }
            out.push(sym as u8);
        } else if sym == 256 {
            return Ok(());
        } else {
            let k = sym - 257;
            let len = usize::from(*LEN_BASE.get(k).ok_or("a bad length code")?)
                + b.bits(u32::from(LEN_EXTRA[k]))? as usize;
            let d = usize::from(dist.decode(b)?);
            let back = usize::from(*DIST_BASE.get(d).ok_or("a bad distance code")?)
                + b.bits(u32::from(DIST_EXTRA[d]))? as usize;
            if back > out.len() {
                return Err("a distance back beyond the start");
            }
            if out.len() + len > limit {
                return Err("more data than the directory says");
            }
            let from = out.len() - back;
            for j in 0..len {
                let byte = out[from + j];
                out.push(byte);
            }
        }
    }
}

/// Millimetres per unit of a 3MF `unit` attribute.
fn unit_mm(unit: &str) -> Option<f64> {
    Some(match unit {
        "micron" => 0.001,
        "millimeter" => 1.0,
        "centimeter" => 10.0,
        "inch" => 25.4,
        "foot" => 304.8,
        "meter" => 1000.0,
        _ => return None,
    })
}

/// A 3MF mesh and the length of its unit.
#[derive(Debug, Clone, PartialEq)]
pub struct ThreeMf {
    /// Every build item's mesh, placed, welded exactly (in the file's units).
    pub mesh: Mesh,
    /// The model's `unit` attribute (`millimeter` when absent).
    pub unit: String,
    /// Millimetres per unit.
    pub mm_per_unit: f64,
}

/// An affine map as 3MF writes it: `p' = p·M + t` (row vectors), `m` row-major 3×3.
#[derive(Clone, Copy)]
struct Affine {
    m: [f64; 9],
    t: [f64; 3],
}

impl Affine {
    const ID: Affine = Affine {
        m: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        t: [0.0; 3],
    };

    fn apply(&self, p: &P3) -> P3 {
        let m = &self.m;
        P3::new(
            p.x * m[0] + p.y * m[3] + p.z * m[6] + self.t[0],
            p.x * m[1] + p.y * m[4] + p.z * m[7] + self.t[1],
            p.x * m[2] + p.y * m[5] + p.z * m[8] + self.t[2],
        )
    }

    /// `self` then `outer`.
    fn then(&self, outer: &Affine) -> Affine {
        let (a, b) = (&self.m, &outer.m);
        let mut m = [0.0; 9];
        for r in 0..3 {
            for c in 0..3 {
                m[3 * r + c] = (0..3).map(|k| a[3 * r + k] * b[3 * k + c]).sum();
            }
        }
        let t = outer.apply(&P3::new(self.t[0], self.t[1], self.t[2]));
        Affine {
            m,
            t: [t.x, t.y, t.z],
        }
    }

    fn det(&self) -> f64 {
        let m = &self.m;
        m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6])
            + m[2] * (m[3] * m[7] - m[4] * m[6])
    }
}

/// The model part's XML, read into a mesh.
struct ModelReader<'a> {
    part: &'a str,
    doc: &'a roxmltree::Document<'a>,
    objects: std::collections::HashMap<&'a str, roxmltree::Node<'a, 'a>>,
    corners: Vec<P3>,
    /// Objects placed, vertices and triangles read so far, and the bound.
    work: usize,
    max_work: usize,
}

impl<'a> ModelReader<'a> {
    fn err(&self, node: roxmltree::Node, text: &str, why: impl Into<String>) -> MeshError {
        let pos = self.doc.text_pos_at(node.range().start);
        MeshError::Package {
            place: format!("{} line {}, column {}", self.part, pos.row, pos.col),
            text: text.chars().take(200).collect(),
            why: why.into(),
        }
    }

    fn number(&self, node: roxmltree::Node, name: &str) -> Result<f64, MeshError> {
        let text = node
            .attribute(name)
            .ok_or_else(|| self.err(node, "", format!("no `{name}` attribute")))?;
        let v: f64 = text
            .trim()
            .parse()
            .map_err(|_| self.err(node, text, format!("`{name}` is not a number")))?;
        if !v.is_finite() {
            return Err(self.err(
                node,
                text,
                format!("vertex coordinate `{name}` is not a finite number"),
            ));
        }
        Ok(v)
    }

    fn transform(&self, node: roxmltree::Node) -> Result<Affine, MeshError> {
        let Some(text) = node.attribute("transform") else {
            return Ok(Affine::ID);
        };
        let v: Vec<f64> = text
            .split_ascii_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|_| self.err(node, text, "a transform is 12 numbers"))?;
        if v.len() != 12 || !v.iter().all(|x| x.is_finite()) {
            return Err(self.err(node, text, "a transform is 12 finite numbers"));
        }
        Ok(Affine {
            m: [v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]],
            t: [v[9], v[10], v[11]],
        })
    }

    /// One more unit of work placing object `id` (from `from`), refused past
    /// [`MAX_WORK`].
    fn spend(&mut self, from: roxmltree::Node, id: &str) -> Result<(), MeshError> {
        self.work += 1;
        if self.work > self.max_work {
            return Err(self.err(
                from,
                id,
                format!(
                    "the build places more than {} objects, vertices and triangles",
                    self.max_work
                ),
            ));
        }
        Ok(())
    }

    /// Object `id`'s triangles placed by `at`, added to the corners.
    fn object(
        &mut self,
        from: roxmltree::Node<'a, 'a>,
        id: &str,
        at: &Affine,
        depth: usize,
    ) -> Result<(), MeshError> {
        let Some(&obj) = self.objects.get(id) else {
            return Err(self.err(from, id, "names an object the resources do not hold"));
        };
        if depth > MAX_DEPTH {
            return Err(self.err(
                from,
                id,
                format!("components nest deeper than {MAX_DEPTH} (a cycle?)"),
            ));
        }
        self.spend(from, id)?;
        let child = |n: roxmltree::Node<'a, 'a>, name: &str| {
            n.children()
                .find(|c| c.is_element() && c.tag_name().name() == name)
        };
        if let Some(mesh) = child(obj, "mesh") {
            let mut verts = Vec::new();
            if let Some(vs) = child(mesh, "vertices") {
                for v in vs.children().filter(|c| c.tag_name().name() == "vertex") {
                    self.spend(from, id)?;
                    let p = P3::new(
                        self.number(v, "x")?,
                        self.number(v, "y")?,
                        self.number(v, "z")?,
                    );
                    verts.push(at.apply(&p));
                }
            }
            let flip = at.det() < 0.0;
            if let Some(ts) = child(mesh, "triangles") {
                for t in ts.children().filter(|c| c.tag_name().name() == "triangle") {
                    self.spend(from, id)?;
                    let mut c = [P3::zeros(); 3];
                    for (k, name) in ["v1", "v2", "v3"].iter().enumerate() {
                        let text = t.attribute(*name).unwrap_or("");
                        let i: usize = text.trim().parse().map_err(|_| {
                            self.err(t, text, format!("`{name}` is not a vertex index"))
                        })?;
                        c[k] = *verts.get(i).ok_or_else(|| {
                            self.err(
                                t,
                                text,
                                format!(
                                    "`{name}` names a vertex that is not there (the object has {}, numbered from 0)",
                                    verts.len()
                                ),
                            )
                        })?;
                    }
                    if flip {
                        c.swap(1, 2);
                    }
                    self.corners.extend_from_slice(&c);
                }
            }
        } else if let Some(comps) = child(obj, "components") {
            for c in comps
                .children()
                .filter(|c| c.tag_name().name() == "component")
            {
                let cid = c
                    .attribute("objectid")
                    .ok_or_else(|| self.err(c, "", "a component without `objectid`"))?;
                let inner = self.transform(c)?.then(at);
                self.object(c, cid, &inner, depth + 1)?;
            }
        }
        Ok(())
    }
}

/// The model part's name: the target of the package's 3D-model relationship, else
/// `3D/3dmodel.model`.
fn model_name(b: &[u8], list: &[Entry]) -> String {
    let rels = list
        .iter()
        .find(|e| e.name == "_rels/.rels")
        .and_then(|e| part_bytes(b, e).ok())
        .and_then(|x| String::from_utf8(x).ok());
    if let Some(text) = rels {
        if let Ok(doc) = roxmltree::Document::parse(&text) {
            if let Some(t) = doc
                .descendants()
                .filter(|n| n.tag_name().name() == "Relationship")
                .find(|n| n.attribute("Type").is_some_and(|t| t.ends_with("/3dmodel")))
                .and_then(|n| n.attribute("Target"))
            {
                return t.trim_start_matches('/').to_string();
            }
        }
    }
    "3D/3dmodel.model".to_string()
}

/// Read a 3MF package (see the module documentation).
pub fn read_3mf(bytes: &[u8]) -> Result<ThreeMf, MeshError> {
    read_within(bytes, MAX_WORK)
}

/// [`read_3mf`] with `max_work` in place of [`MAX_WORK`].
fn read_within(bytes: &[u8], max_work: usize) -> Result<ThreeMf, MeshError> {
    let list = entries(bytes)?;
    let name = model_name(bytes, &list);
    let entry = list.iter().find(|e| e.name == name).ok_or_else(|| {
        at_byte(
            0,
            name.clone(),
            "the package holds no 3D model part (3D/3dmodel.model)",
        )
    })?;
    let raw = part_bytes(bytes, entry)?;
    let text = String::from_utf8(raw).map_err(|e| MeshError::Package {
        place: format!("{name} byte {}", e.utf8_error().valid_up_to()),
        text: String::new(),
        why: "the model is not UTF-8".into(),
    })?;
    let doc = roxmltree::Document::parse(&text).map_err(|e| {
        let p = e.pos();
        MeshError::Package {
            place: format!("{name} line {}, column {}", p.row, p.col),
            text: String::new(),
            why: format!("not well-formed XML: {e}"),
        }
    })?;
    let root = doc.root_element();
    let mut r = ModelReader {
        part: &name,
        doc: &doc,
        objects: std::collections::HashMap::new(),
        corners: Vec::new(),
        work: 0,
        max_work,
    };
    if root.tag_name().name() != "model" {
        return Err(r.err(
            root,
            root.tag_name().name(),
            "the root element is not `model`",
        ));
    }
    let unit = root.attribute("unit").unwrap_or("millimeter");
    let mm_per_unit = unit_mm(unit).ok_or_else(|| {
        r.err(
            root,
            unit,
            "an unknown unit (micron, millimeter, centimeter, inch, foot or meter)",
        )
    })?;
    for o in root
        .descendants()
        .filter(|n| n.tag_name().name() == "object")
    {
        if let Some(id) = o.attribute("id") {
            r.objects.insert(id, o);
        }
    }
    let build = root
        .children()
        .find(|c| c.tag_name().name() == "build")
        .ok_or_else(|| r.err(root, "", "no `build` element: nothing to make"))?;
    for item in build.children().filter(|c| c.tag_name().name() == "item") {
        let id = item
            .attribute("objectid")
            .ok_or_else(|| r.err(item, "", "a build item without `objectid`"))?;
        let at = r.transform(item)?;
        r.object(item, id, &at, 0)?;
    }
    let corners = std::mem::take(&mut r.corners);
    if corners.is_empty() {
        return Err(MeshError::Empty);
    }
    let n = corners.len() / 3;
    if n > u32::MAX as usize / 3 {
        return Err(MeshError::Unsupported(
            "more than 2^32 / 3 triangles".into(),
        ));
    }
    let triangles = (0..n)
        .map(|i| {
            let b = (3 * i) as u32;
            [b, b + 1, b + 2]
        })
        .collect();
    Ok(ThreeMf {
        mesh: crate::weld::weld_exact(&Mesh {
            vertices: corners,
            triangles,
        }),
        unit: unit.to_string(),
        mm_per_unit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> Vec<u8> {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../fixtures/meshes/3mf")
            .join(name);
        std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
    }

    /// A ZIP package of stored (uncompressed) parts.
    fn zip(parts: &[(&str, &[u8])]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut dir = Vec::new();
        for (name, data) in parts {
            let at = out.len() as u32;
            let crc = crc32(data);
            let head = |sig: &[u8], central: bool| {
                let mut h = sig.to_vec();
                if central {
                    h.extend_from_slice(&20u16.to_le_bytes());
                }
                h.extend_from_slice(&20u16.to_le_bytes()); // version
                h.extend_from_slice(&0u16.to_le_bytes()); // flags
                h.extend_from_slice(&0u16.to_le_bytes()); // stored
                h.extend_from_slice(&[0; 4]); // time, date
                h.extend_from_slice(&crc.to_le_bytes());
                h.extend_from_slice(&(data.len() as u32).to_le_bytes());
                h.extend_from_slice(&(data.len() as u32).to_le_bytes());
                h.extend_from_slice(&(name.len() as u16).to_le_bytes());
                h.extend_from_slice(&0u16.to_le_bytes()); // extra
                if central {
                    h.extend_from_slice(&[0; 6]); // comment, disk, internal attributes
                    h.extend_from_slice(&[0; 4]); // external attributes
                    h.extend_from_slice(&at.to_le_bytes());
                }
                h.extend_from_slice(name.as_bytes());
                h
            };
            out.extend(head(b"PK\x03\x04", false));
            out.extend_from_slice(data);
            dir.extend(head(b"PK\x01\x02", true));
        }
        let start = out.len() as u32;
        out.extend_from_slice(&dir);
        out.extend_from_slice(b"PK\x05\x06\0\0\0\0");
        out.extend_from_slice(&(parts.len() as u16).to_le_bytes());
        out.extend_from_slice(&(parts.len() as u16).to_le_bytes());
        out.extend_from_slice(&(dir.len() as u32).to_le_bytes());
        out.extend_from_slice(&start.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        out
    }

    /// A model part holding one tetrahedron with the given vertex text and unit.
    fn tetra(unit: &str, x1: &str) -> String {
        format!(
            r#"<?xml version="1.0" encoding="UTF-8"?>
<model unit="{unit}" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">
  <resources>
    <object id="1" type="model">
      <mesh>
        <vertices>
          <vertex x="0" y="0" z="0" />
          <vertex x="{x1}" y="0" z="0" />
          <vertex x="0" y="1" z="0" />
          <vertex x="0" y="0" z="1" />
        </vertices>
        <triangles>
          <triangle v1="0" v2="2" v3="1" />
          <triangle v1="0" v2="1" v3="3" />
          <triangle v1="0" v2="3" v3="2" />
          <triangle v1="1" v2="2" v3="3" />
        </triangles>
      </mesh>
    </object>
  </resources>
  <build>
    <item objectid="1" />
  </build>
</model>
"#
        )
    }

    /// h58: a megabyte of DEFLATE blanks inflates to a gigabyte of XML (within
    /// [`MAX_PART`]) and took 1 GB to read; a part claiming more than [`MAX_RATIO`] times
    /// its compressed size is refused before it is inflated.
    #[test]
    fn a_zip_bomb_part_is_refused_before_it_is_inflated() {
        let model = tetra("millimeter", "1");
        let mut pkg = zip(&[("3D/3dmodel.model", model.as_bytes())]);
        // The central directory's entry: say DEFLATE, 64 MiB from the stored bytes.
        let cd = pkg
            .windows(4)
            .position(|w| w == b"PK\x01\x02")
            .expect("central directory");
        pkg[cd + 10..cd + 12].copy_from_slice(&8u16.to_le_bytes());
        pkg[cd + 24..cd + 28].copy_from_slice(&(64u32 << 20).to_le_bytes());
        let e = read_3mf(&pkg).expect_err("a bomb");
        let text = e.to_string();
        assert!(text.contains("ZIP bomb"), "{text}");
        // The same model stored as it is reads.
        let ok = zip(&[("3D/3dmodel.model", model.as_bytes())]);
        assert!(read_3mf(&ok).is_ok());
    }

    #[test]
    fn the_consortiums_box_is_a_closed_10_by_20_by_30_mm_solid() {
        let t = read_3mf(&fixture("box.3mf")).expect("box");
        assert_eq!(t.unit, "millimeter");
        assert_eq!(t.mm_per_unit, 1.0);
        assert_eq!(t.mesh.vertices.len(), 8);
        assert_eq!(t.mesh.triangles.len(), 12);
        assert!(crate::manifold_report(&t.mesh).closed_oriented());
        assert_eq!(crate::props::volume(&t.mesh), 6000.0);
        let (lo, hi) = crate::props::bounds(&t.mesh).expect("bounds");
        assert_eq!((lo, hi), (P3::zeros(), P3::new(10.0, 20.0, 30.0)));
        // Through the generic reader and by content.
        let bytes = fixture("box.3mf");
        assert_eq!(
            crate::read::Format::sniff(&bytes),
            crate::read::Format::ThreeMf
        );
        assert_eq!(
            crate::read(&bytes, crate::read::Format::ThreeMf),
            Ok(t.mesh)
        );
    }

    #[test]
    fn build_item_transforms_place_objects_as_components_do() {
        let items = read_3mf(&fixture("items-transform.3mf")).expect("items");
        let comps = read_3mf(&fixture("components.3mf")).expect("components");
        assert_eq!(items.mesh, comps.mesh);
        // Two copies of one closed object, the second 30 along x and 40 along y.
        let r = crate::manifold_report(&items.mesh);
        assert!(r.closed_oriented(), "{r:?}");
        let (lo, hi) = crate::props::bounds(&items.mesh).expect("bounds");
        assert!(hi.x - lo.x > 30.0 && hi.y - lo.y > 40.0, "{lo} {hi}");
        assert!(crate::props::volume(&items.mesh) > 0.0);
    }

    #[test]
    fn units_come_from_the_file() {
        for (unit, mm) in [
            ("micron", 0.001),
            ("millimeter", 1.0),
            ("centimeter", 10.0),
            ("inch", 25.4),
            ("foot", 304.8),
            ("meter", 1000.0),
        ] {
            let pkg = zip(&[("3D/3dmodel.model", tetra(unit, "2").as_bytes())]);
            let t = read_3mf(&pkg).expect("tetra");
            assert_eq!((t.unit.as_str(), t.mm_per_unit), (unit, mm));
            // The generic reader gives millimetres.
            let m = crate::read(&pkg, crate::read::Format::ThreeMf).expect("read");
            let (_, hi) = crate::props::bounds(&m).expect("bounds");
            assert_eq!(hi.x, 2.0 * mm);
        }
        let pkg = zip(&[("3D/3dmodel.model", tetra("furlong", "2").as_bytes())]);
        let e = read_3mf(&pkg).expect_err("unknown unit");
        assert_eq!(e.text(), Some("furlong"));
        assert!(
            e.to_string().contains("3D/3dmodel.model line 2, column 1"),
            "{e}"
        );
    }

    #[test]
    fn bad_packages_are_refused_with_their_place() {
        // Not a ZIP at all.
        let e = read_3mf(b"solid nothing\nendsolid\n").expect_err("not a zip");
        assert!(e.to_string().contains("end-of-central-directory"), "{e}");
        // A package without the model part.
        let pkg = zip(&[("Metadata/thumbnail.png", b"png")]);
        let e = read_3mf(&pkg).expect_err("no model");
        assert!(e.to_string().contains("no 3D model part"), "{e}");
        // The model named by the package's relationship.
        let rels = br#"<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
<Relationship Target="/3D/part.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel" />
</Relationships>"#;
        let pkg = zip(&[
            ("_rels/.rels", &rels[..]),
            ("3D/part.model", tetra("millimeter", "3").as_bytes()),
        ]);
        assert_eq!(read_3mf(&pkg).expect("named model").mesh.vertices.len(), 4);
        // A NaN vertex: located in the model part, with its text.
        for bad in ["NaN", "inf", "1e999"] {
            let pkg = zip(&[("3D/3dmodel.model", tetra("millimeter", bad).as_bytes())]);
            let e = read_3mf(&pkg).expect_err("not finite");
            assert_eq!(e.text(), Some(bad));
            assert!(
                e.to_string()
                    .starts_with("3D/3dmodel.model line 8, column 11: vertex coordinate `x`"),
                "{e}"
            );
        }
        // A triangle naming a vertex that is not there.
        let text = tetra("millimeter", "1").replace(
            r#"v3="3" />
        </triangles>"#,
            r#"v3="4" />
        </triangles>"#,
        );
        let pkg = zip(&[("3D/3dmodel.model", text.as_bytes())]);
        let e = read_3mf(&pkg).expect_err("index");
        assert_eq!(e.text(), Some("4"));
        assert!(e.to_string().contains("line 16, column 11"), "{e}");
        // XML that is not well formed.
        let pkg = zip(&[(
            "3D/3dmodel.model",
            b"<model unit=\"millimeter\"><resources>",
        )]);
        let e = read_3mf(&pkg).expect_err("xml");
        assert!(e.to_string().contains("not well-formed XML"), "{e}");
        // No build: nothing to make.
        let text = tetra("millimeter", "1")
            .replace("<build>\n    <item objectid=\"1\" />\n  </build>", "");
        let pkg = zip(&[("3D/3dmodel.model", text.as_bytes())]);
        assert!(read_3mf(&pkg)
            .expect_err("no build")
            .to_string()
            .contains("no `build`"));
        // A build item naming no object; components nesting without end.
        let text =
            tetra("millimeter", "1").replace("<item objectid=\"1\" />", "<item objectid=\"7\" />");
        let pkg = zip(&[("3D/3dmodel.model", text.as_bytes())]);
        assert!(read_3mf(&pkg)
            .expect_err("no object")
            .to_string()
            .contains("names an object"));
        let text = tetra("millimeter", "1").replace(
            "</resources>",
            "<object id=\"2\"><components><component objectid=\"2\" /></components></object></resources>",
        ).replace("<item objectid=\"1\" />", "<item objectid=\"2\" />");
        let pkg = zip(&[("3D/3dmodel.model", text.as_bytes())]);
        assert!(read_3mf(&pkg)
            .expect_err("cycle")
            .to_string()
            .contains("nest deeper"));
        // Two components per level, 30 levels: 2^30 placements of the tetrahedron,
        // refused by the work bound rather than attempted.
        let mut objs = String::new();
        for k in 2..32 {
            objs.push_str(&format!(
                "<object id=\"{k}\"><components><component objectid=\"{}\" /><component objectid=\"{}\" /></components></object>",
                k - 1,
                k - 1
            ));
        }
        let text = tetra("millimeter", "1")
            .replace("</resources>", &format!("{objs}</resources>"))
            .replace("<item objectid=\"1\" />", "<item objectid=\"31\" />");
        let pkg = zip(&[("3D/3dmodel.model", text.as_bytes())]);
        // (The bound made small here; `MAX_WORK` applies the same way.)
        let e = read_within(&pkg, 100_000).expect_err("bomb");
        assert!(e.to_string().contains("the build places more than"), "{e}");
    }

    #[test]
    fn corrupt_packages_are_refused_and_never_panic() {
        let good = fixture("box.3mf");
        // Cut short anywhere: refused (the directory is at the end).
        for cut in [0, 10, 100, 500, good.len() - 30, good.len() - 1] {
            assert!(read_3mf(&good[..cut]).is_err(), "cut at {cut}");
        }
        // Every byte flipped in turn: an error or (where the byte does not matter, as in
        // a time stamp or another part) the same mesh, never a panic or another mesh;
        // every flip in the model's compressed data is caught.
        let want = read_3mf(&good).expect("box").mesh;
        let list = entries(&good).expect("entries");
        let e = list
            .iter()
            .find(|e| e.name == "3D/3dmodel.model")
            .expect("model");
        let data = e.local
            + 30
            + u16le(&good, e.local + 26).unwrap_or(0)
            + u16le(&good, e.local + 28).unwrap_or(0);
        for i in 0..good.len() {
            let mut b = good.clone();
            b[i] ^= 0x5A;
            if let Ok(t) = read_3mf(&b) {
                assert_eq!(t.mesh, want, "byte {i}");
                assert!(!(data..data + e.compressed).contains(&i), "byte {i}");
            }
        }
        // The model part's CRC is checked.
        let mut pkg = zip(&[("3D/3dmodel.model", tetra("millimeter", "2").as_bytes())]);
        let at = pkg
            .windows(6)
            .position(|w| w == b"x=\"2\" ")
            .expect("vertex");
        pkg[at + 3] = b'3';
        let e = read_3mf(&pkg).expect_err("crc");
        assert!(e.to_string().contains("CRC-32"), "{e}");
    }

    #[test]
    fn crc32_and_inflate_of_known_streams() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        // A stored block written by hand; a fixed-Huffman block from zlib
        // (`compressobj(9, DEFLATED, -15, 9, Z_FIXED)` of "abcabcabc": three literals
        // and a copy).
        assert_eq!(
            inflate(&[0x01, 0x03, 0x00, 0xFC, 0xFF, b'a', b'b', b'c'], 3),
            Ok(b"abc".to_vec())
        );
        let fixed = [0x4B, 0x4C, 0x4A, 0x4E, 0x04, 0x23, 0x00];
        assert_eq!(inflate(&fixed, 100), Ok(b"abcabcabc".to_vec()));
        // Beyond the limit, a stored block whose length check fails, a truncated stream,
        // the reserved block type.
        assert!(inflate(&fixed, 8).is_err());
        assert!(inflate(&[0x01, 0x03, 0x00, 0xFC, 0xFE, b'a', b'b', b'c'], 3).is_err());
        assert!(inflate(&fixed[..3], 100).is_err());
        assert!(inflate(&[0x07], 100).is_err());
    }
}
