//! What rank 0 asks the other ranks to do, what they answer, and how the answers of all ranks
//! combine up a binary tree to rank 0 (docs/design.md §9).

use super::cluster::Cluster;
use super::wire::{Reader, Writer};
use crate::lsq::StreamedQr;
use crate::sweep::{FreqStats, Response};
use crate::{Error, Result};
use faer::{c64, Mat};

/// What to keep of the responses a rank absorbs (for absorbing them again into another split).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Keep {
    /// Nothing.
    No,
    /// In memory.
    Memory,
    /// In a temporary file.
    Spill,
}

/// One unit of work. Rank r takes the frequencies k ≡ r (mod ranks).
#[derive(Clone, Debug)]
pub(crate) enum Command {
    /// Solve the elastic response at `freqs`, absorb each block into a streamed QR of the
    /// row split that keeps `interface` (§3.3, [`crate::lsq::Split`]), answer the merged QR
    /// and X at `outputs`.
    Absorb {
        inputs: Vec<usize>,
        outputs: Vec<usize>,
        interface: Vec<usize>,
        freqs: Vec<f64>,
        keep: Keep,
    },
    /// Absorb the kept responses into a fresh QR of the split that keeps `interface`.
    Regrow {
        inputs: usize,
        interface: Vec<usize>,
    },
    /// Solve at `freqs`, answer X at `outputs`.
    Respond {
        response: Response,
        inputs: Vec<usize>,
        outputs: Vec<usize>,
        freqs: Vec<f64>,
    },
    /// The run is over; exit with `code`.
    Stop { code: i32 },
}

/// One rank's (or a subtree's) answer.
#[derive(Default)]
pub(crate) struct Reply {
    /// The merged streamed QR of the absorbed frequencies ([`Command::Absorb`],
    /// [`Command::Regrow`]).
    pub qr: Option<StreamedQr>,
    /// X at the outputs (or all of X), by the frequency's index in the command.
    pub x: Vec<(usize, Mat<c64>)>,
    /// Per-frequency measurements, by index.
    pub stats: Vec<(usize, FreqStats)>,
    /// Seconds spent absorbing, summed over workers and ranks.
    pub absorb_s: f64,
}

impl Reply {
    /// The answer of both parts (TSQR merge of the QR states, §3.3).
    fn combine(mut self, other: Reply) -> Result<Reply> {
        self.qr = match (self.qr, other.qr) {
            (Some(a), Some(b)) => Some(a.merge(b)?),
            (a, b) => a.or(b),
        };
        self.x.extend(other.x);
        self.stats.extend(other.stats);
        self.absorb_s += other.absorb_s;
        Ok(self)
    }

    /// Sorts the per-frequency parts by index.
    pub fn sorted(mut self) -> Reply {
        self.x.sort_by_key(|t| t.0);
        self.stats.sort_by_key(|t| t.0);
        self
    }
}

const ABSORB: u64 = 1;
const REGROW: u64 = 2;
const RESPOND: u64 = 3;
const STOP: u64 = 4;

fn keep_code(k: Keep) -> u64 {
    match k {
        Keep::No => 0,
        Keep::Memory => 1,
        Keep::Spill => 2,
    }
}

impl Command {
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        match self {
            Command::Absorb {
                inputs,
                outputs,
                interface,
                freqs,
                keep,
            } => {
                w.u64(ABSORB)
                    .usizes(inputs)
                    .usizes(outputs)
                    .usizes(interface)
                    .f64s(freqs)
                    .u64(keep_code(*keep));
            }
            Command::Regrow { inputs, interface } => {
                w.u64(REGROW).usize(*inputs).usizes(interface);
            }
            Command::Respond {
                response,
                inputs,
                outputs,
                freqs,
            } => {
                w.u64(RESPOND)
                    .u64(u64::from(*response == Response::Total))
                    .usizes(inputs)
                    .usizes(outputs)
                    .f64s(freqs);
            }
            Command::Stop { code } => {
                w.u64(STOP).u64(*code as u32 as u64);
            }
        }
        w.0
    }

    pub fn decode(bytes: &[u8]) -> Result<Command> {
        let mut r = Reader::new(bytes);
        Ok(match r.u64()? {
            ABSORB => Command::Absorb {
                inputs: r.usizes()?,
                outputs: r.usizes()?,
                interface: r.usizes()?,
                freqs: r.f64s()?,
                keep: match r.u64()? {
                    0 => Keep::No,
                    1 => Keep::Memory,
                    _ => Keep::Spill,
                },
            },
            REGROW => Command::Regrow {
                inputs: r.usize()?,
                interface: r.usizes()?,
            },
            RESPOND => Command::Respond {
                response: if r.u64()? == 1 {
                    Response::Total
                } else {
                    Response::Elastic
                },
                inputs: r.usizes()?,
                outputs: r.usizes()?,
                freqs: r.f64s()?,
            },
            STOP => Command::Stop {
                code: r.u64()? as u32 as i32,
            },
            t => {
                return Err(Error::Distributed(format!(
                    "unknown command {t}: every rank must run the same sparsemor build"
                )))
            }
        })
    }
}

/// An answer (or the error that replaced it) as bytes: a failing rank sends its rank and its
/// error's text, which every later stage passes on unchanged.
fn encode(rank: usize, reply: &Result<Reply>) -> Vec<u8> {
    let mut w = Writer::default();
    let reply = match reply {
        Err(Error::Remote { rank, message }) => {
            w.u64(1).usize(*rank).str(message);
            return w.0;
        }
        Err(e) => {
            w.u64(1).usize(rank).str(&e.to_string());
            return w.0;
        }
        Ok(r) => r,
    };
    w.u64(0);
    match &reply.qr {
        None => {
            w.u64(0);
        }
        Some(qr) => {
            let (r, y, e, rows) = qr.parts();
            w.u64(1).usize(r.nrows()).usize(rows).f64s(y).f64s(e);
            for j in 0..r.ncols() {
                for i in 0..=j {
                    w.f64(r[(i, j)]);
                }
            }
        }
    }
    w.usize(reply.x.len());
    for (k, x) in &reply.x {
        w.usize(*k).c64_mat(x);
    }
    w.usize(reply.stats.len());
    for (k, s) in &reply.stats {
        w.usize(*k)
            .f64(s.freq_hz)
            .f64(s.factor_s)
            .f64(s.solve_s)
            .f64(s.probe_error)
            .f64(s.backward_error)
            .usize(s.refinement_steps)
            .f64(s.pivot_ratio)
            .u64(u64::from(s.pivoted))
            .usize(s.space_dim)
            .f64(s.relative_residual)
            .f64(s.normwise_backward_error)
            .usize(s.space_cost.0)
            .usize(s.space_cost.1);
    }
    w.f64(reply.absorb_s);
    w.0
}

fn decode(bytes: &[u8]) -> Result<Result<Reply>> {
    let mut r = Reader::new(bytes);
    if r.u64()? == 1 {
        let rank = r.usize()?;
        let message = r.str()?;
        return Ok(Err(Error::Remote { rank, message }));
    }
    let qr = match r.u64()? {
        0 => None,
        _ => {
            let (n, rows) = (r.usize()?, r.usize()?);
            let (y, e) = (r.f64s()?, r.f64s()?);
            let mut rm = Mat::<f64>::zeros(n, n);
            for j in 0..n {
                for i in 0..=j {
                    rm[(i, j)] = r.f64()?;
                }
            }
            Some(StreamedQr::from_parts(rm, y, e, rows)?)
        }
    };
    let nx = r.usize()?;
    let mut x = Vec::new();
    for _ in 0..nx {
        x.push((r.usize()?, r.c64_mat()?));
    }
    let ns = r.usize()?;
    let mut stats = Vec::new();
    for _ in 0..ns {
        stats.push((
            r.usize()?,
            FreqStats {
                freq_hz: r.f64()?,
                factor_s: r.f64()?,
                solve_s: r.f64()?,
                probe_error: r.f64()?,
                backward_error: r.f64()?,
                refinement_steps: r.usize()?,
                pivot_ratio: r.f64()?,
                pivoted: r.u64()? == 1,
                space_dim: r.usize()?,
                relative_residual: r.f64()?,
                normwise_backward_error: r.f64()?,
                space_cost: (r.usize()?, r.usize()?),
            },
        ));
    }
    let absorb_s = r.f64()?;
    Ok(Ok(Reply {
        qr,
        x,
        stats,
        absorb_s,
    }))
}

/// Combines every rank's answer up a binomial tree (at step s = 1, 2, 4, …, rank r with
/// r mod 2s = s sends to r − s): ⌈log₂ ranks⌉ stages, each rank sends once. Rank 0 returns
/// the answer of all ranks, or the error of the lowest failing rank; the other ranks return
/// `Ok(None)` after sending. A rank whose own work failed still receives from its children,
/// so no rank waits forever.
pub(crate) fn gather(cluster: &dyn Cluster, mine: Result<Reply>) -> Result<Option<Reply>> {
    let (rank, size) = (cluster.rank(), cluster.size());
    let mut acc = mine;
    let mut step = 1;
    while step < size {
        if rank % (2 * step) == step {
            cluster.send(rank - step, encode(rank, &acc));
            return Ok(None);
        }
        if rank + step < size {
            let theirs = decode(&cluster.receive(rank + step))?;
            acc = match (acc, theirs) {
                (Err(e), _) | (Ok(_), Err(e)) => Err(e),
                (Ok(a), Ok(b)) => a.combine(b),
            };
        }
        step *= 2;
    }
    acc.map(Some)
}
