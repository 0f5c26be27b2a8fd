//! The ROM's physical DoFs: line-fitting's interface and Craig–Bampton's boundary
//! (docs/design.md §3.3, §3.8): an explicit list, or the outputs plus DoFs spread along the
//! body.

use crate::body::Body;
use crate::{Error, Result};

/// How the interface (line-fitting's ROM DoFs, order n) or the Craig–Bampton boundary is
/// chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum Interface {
    /// These DoFs (must contain every output).
    Explicit(Vec<usize>),
    /// The outputs plus k DoFs spread along the body by [`spread_dofs`].
    OutputsPlus(usize),
    /// The default: the outputs plus ⌈q/2⌉ spread DoFs for q outputs ([`Self::auto_extra`]) —
    /// on the paper bar 9 + 5 = 14, the order of the paper's example.
    Auto,
}

impl Interface {
    /// The number of spread DoFs [`Interface::Auto`] adds to q outputs: ⌈q/2⌉.
    pub fn auto_extra(outputs: usize) -> usize {
        outputs.div_ceil(2)
    }

    /// The DoF list of this setting for the given outputs: the explicit list, or the
    /// outputs followed by the spread DoFs ([`spread_dofs`]). Shared by line-fitting (the
    /// interface) and Craig–Bampton (the boundary); the callers check the list.
    ///
    /// # Errors
    /// As [`spread_dofs`].
    pub fn resolve(&self, body: &Body, outputs: &[usize]) -> Result<Vec<usize>> {
        let extra = match self {
            Interface::Explicit(i) => return Ok(i.clone()),
            Interface::OutputsPlus(k) => *k,
            Interface::Auto => Interface::auto_extra(outputs.len()),
        };
        let mut i = outputs.to_vec();
        i.extend(spread_dofs(body, extra, outputs)?);
        Ok(i)
    }
}

/// `k` DoFs spread uniformly along the body, none of them in `exclude`.
///
/// Rule (with nodes): the long axis a is the longest side of the nodes' bounding box; the
/// targets are the points at fractions (j + ½)/k of its length on the line through the
/// centroid; the node nearest to each target is taken (the lower index on a tie; the next
/// nearest if its DoF is excluded or taken), and its DoF in a direction cycling through the
/// two axes perpendicular to a (bending carries most of a slender body's low-frequency
/// dynamics). Without nodes: DoFs at fractions (j + ½)/k of 0..N.
///
/// # Errors
/// [`Error::InvalidSetting`] when fewer than k DoFs are available.
pub fn spread_dofs(body: &Body, k: usize, exclude: &[usize]) -> Result<Vec<usize>> {
    let n = body.n();
    if k + exclude.len() > n {
        return Err(Error::InvalidSetting(format!(
            "cannot spread {k} extra interface DoFs over a model with N = {n}"
        )));
    }
    let mut taken: Vec<bool> = vec![false; n];
    for &d in exclude {
        taken[d] = true;
    }
    let mut out = Vec::with_capacity(k);
    let Some(nodes) = body.nodes() else {
        for j in 0..k {
            let mut d = ((j as f64 + 0.5) / k as f64 * n as f64) as usize % n;
            while taken[d] {
                d = (d + 1) % n;
            }
            taken[d] = true;
            out.push(d);
        }
        return Ok(out);
    };
    let (mut lo, mut hi, mut c) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], [0.0; 3]);
    for p in nodes {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
            c[a] += p[a] / nodes.len() as f64;
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(2);
    let perp = [(axis + 1) % 3, (axis + 2) % 3];
    let dpn = body.dofs_per_node();
    for j in 0..k {
        let mut target = c;
        target[axis] = lo[axis] + (j as f64 + 0.5) / k as f64 * (hi[axis] - lo[axis]);
        let dir = perp[j % 2];
        let dist = |p: &[f64; 3]| (0..3).map(|a| (p[a] - target[a]).powi(2)).sum::<f64>();
        let best = (0..nodes.len())
            .filter(|&i| !taken[i * dpn + dir])
            .min_by(|&x, &y| dist(&nodes[x]).total_cmp(&dist(&nodes[y])).then(x.cmp(&y)))
            .ok_or_else(|| {
                Error::InvalidSetting("no free DoF left to spread the interface over".into())
            })?;
        taken[best * dpn + dir] = true;
        out.push(best * dpn + dir);
    }
    Ok(out)
}
