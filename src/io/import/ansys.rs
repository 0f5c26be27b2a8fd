//! ANSYS MAPDL models: the binary full file (`Jobname.full`, [`read_full`]) and the APDL Math
//! Matrix Market export ([`read_apdl_math`]).
//!
//! # The binary full file
//! Facts used here, from the ANSYS Programmer's Reference (`fdfull.inc`, "Description of the
//! Full Stiffness-Mass File") as read by the independent reader ansys-mapdl-reader
//! (`full.py`, `common.py`, `binary_reader.cpp`), and checked on `ansys_example_full/file.full`
//! (ANSYS 15.0):
//! * The file is a sequence of records. A record is: a word count `n` (4-byte integer), a
//!   flag word, `n` data words of 4 bytes, and a footer word repeating `n`. Bits of the flag
//!   word: 31 integer data (else real), 30 short precision (16-bit integers / 32-bit floats),
//!   29 zlib, 28 windowed sparse, 27 bit sparse compression. Only plain 32-bit integer and
//!   64-bit real records are read; the others are refused with their byte offset.
//! * Byte order: the first word is 100 (the standard header's length); read little-endian
//!   unless it only reads 100 big-endian.
//! * Record 1, the standard header (100 integers): item 1 the file unit (4 = full file), item
//!   5 the unit system of `/UNITS` (0 user, 1 SI, 2 CGS, 3 BFT, 4 BIN, 5 MKS, 6 MPA, 7 uMKS),
//!   item 10 the release as 4 characters (`15.0`), items 12–14 the machine, 15–16 the job name,
//!   41–60 the title. Characters are stored one word per 4, most significant byte first.
//! * Record 2, the full header (items 1-based): 1 `fun04` (< 0: sparse/symbolic assembly, the
//!   layout of release ≥ 14.5; > 0: the old frontal layout, refused), 2 `neqn`, 8 `numdof`,
//!   9/10 `ntermK` (low/high word), 11 `lumpm`, 14 `keyuns` (unsymmetric, refused), 19/20
//!   `ptrSTF`, 22/34 `ntermM` (high/low), 27/28 `ptrMAS`, 33 `nNodes`, 36/37 `ptrDOF`.
//!   Pointers count 4-byte words from the start of the file; a "long" is low + 2³²·high.
//! * Record 3: the DoF set, `numdof` DoF keys (1 UX, 2 UY, 3 UZ, 4 ROTX, 5 ROTY, 6 ROTZ).
//!   Record 4: the nodal equivalence table, the node number of each of the `nNodes` internal
//!   nodes.
//! * At `ptrDOF`: the DoF count of each internal node, then one integer per equation whose sign
//!   is negative for a constrained DoF. Equations run node by node in internal order, each
//!   node's DoFs in the DoF-set order.
//! * At `ptrSTF` (`ptrMAS`): for each equation (column) j, an integer record of the 1-based row
//!   numbers i ≥ j of the column (lower triangle) and a real record of their values.
//!
//! The result is ordered like ansys-mapdl-reader's `load_km(sort=True)` (and ANSYS `HBMAT`):
//! nodes by ascending node number, each node's DoFs in DoF-set order. Constrained DoFs (their
//! rows and columns) are removed and listed in [`Imported::removed`]. The full file holds no
//! coordinates; a node table ([`super::read_node_table`]) may be given with it.
//!
//! The file is read record by record through a buffered reader (no whole-file copy); errors
//! name the byte offset of the record.
//!
//! # The APDL Math export
//! `*EXPORT,K,MMF,…` and `*EXPORT,M,MMF,…` write Matrix Market `coordinate real symmetric`
//! files (`% Creator: ANSYS Inc`), read by [`crate::io::matrix_market`]. The DoF mapping vector
//! (a Matrix Market `array integer` file) holds the node number of each block of
//! `dofs_per_node` equations (EXUDYN's `rotorAnsysMatrixDofMappingVector.txt`: 115 entries for
//! N = 345). The order of the matrices is kept.
//!
//! K and M may instead be Harwell–Boeing files (`*EXPORT,…,HBMAT`, the `HBMAT` command; read by
//! [`super::harwell_boeing`], told apart by their header); the rest of the set is the same.
//!
//! # Recognizing the files
//! `looks_like_full`: the 32-bit word 100 at byte 0 in either byte order (the standard
//! header's record length). `looks_like_mapping`: a Matrix Market banner naming `array` and
//! `integer`. `looks_like_matrix_market`: any other Matrix Market file, a K or M.

use super::harwell_boeing;
use super::node_table::read_node_table;
use super::types::{uniform_nodes, Direction, Dof, Format, Imported};
use crate::io::binary::{word, BinaryFile};
use crate::io::file::head;
use crate::io::matrix_market;
use crate::sparse::Triplets;
use crate::{Error, Result};
use std::path::Path;

const FLAG_INTEGER: u32 = 1 << 31;
const FLAG_SHORT: u32 = 1 << 30;
const FLAG_ZLIB: u32 = 1 << 29;
const FLAG_WINDOWED: u32 = 1 << 28;
const FLAG_BITSPARSE: u32 = 1 << 27;

/// True when `head` (a file's first bytes) starts like an ANSYS binary file: the 32-bit word
/// 100 at byte 0, in either byte order (the standard header is a 100-word record; ANSYS
/// Programmer's Reference, "Standard ANSYS file header").
pub(crate) fn looks_like_full(head: &[u8]) -> bool {
    head.len() >= 4 && (word(head, false) == 100 || word(head, true) == 100)
}

/// True when `head` (a file's first bytes) is a Matrix Market file: with an APDL Math export,
/// the K or M (unless [`looks_like_mapping`]).
pub(crate) fn looks_like_matrix_market(head: &[u8]) -> bool {
    head.starts_with(b"%%MatrixMarket")
}

/// True when `head` (a file's first bytes) is the DoF mapping vector of an APDL Math export:
/// a Matrix Market file whose banner names `array` and `integer`.
pub(crate) fn looks_like_mapping(head: &[u8]) -> bool {
    let banner = String::from_utf8_lossy(head.split(|&b| b == b'\n').next().unwrap_or(&[]))
        .to_ascii_lowercase();
    looks_like_matrix_market(head) && banner.contains("array") && banner.contains("integer")
}

/// Sequential reader of ANSYS binary records.
struct Records {
    f: BinaryFile,
    bytes: Vec<u8>,
}

impl Records {
    fn open(path: &Path) -> Result<Self> {
        let mut r = Records {
            f: BinaryFile::open(path, false)?,
            bytes: Vec::new(),
        };
        let mut w = [0u8; 4];
        r.read_exact(&mut w, 0, "the standard header")?;
        r.f.big_endian = match (u32::from_le_bytes(w), u32::from_be_bytes(w)) {
            (100, _) => false,
            (_, 100) => true,
            _ => {
                return Err(r.error(
                    0,
                    "not an ANSYS binary file: the first word must be 100 (the length of the standard header)",
                ))
            }
        };
        r.seek_word(0, "the standard header")?;
        Ok(r)
    }

    fn error(&self, at: u64, msg: impl std::fmt::Display) -> Error {
        self.f.error(at, msg)
    }

    fn word(&self, b: &[u8]) -> u32 {
        self.f.word(b)
    }

    fn read_exact(&mut self, buf: &mut [u8], at: u64, what: &str) -> Result<()> {
        self.f.read_exact(buf, at, what)
    }

    /// Moves to a word pointer of the full header.
    fn seek_word(&mut self, word: u64, what: &str) -> Result<()> {
        let at = word.saturating_mul(4);
        if at >= self.f.len {
            return Err(self.error(
                at,
                format!(
                    "the pointer to {what} (word {word}) lies beyond the end of the file ({} bytes; truncated file?)",
                    self.f.len
                ),
            ));
        }
        self.f.seek(at)
    }

    /// Reads the next record into `self.bytes`; checks its type, size and footer.
    fn record(&mut self, integer: bool, what: &str) -> Result<()> {
        let at = self.f.pos;
        let mut head = [0u8; 8];
        self.read_exact(&mut head, at, &format!("the header of the {what} record"))?;
        let (n, flags) = (self.word(&head[..4]), self.word(&head[4..]));
        let size = u64::from(n) * 4;
        if n > i32::MAX as u32 || at + 12 + size > self.f.len {
            return Err(self.error(
                at,
                format!(
                    "the {what} record claims {n} words but the file ends at byte {} (truncated file?)",
                    self.f.len
                ),
            ));
        }
        if flags & (FLAG_ZLIB | FLAG_WINDOWED | FLAG_BITSPARSE) != 0 {
            return Err(self.error(
                at,
                format!("the {what} record is compressed (flags {flags:#010x}); only uncompressed full files are supported"),
            ));
        }
        let kind_ok = if integer {
            flags & FLAG_INTEGER != 0 && flags & FLAG_SHORT == 0
        } else {
            flags & (FLAG_INTEGER | FLAG_SHORT) == 0 && n % 2 == 0
        };
        if !kind_ok {
            let found = match (flags & FLAG_INTEGER != 0, flags & FLAG_SHORT != 0) {
                (true, true) => "16-bit integers",
                (true, false) => "32-bit integers",
                (false, true) => "32-bit reals",
                (false, false) => "64-bit reals",
            };
            return Err(self.error(
                at,
                format!(
                    "the {what} record holds {found} ({n} words); expected {}",
                    if integer {
                        "32-bit integers"
                    } else {
                        "64-bit reals"
                    }
                ),
            ));
        }
        let mut bytes = std::mem::take(&mut self.bytes);
        bytes.resize(size as usize + 4, 0);
        self.read_exact(&mut bytes, at, &format!("the {what} record"))?;
        let footer = self.word(&bytes[size as usize..]);
        bytes.truncate(size as usize);
        self.bytes = bytes;
        if footer != n {
            return Err(self.error(
                at,
                format!(
                    "the {what} record ends with {footer}, not its word count {n} (corrupt file)"
                ),
            ));
        }
        self.f.pos = at + 12 + size;
        Ok(())
    }

    /// The next record as 32-bit integers.
    fn ints(&mut self, what: &str, out: &mut Vec<i32>) -> Result<u64> {
        let at = self.f.pos;
        self.record(true, what)?;
        out.clear();
        out.extend(self.bytes.chunks_exact(4).map(|b| self.word(b) as i32));
        Ok(at)
    }

    /// The next record as 64-bit reals.
    fn reals(&mut self, what: &str, out: &mut Vec<f64>) -> Result<()> {
        self.record(false, what)?;
        out.clear();
        let big = self.f.big_endian;
        out.extend(self.bytes.chunks_exact(8).map(|b| {
            let w = [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]];
            if big {
                f64::from_be_bytes(w)
            } else {
                f64::from_le_bytes(w)
            }
        }));
        Ok(())
    }

    /// A whole integer record that must hold `len` entries.
    fn table(&mut self, what: &str, len: usize) -> Result<Vec<i32>> {
        let mut v = Vec::new();
        let at = self.ints(what, &mut v)?;
        if v.len() < len {
            return Err(self.error(
                at,
                format!(
                    "the {what} holds {} entries; the full header says {len}",
                    v.len()
                ),
            ));
        }
        v.truncate(len);
        Ok(v)
    }
}

/// Four characters stored in one integer word, most significant byte first.
fn chars(words: &[i32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_be_bytes()).collect();
    String::from_utf8_lossy(&bytes)
        .trim_matches(|c: char| c.is_whitespace() || c == '\0')
        .to_string()
}

/// A "long" pointer or count from its low and high words.
fn long(low: i32, high: i32) -> u64 {
    u64::from(low as u32) | (u64::from(high as u32) << 32)
}

/// Reads an ANSYS binary full file (see the [module documentation](self)), with an optional
/// node table (`node x y z`) for the coordinates.
///
/// # Errors
/// [`Error::Parse`] with the byte offset: not an ANSYS binary file, not a full file, a release
/// before 14.5 (frontal layout), unsymmetric or lumped matrices, compressed or 16-bit records,
/// a truncated or corrupt record, a row index out of range or above the diagonal, a term count
/// that disagrees with the header, DoF keys other than UX–ROTZ; the node table's errors.
pub fn read_full(path: &Path, node_table: Option<&Path>) -> Result<Imported> {
    let mut r = Records::open(path)?;
    let std = r.table("standard header", 100)?;
    if std[0] != 4 {
        return Err(r.error(
            8,
            format!(
                "ANSYS binary file of unit {} (4 is the full file; 12 a result file, 2 an element matrix file)",
                std[0]
            ),
        ));
    }
    let release = chars(&std[9..10]);
    let version: Option<(u32, u32)> = release
        .split_once('.')
        .and_then(|(a, b)| Some((a.trim().parse().ok()?, b.trim().parse().ok()?)));
    let h = r.table("full header", 37)?;
    let full_header_at = 4 * 103;
    if version.is_some_and(|v| v < (14, 5)) {
        return Err(r.error(
            44,
            format!("ANSYS release '{release}': full files before 14.5 (frontal assembly) are not supported"),
        ));
    }
    if h[0] >= 0 {
        return Err(r.error(
            full_header_at,
            "frontal-assembly full file (fun04 > 0): only the sparse-assembly layout of ANSYS >= 14.5 is supported",
        ));
    }
    let neqn = usize::try_from(h[1]).unwrap_or(0);
    let numdof = usize::try_from(h[7]).unwrap_or(0);
    let n_nodes = usize::try_from(h[32]).unwrap_or(0);
    let nterm_k = long(h[8], h[9]);
    let nterm_m = long(h[33], h[21]);
    let (ptr_stf, ptr_mas, ptr_dof) = (long(h[18], h[19]), long(h[26], h[27]), long(h[35], h[36]));
    if neqn == 0 || n_nodes == 0 || numdof == 0 {
        return Err(r.error(
            full_header_at,
            format!(
                "full header: neqn = {}, nNodes = {}, numdof = {}: an empty model",
                h[1], h[32], h[7]
            ),
        ));
    }
    if h[13] != 0 {
        return Err(r.error(
            full_header_at,
            "unsymmetric matrices (keyuns = 1): sparsemor needs symmetric M and K",
        ));
    }
    if h[10] != 0 {
        return Err(r.error(
            full_header_at,
            "lumped mass (lumpm = 1): the layout of a lumped full file is not supported; write a consistent mass (LUMPM,OFF) or export with *EXPORT,MMF",
        ));
    }
    if nterm_m == 0 || ptr_mas == 0 {
        return Err(r.error(
            full_header_at,
            "the full file holds no mass matrix: run a modal analysis (ANTYPE,MODAL) or *EXPORT the mass",
        ));
    }
    let set_at = r.f.pos;
    let dof_set: Vec<Direction> = r
        .table("DoF set", numdof)?
        .into_iter()
        .map(|k| {
            Direction::from_key(i64::from(k)).ok_or_else(|| {
                r.error(
                    set_at,
                    format!("DoF key {k} in the DoF set: only UX, UY, UZ, ROTX, ROTY, ROTZ (keys 1–6) are supported"),
                )
            })
        })
        .collect::<Result<_>>()?;
    if numdof != 3 && numdof != 6 {
        return Err(r.error(
            set_at,
            format!("{numdof} DoFs per node: supported are 3 (UX, UY, UZ) and 6 (with ROTX, ROTY, ROTZ)"),
        ));
    }
    let node_numbers = r.table("nodal equivalence table", n_nodes)?;
    r.seek_word(ptr_dof, "the DoF counts (ptrDOF)")?;
    let counts_at = r.f.pos;
    let counts = r.table("DoF counts per node", n_nodes)?;
    let constraints = r.table("constraint flags", neqn)?;
    // Equation -> DoF, in the file's internal order.
    let mut eq = Vec::with_capacity(neqn);
    for (&node, &c) in node_numbers.iter().zip(&counts) {
        if usize::try_from(c).ok() != Some(numdof) || node <= 0 {
            return Err(r.error(
                counts_at,
                format!("node {node} has {c} DoFs, not the file's {numdof}: nodes with differing DoF sets are not supported"),
            ));
        }
        eq.extend(dof_set.iter().map(|&dir| Dof {
            node: node as u64,
            dir,
        }));
    }
    if eq.len() != neqn {
        return Err(r.error(
            counts_at,
            format!(
                "the nodes carry {} DoFs but the full header has neqn = {neqn}",
                eq.len()
            ),
        ));
    }
    // Sorted order: ascending node number, DoF-set order within a node (stable sort).
    let mut order: Vec<usize> = (0..neqn).collect();
    order.sort_by_key(|&e| eq[e].node);
    if let Some(w) = order
        .windows(numdof + 1)
        .find(|w| eq[w[0]].node == eq[w[numdof]].node)
    {
        return Err(r.error(
            counts_at,
            format!(
                "node {} appears twice in the nodal equivalence table",
                eq[w[0]].node
            ),
        ));
    }
    let mut new_index = vec![usize::MAX; neqn];
    let (mut dofs, mut removed) = (Vec::new(), Vec::new());
    for &e in &order {
        if constraints[e] < 0 {
            removed.push(eq[e]);
        } else {
            new_index[e] = dofs.len();
            dofs.push(eq[e]);
        }
    }
    r.seek_word(ptr_stf, "the stiffness matrix (ptrSTF)")?;
    let stiffness = read_lower(&mut r, neqn, nterm_k, &new_index, "stiffness")?;
    r.seek_word(ptr_mas, "the mass matrix (ptrMAS)")?;
    let mass = read_lower(&mut r, neqn, nterm_m, &new_index, "mass")?;
    let n = dofs.len();
    let mut notes = Vec::new();
    if !removed.is_empty() {
        notes.push(format!(
            "{} constrained DoFs removed (their rows and columns)",
            removed.len()
        ));
    }
    let table = node_table.map(read_node_table).transpose()?;
    let nodes = uniform_nodes(&dofs, numdof, table.as_ref(), node_table, &mut notes)?;
    let title = chars(&std[40..60]);
    let mut producer = format!(
        "ANSYS {release} ({}), jobname {}",
        chars(&std[11..14]),
        chars(&std[14..16])
    );
    if !title.is_empty() {
        producer.push_str(&format!(", title {title}"));
    }
    let unit_names = [
        "user defined",
        "SI",
        "CGS",
        "BFT",
        "BIN",
        "MKS",
        "MPA",
        "uMKS",
    ];
    let mut units = match usize::try_from(std[4]).ok().and_then(|u| unit_names.get(u)) {
        Some(u) => format!("/UNITS {u} (standard header item 5)"),
        None => format!("not recorded (standard header item 5 = {})", std[4]),
    };
    if let Some(u) = table.as_ref().and_then(|t| t.length_unit.as_ref()) {
        units.push_str(&format!("; node table lengths in {u}"));
    }
    let mut files = vec![path.to_path_buf()];
    files.extend(node_table.map(Path::to_path_buf));
    Ok(Imported {
        format: Format::AnsysFull,
        files,
        producer,
        units,
        mass: mass.into_csc(n, true),
        stiffness: stiffness.into_csc(n, true),
        dofs,
        nodes,
        dofs_per_node: numdof,
        removed,
        notes,
    })
}

/// One lower-triangle matrix at the reader's position: per column an index and a value
/// record. Entries in constrained rows or columns (`new_index` = MAX) are dropped.
fn read_lower(
    r: &mut Records,
    neqn: usize,
    nterm: u64,
    new_index: &[usize],
    what: &str,
) -> Result<Triplets> {
    let mut t = Triplets::default();
    let (mut rows, mut vals) = (Vec::new(), Vec::new());
    let mut terms = 0u64;
    let rows_what = format!("{what} row-index");
    let vals_what = format!("{what} value");
    for col in 0..neqn {
        let at = r.ints(&rows_what, &mut rows)?;
        r.reals(&vals_what, &mut vals)?;
        if vals.len() != rows.len() {
            return Err(r.error(
                at,
                format!(
                    "{what} column {}: {} row indices but {} values",
                    col + 1,
                    rows.len(),
                    vals.len()
                ),
            ));
        }
        terms += rows.len() as u64;
        for (&row, &v) in rows.iter().zip(&vals) {
            let i = usize::try_from(row).unwrap_or(0).wrapping_sub(1);
            if i >= neqn || i < col {
                return Err(r.error(
                    at,
                    format!(
                        "{what} column {}: row {row} is outside {}..={neqn} (the lower triangle)",
                        col + 1,
                        col + 1
                    ),
                ));
            }
            if !v.is_finite() {
                return Err(r.error(
                    at,
                    format!("{what} column {}: row {row} holds {v}", col + 1),
                ));
            }
            let (a, b) = (new_index[i], new_index[col]);
            if a != usize::MAX && b != usize::MAX {
                t.push(a, b, v);
            }
        }
    }
    if terms != nterm {
        return Err(r.error(
            r.f.pos,
            format!("the {what} matrix holds {terms} terms but the full header says {nterm}"),
        ));
    }
    Ok(t)
}

/// Reads an APDL Math export: K and M (Matrix Market or Harwell–Boeing), the DoF mapping vector and an optional
/// node table (see the [module documentation](self)).
///
/// # Errors
/// The Matrix Market reader's errors (file:line); [`Error::InvalidModel`] for K and M of
/// different sizes, a mapping vector whose length is not N/3 or N/6, a mapping entry that is not
/// a positive node number or repeats a node, a node of the mapping missing from the table.
pub fn read_apdl_math(
    stiffness: &Path,
    mass: &Path,
    mapping: &Path,
    node_table: Option<&Path>,
) -> Result<Imported> {
    let (k, creator, kind) = exported_matrix(stiffness)?;
    let (m, ..) = exported_matrix(mass)?;
    let n = k.nrows();
    if k.ncols() != n || m.nrows() != n || m.ncols() != n {
        return Err(Error::InvalidModel(format!(
            "mismatched sizes: {} is {}×{} but {} is {}×{}",
            stiffness.display(),
            k.nrows(),
            k.ncols(),
            mass.display(),
            m.nrows(),
            m.ncols()
        )));
    }
    let map = matrix_market::read_dense(mapping)?;
    let len = map.nrows() * map.ncols();
    let dofs_per_node = match len {
        l if l > 0 && 3 * l == n => 3,
        l if l > 0 && 6 * l == n => 6,
        _ => {
            return Err(Error::InvalidModel(format!(
                "{}: the DoF mapping vector has {len} entries but K and M have N = {n} equations: \
                 expected N/3 = {} (one node number per block of 3 DoFs) or N/6 for 6 DoFs per node",
                mapping.display(),
                n as f64 / 3.0
            )))
        }
    };
    let mut seen = std::collections::HashSet::with_capacity(len);
    let mut dofs = Vec::with_capacity(n);
    for b in 0..len {
        let v = map[(b % map.nrows(), b / map.nrows())];
        if !(v >= 1.0 && v.fract() == 0.0 && v < 2f64.powi(53) && seen.insert(v as u64)) {
            return Err(Error::InvalidModel(format!(
                "{}: entry {} of the DoF mapping vector is {v}: need distinct positive node numbers",
                mapping.display(),
                b + 1
            )));
        }
        dofs.extend(Direction::ALL[..dofs_per_node].iter().map(|&dir| Dof {
            node: v as u64,
            dir,
        }));
    }
    let mut notes = Vec::new();
    let table = node_table.map(read_node_table).transpose()?;
    let nodes = uniform_nodes(&dofs, dofs_per_node, table.as_ref(), node_table, &mut notes)?;
    let mut units = format!("not recorded by the {kind} export");
    if let Some(u) = table.as_ref().and_then(|t| t.length_unit.as_ref()) {
        units.push_str(&format!("; node table lengths in {u}"));
    }
    let mut files = vec![
        stiffness.to_path_buf(),
        mass.to_path_buf(),
        mapping.to_path_buf(),
    ];
    files.extend(node_table.map(Path::to_path_buf));
    Ok(Imported {
        format: Format::AnsysApdlMath,
        files,
        producer: format!("{creator} (APDL Math *EXPORT, {kind})"),
        units,
        mass: m,
        stiffness: k,
        dofs,
        nodes,
        dofs_per_node,
        removed: Vec::new(),
        notes,
    })
}

/// An exported K or M, Matrix Market or Harwell–Boeing (told by its header): the matrix, who
/// wrote it (the `% Creator:` comment; the Harwell–Boeing title and key) and the format's name.
fn exported_matrix(path: &Path) -> Result<(crate::sparse::Csc, String, &'static str)> {
    if harwell_boeing::looks_like(&head(path)?) {
        let (h, a) = harwell_boeing::read_with_header(path)?;
        let who = [h.title.as_str(), h.key.as_str()]
            .iter()
            .filter(|s| !s.is_empty())
            .copied()
            .collect::<Vec<_>>()
            .join(" ");
        let who = if who.is_empty() {
            "unknown creator".into()
        } else {
            who
        };
        return Ok((a, who, "Harwell-Boeing"));
    }
    let a = matrix_market::read_sparse(path)?;
    Ok((a, creator(path)?, "Matrix Market"))
}

/// The `% Creator:` comment of a Matrix Market header, or `unknown creator`.
fn creator(path: &Path) -> Result<String> {
    let head = head(path)?;
    Ok(String::from_utf8_lossy(&head)
        .lines()
        .take_while(|l| l.starts_with('%'))
        .find_map(|l| {
            let (_, c) = l.split_once("Creator:")?;
            Some(c.trim().to_string())
        })
        .unwrap_or_else(|| "unknown creator".into()))
}
