//! The frequency engine: solves A(iω)X = B at a list of frequencies and hands each block to
//! a consumer known to every rank — absorbed into the streamed QR of a row split
//! ([`crate::lsq::Split`], §3.3), or returned as X at chosen rows — in this process or over the
//! ranks of a [`Cluster`] (docs/design.md §9). Line-fitting, the transfer functions and the
//! sampling loop's verification all call it; it knows none of them.

use super::cluster::Cluster;
use super::protocol::{gather, Command, Keep, Reply};
use crate::body::Body;
use crate::factor::SymbolicStats;
use crate::lsq::{Split, SplitState, StreamedQr};
use crate::shifted_space::Rows;
use crate::snapshots::{GrowBy, SnapshotStore};
use crate::sweep::{
    rows_of, FreqStats, ProgressFn, Response, Schedule, SolveAccuracy, Solver, SweepOptions,
};
use crate::{Error, Result};
use faer::{c64, Mat, MatRef};
use std::sync::Arc;

/// Solves frequencies for one body: in this process, or — when the options carry a
/// [`Cluster`] of more than one rank — on every rank, each taking its share.
pub(crate) struct Engine<'a> {
    body: &'a Body,
    opts: SweepOptions,
    /// The ranks of a distributed run, when there is more than one.
    cluster: Option<Arc<dyn Cluster>>,
    /// This rank's solvers, one per (response, inputs), built on first use.
    solvers: Vec<(Response, Vec<usize>, Solver<'a>)>,
    /// This rank's kept responses (for absorbing them again into another split), and the
    /// inputs of the elastic solver whose Krylov basis their coefficients refer to.
    store: Option<(Vec<usize>, SnapshotStore)>,
    /// Every frequency solved through this engine, on every rank.
    accuracy: SolveAccuracy,
    /// Seconds rank 0 spent receiving and merging the other ranks' answers.
    gather_s: f64,
}

/// What a solved response leaves in the snapshot store.
enum Kept {
    /// Its coefficients c in the solver's Krylov basis Q (X = Q c).
    Span(Mat<c64>),
    /// X itself (a factored frequency).
    Full(Mat<c64>),
}

/// What [`Engine::absorb`] returns.
pub(crate) struct Absorbed {
    /// The streamed QR of every absorbed frequency.
    pub qr: StreamedQr,
    /// X at the outputs, in the order of the frequencies.
    pub h: Vec<Mat<c64>>,
    /// Seconds spent absorbing (summed over workers and ranks).
    pub absorb_s: f64,
}

impl<'a> Engine<'a> {
    /// An engine for `body` with the sweep options of the run, in this process (`cluster`
    /// `None` or of one rank) or over the ranks of `cluster`. On a cluster the ranks of a
    /// machine share its cores and memory: the default thread count and memory budget are
    /// divided by their number.
    pub fn new(body: &'a Body, opts: &SweepOptions, cluster: Option<Arc<dyn Cluster>>) -> Self {
        let mut opts = opts.clone();
        let cluster = cluster.filter(|c| c.size() > 1);
        if let Some(c) = &cluster {
            let node = c.node_size().max(1);
            if opts.memory_budget.is_none() {
                opts.memory_budget = Some(crate::memory::default_budget(2) / node);
            }
            if opts.threads == 0 {
                opts.threads = (crate::pool::resolve_threads(0) / node).max(1);
            }
        }
        Engine {
            body,
            opts,
            cluster,
            solvers: Vec::new(),
            store: None,
            accuracy: SolveAccuracy::default(),
            gather_s: 0.0,
        }
    }

    /// The cluster, when there is more than one rank.
    fn cluster(&self) -> Option<Arc<dyn Cluster>> {
        self.cluster.clone()
    }

    /// Number of ranks the frequencies are spread over.
    pub fn ranks(&self) -> usize {
        self.cluster().map_or(1, |c| c.size())
    }

    /// Seconds rank 0 spent waiting for, receiving and merging the other ranks' answers (0 in
    /// one process).
    pub fn gather_seconds(&self) -> f64 {
        self.gather_s
    }

    /// Frequencies solved at once: this rank's threads times the ranks.
    pub fn concurrency(&self) -> usize {
        self.opts.resolved_threads() * self.ranks()
    }

    /// Whether `response` is answered from a shifted Krylov space (one factorization for
    /// every frequency, docs/design.md §3.10) rather than a factorization per frequency.
    pub fn by_space(&self, response: Response) -> bool {
        crate::sweep::space_applies(self.body, response, &self.opts)
    }

    /// `response` at the rows `outputs` at each of `freqs` from this process's shifted Krylov
    /// space ([`Solver::rows_from_space`], not certified): `None` on a cluster or when no
    /// space answers this response.
    ///
    /// # Errors
    /// The solver's and the space's errors.
    pub fn rows_from_space(
        &mut self,
        response: Response,
        inputs: &[usize],
        outputs: &[usize],
        freqs: &[f64],
    ) -> Result<Option<Arc<Rows>>> {
        if self.ranks() > 1 || !self.by_space(response) {
            return Ok(None);
        }
        let (rows, cost) = self
            .solver(response, inputs)?
            .rows_from_space(freqs, outputs)?;
        self.accuracy.add_space_cost(cost);
        Ok(rows)
    }

    /// The eigenvalues of K − λM below (2π `f_hz`)², rigid ones included, counted by the
    /// factor of this process's shifted Krylov space for `response` to `inputs`, made about
    /// that shift ([`Solver::count_below`]): `None` on a cluster or when no shifted space
    /// answers this response.
    ///
    /// # Errors
    /// The solver's and the factorization's errors.
    pub fn count_below(
        &mut self,
        response: Response,
        inputs: &[usize],
        f_hz: f64,
    ) -> Result<Option<usize>> {
        if self.ranks() > 1 || !self.by_space(response) {
            return Ok(None);
        }
        let Some((below, cost)) = self.solver(response, inputs)?.count_below(f_hz)? else {
            return Ok(None);
        };
        self.accuracy.add_space_cost(cost);
        Ok(Some(below))
    }

    /// Number of ranks on this machine (sharing its memory).
    pub fn node_ranks(&self) -> usize {
        self.cluster().map_or(1, |c| c.node_size().max(1))
    }

    /// The accuracy of every factorization so far, on every rank.
    pub fn accuracy(&self) -> SolveAccuracy {
        let mut a = self.accuracy;
        for (_, _, s) in &self.solvers {
            let place = s.factor_place();
            a.space_disk_written += place.written;
            a.space_disk_read += place.read;
        }
        a
    }

    /// This rank's solver for (response, inputs).
    fn solver(&mut self, response: Response, inputs: &[usize]) -> Result<&Solver<'a>> {
        let i = match self
            .solvers
            .iter()
            .position(|(r, i, _)| *r == response && i == inputs)
        {
            Some(i) => i,
            None => {
                let s = Solver::new(self.body, inputs, response, &self.opts)?;
                self.solvers.push((response, inputs.to_vec(), s));
                self.solvers.len() - 1
            }
        };
        Ok(&self.solvers[i].2)
    }

    /// This rank's symbolic analysis (once the solver of (response, inputs) has factored)
    /// and the schedule of `n_freqs` frequencies, once that solver was used.
    pub fn local_stats(
        &self,
        response: Response,
        inputs: &[usize],
        n_freqs: usize,
    ) -> Option<(Option<SymbolicStats>, Schedule)> {
        let per_rank = n_freqs.div_ceil(self.ranks());
        self.solvers
            .iter()
            .find(|(r, i, _)| *r == response && i == inputs)
            .map(|(_, _, s)| (s.symbolic_stats().cloned(), s.schedule(per_rank)))
    }

    /// Whether this rank's kept snapshots are in a temporary file.
    pub fn spilled(&self) -> bool {
        self.store.as_ref().is_some_and(|s| s.1.spilled())
    }

    /// Runs `cmd` on every rank and returns the combined answer (sorted by frequency index).
    fn execute(&mut self, cmd: Command, progress: ProgressFn<'_>) -> Result<Reply> {
        let reply = match self.cluster() {
            None => self.run_share(&cmd, 0, 1, progress)?,
            Some(c) => {
                c.broadcast(cmd.encode());
                let mine = self.run_share(&cmd, 0, c.size(), progress);
                let t = std::time::Instant::now();
                let all = gather(&*c, mine)?.ok_or_else(|| {
                    Error::Distributed("rank 0 got no answer from the tree".into())
                })?;
                self.gather_s += t.elapsed().as_secs_f64();
                all
            }
        };
        for (_, s) in &reply.stats {
            self.accuracy.add(s);
        }
        Ok(reply.sorted())
    }

    /// Solves the elastic response at `freqs` and absorbs it into the streamed QR of `split`
    /// (eq. 22); keeps the responses on their rank when `keep` says so.
    pub fn absorb(
        &mut self,
        split: &Split,
        inputs: &[usize],
        outputs: &[usize],
        freqs: &[f64],
        keep: Keep,
        progress: ProgressFn<'_>,
    ) -> Result<Absorbed> {
        let cmd = Command::Absorb {
            inputs: inputs.to_vec(),
            outputs: outputs.to_vec(),
            interface: split.interface.clone(),
            freqs: freqs.to_vec(),
            keep,
        };
        let r = self.execute(cmd, progress)?;
        Ok(Absorbed {
            qr: r.qr.unwrap_or_else(|| split.empty_qr()),
            h: r.x.into_iter().map(|t| t.1).collect(),
            absorb_s: r.absorb_s,
        })
    }

    /// The streamed QR of every kept response for `split`.
    pub fn regrow(&mut self, split: &Split, inputs: usize) -> Result<StreamedQr> {
        let cmd = Command::Regrow {
            inputs,
            interface: split.interface.clone(),
        };
        let r = self.execute(cmd, &crate::sweep::no_progress)?;
        Ok(r.qr.unwrap_or_else(|| split.empty_qr()))
    }

    /// The next interface DoFs by Q-DEIM over the kept snapshots, as many as `by` asks (one
    /// process only: the snapshots of a distributed run stay on their ranks).
    pub fn qdeim_next(&mut self, interface: &[usize], by: GrowBy) -> Result<Vec<usize>> {
        self.check_qdeim()?;
        self.with_kept(|store, basis| store.qdeim_next(interface, by, basis))
            .ok_or_else(|| {
                Error::InvalidSetting("the interface may not grow: no snapshots were kept".into())
            })?
    }

    /// Calls `f` with the kept responses and the Krylov basis their coefficients refer to
    /// (`None` when their solver has no space); `None` when nothing is kept.
    fn with_kept<R>(
        &mut self,
        f: impl FnOnce(&mut SnapshotStore, Option<MatRef<'_, f64>>) -> R,
    ) -> Option<R> {
        let (inputs, store) = self.store.as_mut()?;
        let solver = self
            .solvers
            .iter()
            .find(|(r, i, _)| *r == Response::Elastic && i == inputs);
        Some(match solver {
            Some((_, _, s)) => s.with_basis(|basis| f(store, basis)),
            None => f(store, None),
        })
    }

    /// Whether Q-DEIM growth can run: the snapshots must all be in this process.
    pub fn check_qdeim(&self) -> Result<()> {
        if self.ranks() > 1 {
            return Err(Error::InvalidSetting(
                "growth qdeim needs every snapshot in one process; a distributed run keeps them \
                 on their ranks: use growth residual"
                    .into(),
            ));
        }
        Ok(())
    }

    /// X at `outputs` for `response` at `freqs`, in their order, with
    /// the per-frequency measurements.
    pub fn respond(
        &mut self,
        response: Response,
        inputs: &[usize],
        outputs: &[usize],
        freqs: &[f64],
        progress: ProgressFn<'_>,
    ) -> Result<(Vec<Mat<c64>>, Vec<FreqStats>)> {
        let cmd = Command::Respond {
            response,
            inputs: inputs.to_vec(),
            outputs: outputs.to_vec(),
            freqs: freqs.to_vec(),
        };
        let r = self.execute(cmd, progress)?;
        Ok((
            r.x.into_iter().map(|t| t.1).collect(),
            r.stats.into_iter().map(|t| t.1).collect(),
        ))
    }

    /// Carries out `cmd` on this rank's share (frequencies k ≡ rank mod size). Per-frequency
    /// results are keyed by the frequency's index in the command.
    pub(super) fn run_share(
        &mut self,
        cmd: &Command,
        rank: usize,
        size: usize,
        progress: ProgressFn<'_>,
    ) -> Result<Reply> {
        // this rank's frequencies and their indices in the command
        let share = |freqs: &[f64]| -> (Vec<usize>, Vec<f64>) {
            (0..freqs.len())
                .filter(|k| k % size == rank)
                .map(|k| (k, freqs[k]))
                .unzip()
        };
        let keyed = |index: &[usize], stats: Vec<FreqStats>| -> Vec<(usize, FreqStats)> {
            index.iter().copied().zip(stats).collect()
        };
        match cmd {
            Command::Absorb {
                inputs,
                outputs,
                interface,
                freqs,
                keep,
            } => {
                let (index, mine) = share(freqs);
                if mine.is_empty() {
                    return Ok(Reply::default());
                }
                let split = Split::from_interface(self.body.n(), interface.clone());
                let keep_x = *keep != Keep::No;
                if keep_x && self.store.is_none() {
                    let store = SnapshotStore::new(*keep == Keep::Spill)?;
                    self.store = Some((inputs.clone(), store));
                }
                let p = inputs.len();
                // coefficients refer to the basis of the solver the store was made for
                let span_ok = self.store.as_ref().is_some_and(|(i, _)| i == inputs);
                // X at the outputs, and what is kept of X when the snapshots are kept
                type State = (SplitState, Vec<(usize, Mat<c64>, Option<Kept>)>);
                let solver = self.solver(Response::Elastic, inputs)?;
                let (states, stats) = solver.run(
                    &mine,
                    || (split.state(p), Vec::new()),
                    |s: &mut State, snap| {
                        split.absorb(&mut s.0, snap.x)?;
                        let kept = keep_x.then(|| match snap.coefficients {
                            Some(c) if span_ok => Kept::Span(c.to_owned()),
                            _ => Kept::Full(snap.x.to_owned()),
                        });
                        s.1.push((index[snap.index], rows_of(outputs, snap.x), kept));
                        Ok(())
                    },
                    progress,
                )?;
                let (workers, xs): (Vec<SplitState>, Vec<_>) = states.into_iter().unzip();
                let mut xs: Vec<_> = xs.into_iter().flatten().collect();
                xs.sort_by_key(|t| t.0);
                let absorb_s = workers.iter().map(|w| w.absorb_s).sum();
                let qr = Some(Split::merge(workers)?);
                let mut full = Vec::new();
                let mut x = Vec::with_capacity(xs.len());
                for (k, h, kept) in xs {
                    x.push((k, h));
                    match (kept, self.store.as_mut()) {
                        (Some(Kept::Span(c)), Some((_, store))) => store.push_span(c),
                        (Some(Kept::Full(xk)), Some(_)) => full.push(xk),
                        _ => {}
                    }
                }
                if let Some((_, store)) = self.store.as_mut() {
                    store.extend(full.into_iter())?;
                }
                Ok(Reply {
                    qr,
                    x,
                    stats: keyed(&index, stats),
                    absorb_s,
                })
            }
            Command::Regrow { inputs, interface } => {
                let split = Split::from_interface(self.body.n(), interface.clone());
                let t = std::time::Instant::now();
                let qr = self
                    .with_kept(|store, basis| store.regrow(&split, *inputs, basis))
                    .transpose()?
                    .unwrap_or_else(|| split.empty_qr());
                Ok(Reply {
                    absorb_s: t.elapsed().as_secs_f64(),
                    qr: Some(qr),
                    ..Reply::default()
                })
            }
            Command::Respond {
                response,
                inputs,
                outputs,
                freqs,
            } => {
                let (index, mine) = share(freqs);
                if mine.is_empty() {
                    return Ok(Reply::default());
                }
                let solver = self.solver(*response, inputs)?;
                type Acc = Vec<(usize, Mat<c64>)>;
                let (states, stats) = solver.run(
                    &mine,
                    Acc::new,
                    |acc: &mut Acc, snap| {
                        acc.push((index[snap.index], rows_of(outputs, snap.x)));
                        Ok(())
                    },
                    progress,
                )?;
                Ok(Reply {
                    qr: None,
                    x: states.into_iter().flatten().collect(),
                    stats: keyed(&index, stats),
                    absorb_s: 0.0,
                })
            }
            Command::Stop { .. } => Err(Error::Distributed(
                "stop is not a unit of work (it ends serve)".into(),
            )),
        }
    }
}
