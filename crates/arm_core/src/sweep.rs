//! Sweeps: every cell of poses × payload masses, in bounded memory, in parallel.
//!
//! A cell is (pose p, mass j), row `r = p·M + j`, payload force `(0, −m_j·g)` at the load
//! point. Each cell gets what [`crate::Workspace::solve`] computes (loaded minus unloaded,
//! exact closure; docs/model.md §2–§5) and a status ([`crate::validity::Status`], docs/model.md
//! §7: out of stroke, near singular, branch flip, over force, large deflection), computed in
//! the same pass. A cell that is not ok (a singular pose or a loaded triangle that cannot
//! close included) is NaN with `ok = false`, never an error. Per pose the sweep also writes
//! the unloaded lengths, a reachability mask and the unloaded load point.
//!
//! * **Two kernels.** The baseline model and the length-only effects (`actuator_compliance`,
//!   `mount_compliance`, `actuator_play`) run through the block kernel of `fast`
//!   ([`L`] poses at once, cheap vectorisable trigonometry, no acos/atan2 in the closure;
//!   arms of up to [`MAX_FAST_LINKS`] links), compiled for AVX-512, AVX2 and baseline x86-64
//!   and picked at run time for the CPU (`pulp`; the same bits on each). The other effects,
//!   and longer arms, run through `Workspace::solve` per cell inside the same chunked,
//!   parallel, reducing machinery.
//! * **Poses.** Either given as rows of angles ([`Poses::Rows`]) or as a regular grid
//!   ([`Poses::Grid`]), whose poses are generated where they are used: block by block in the
//!   block kernel (sines and cosines looked up per axis value), chunk by chunk into the
//!   thread's scratch on the per-cell path. A sweep of 10⁸ poses never holds 10⁸ poses.
//! * **Chunks.** Poses are processed in chunks of about `chunk_rows` rows (default
//!   [`CHUNK_ROWS`]), taken from a queue by the calling thread and `threads − 1` pool
//!   threads; each thread owns its scratch, nothing is allocated per pose. Before any chunk
//!   starts, and before each of its own chunks after its first, the calling thread calls
//!   `cancel(poses_done)` (only there, so a Python signal check and a progress report work;
//!   calling it before the pool threads start means every sweep reports at least once and
//!   honours an interrupt that came early, even when the pool threads take every chunk);
//!   when it returns true the sweep stops and returns [`ArmError::Cancelled`], with the
//!   outputs partly written.
//! * **Reductions.** With [`SweepOptions::reduce`], the cell fields are not stored per cell:
//!   every `group` consecutive rows fold into one output row over the cells that are ok (a
//!   group without one is NaN, its index −1); its status is 0 when every cell is ok, else the
//!   lowest code among those that are not. Per-pose outputs are still written per pose, except
//!   `reachable` when the groups are whole poses and its buffer has one value per group:
//!   then it is "some pose of the group is reachable".
//! * **Mask.** The cells of poses out of stroke are never ok (status `out_of_stroke`), so
//!   [`SweepOptions::mask_unreachable`] changes nothing any more; it is kept for callers.
//!
//! Results do not depend on the chunk size or the number of threads (bit for bit).

mod cells;
mod fallback;
pub(crate) mod fast;
mod reduce;

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

use crate::arm::Arm;
use crate::effects::EffectSet;
use crate::error::{ArmError, Result};
use crate::lanes::transpose::{transpose_into, Shuffles};
use crate::lanes::trig;
use cells::{cut, PoseOut};
pub use cells::{CellFields, Cells, ReduceOp};
pub use fast::L;
use fast::{CellBlock, FastArm, PoseBlock};
use reduce::{fold_op, n_fields, write_group, Acc, Sink, ARGMAX, ARGMIN, MAX, MIN};

/// Default number of rows (cells) per chunk.
pub const CHUNK_ROWS: usize = 16_384;
/// Smallest default chunk (rows) when a small sweep is split between threads.
pub const MIN_CHUNK_ROWS: usize = 512;
/// Longest arm handled by the block kernel; longer arms use the per-cell path.
pub const MAX_FAST_LINKS: usize = 6;

/// Reduce every `group` consecutive rows (cells) with `op`; `group` must divide N·M.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reduce {
    /// The reduction.
    pub op: ReduceOp,
    /// Rows per group (e.g. M to reduce over the payloads of each pose).
    pub group: usize,
}

/// Options of a sweep.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SweepOptions {
    /// Include link and actuator weights in both states.
    pub self_weight: bool,
    /// Reduce the cell fields over groups of rows instead of storing every cell.
    pub reduce: Option<Reduce>,
    /// Threads: `None` uses the calling thread and rayon's global pool (as many threads in
    /// all as the pool has); `Some(k)` the calling thread and a pool of k − 1 threads built
    /// for this call (`Some(1)`: the calling thread alone).
    pub threads: Option<usize>,
    /// Rows per chunk (`None`: [`CHUNK_ROWS`], less for small sweeps so that every thread
    /// gets several chunks); a chunk holds a multiple of [`L`] poses, at least [`L`].
    pub chunk_rows: Option<usize>,
    /// Run the block kernel with baseline x86-64 instructions (SSE2) even where the CPU has
    /// AVX2 or AVX-512; the results are the same bits (the tests check it).
    pub baseline_simd: bool,
    /// Treat the cells of poses that are not reachable (out of stroke) as not solved: NaN,
    /// `ok = false`, skipped by reductions.
    pub mask_unreachable: bool,
}

impl Default for SweepOptions {
    fn default() -> Self {
        Self {
            self_weight: true,
            reduce: None,
            threads: None,
            chunk_rows: None,
            baseline_simd: false,
            mask_unreachable: false,
        }
    }
}

/// Where the poses of a sweep come from.
#[derive(Debug, Clone, Copy)]
pub enum Poses<'a> {
    /// `N × n` unloaded absolute angles (deg), row-major.
    Rows(&'a [f64]),
    /// Poses of a regular grid of angles, generated chunk by chunk (never stored whole).
    Grid(Grid<'a>),
}

/// A regular grid of unloaded absolute angles: the C-order product of one axis per link,
/// outermost first, and of it the flat poses `start .. start + count`.
#[derive(Debug, Clone, Copy)]
pub struct Grid<'a> {
    /// The values (deg) of each grid dimension, outermost first (the last varies fastest).
    pub axes: &'a [&'a [f64]],
    /// The link (0-based) whose angle each dimension sets; every link exactly once.
    pub links: &'a [usize],
    /// First flat pose of the grid to sweep.
    pub start: usize,
    /// Number of poses to sweep.
    pub count: usize,
}

impl Grid<'_> {
    /// Checks the grid against an arm of `n` links; returns the number of poses.
    fn check(&self, n: usize) -> Result<usize> {
        let bad = |msg: String| Err(ArmError::InvalidOption(format!("grid: {msg}")));
        if self.axes.len() != n || self.links.len() != n {
            return bad(format!(
                "{} axes and {} links for an arm of {n} links (one axis per link)",
                self.axes.len(),
                self.links.len()
            ));
        }
        let mut seen = vec![false; n];
        for (d, &i) in self.links.iter().enumerate() {
            if i >= n || seen[i] {
                return bad(format!(
                    "links[{d}] = {i}: every link 0..{n} must be set exactly once"
                ));
            }
            seen[i] = true;
        }
        let mut size: usize = 1;
        for (d, ax) in self.axes.iter().enumerate() {
            if ax.is_empty() {
                return bad(format!("axis {d} is empty"));
            }
            if let Some(k) = ax.iter().position(|v| !v.is_finite()) {
                return bad(format!("axis {d} value {k} is not finite"));
            }
            size = size
                .checked_mul(ax.len())
                .ok_or_else(|| ArmError::InvalidOption("grid: too many poses".into()))?;
        }
        match self.start.checked_add(self.count) {
            Some(end) if end <= size => Ok(self.count),
            _ => bad(format!(
                "poses {} .. {} + {} lie outside the grid's {size} poses",
                self.start, self.start, self.count
            )),
        }
    }

    /// Writes the angles of grid poses `start + p0 .. start + p0 + k` into `buf` (`k × n`).
    fn fill(&self, p0: usize, k: usize, buf: &mut Vec<f64>) {
        let n = self.axes.len();
        buf.clear();
        buf.resize(k * n, 0.0);
        // The multi-index of the first pose, then an odometer: no division per pose.
        let mut idx = vec![0usize; n];
        let mut f = self.start + p0;
        for d in (0..n).rev() {
            idx[d] = f % self.axes[d].len();
            f /= self.axes[d].len();
        }
        for row in buf.chunks_exact_mut(n) {
            for d in 0..n {
                row[self.links[d]] = self.axes[d][idx[d]];
            }
            for d in (0..n).rev() {
                idx[d] += 1;
                if idx[d] < self.axes[d].len() {
                    break;
                }
                idx[d] = 0;
            }
        }
    }
}

/// Output buffers of a sweep, filled in place. `R` is the number of output rows: N·M, or
/// N·M / group when reduced. A per-pose buffer may be empty: it is then not written.
#[derive(Debug)]
pub struct SweepOut<'a> {
    /// Cell fields, `R` rows.
    pub cells: Cells<'a>,
    /// The cell solved and its status ok (reduced: some cell of the group ok), `R`.
    pub ok: &'a mut [bool],
    /// The status code of each cell ([`crate::validity::Status`]; reduced: 0 when every cell
    /// of the group is ok, else the lowest code among those that are not), `R`; may be
    /// empty (not written).
    pub status: &'a mut [u8],
    /// Unloaded pin-to-pin lengths (mm), `N × n` (written also for singular poses).
    pub length_mm: &'a mut [f64],
    /// Not singular and every length within its actuator's stroke limits, `N`; or, with a
    /// reduction over groups of whole poses (`group` a multiple of M, > M), `R` values:
    /// some pose of the group reachable.
    pub reachable: &'a mut [bool],
    /// Unloaded global load point, x (mm), `N`.
    pub effector_x_mm: &'a mut [f64],
    /// Unloaded global load point, y (mm), `N`.
    pub effector_y_mm: &'a mut [f64],
}

/// One chunk's share of the outputs.
struct ChunkOut<'a> {
    /// First pose and number of poses.
    pose0: usize,
    poses: usize,
    /// Output rows `[out0, out0 + len)` that lie wholly in this chunk.
    out0: usize,
    cells: Cells<'a>,
    ok: &'a mut [bool],
    status: &'a mut [u8],
    length: &'a mut [f64],
    reachable: &'a mut [bool],
    ex: &'a mut [f64],
    ey: &'a mut [f64],
}

/// A group that straddles chunks: the accumulators of one chunk's part of it.
struct Partial {
    g: usize,
    vals: Vec<f64>,
    at: Vec<i64>,
    ok: bool,
    status: u8,
    reach: bool,
}

/// What every chunk needs to know.
struct Plan<'a> {
    arm: &'a Arm,
    effects: &'a EffectSet,
    poses: Poses<'a>,
    mass: &'a [f64],
    n: usize,
    self_weight: bool,
    reduce: Option<Reduce>,
    /// Poses per value of `reachable` (> 1: any pose of the group).
    pose_group: usize,
    /// Sines and cosines of a grid's axis values, for the block kernel (else empty).
    axis_trig: Vec<(Vec<f64>, Vec<f64>)>,
    kernel: Kernel,
    /// The instruction set the block kernel runs with.
    simd: pulp::Arch,
}

/// The computation behind the cells (one per sweep: the variants' sizes do not matter).
#[allow(clippy::large_enum_variant)]
enum Kernel {
    F1(FastArm<1>),
    F2(FastArm<2>),
    F3(FastArm<3>),
    F4(FastArm<4>),
    F5(FastArm<5>),
    F6(FastArm<6>),
    /// `Workspace::solve` per cell.
    Exact,
}

impl Kernel {
    fn new(arm: &Arm, effects: &EffectSet, self_weight: bool) -> Self {
        let sw = self_weight;
        let k = match arm.n() {
            1 => FastArm::new(arm, effects, sw).map(Self::F1),
            2 => FastArm::new(arm, effects, sw).map(Self::F2),
            3 => FastArm::new(arm, effects, sw).map(Self::F3),
            4 => FastArm::new(arm, effects, sw).map(Self::F4),
            5 => FastArm::new(arm, effects, sw).map(Self::F5),
            6 => FastArm::new(arm, effects, sw).map(Self::F6),
            _ => None,
        };
        k.unwrap_or(Self::Exact)
    }
}

/// Per-worker scratch space, reused across chunks.
#[derive(Default)]
struct Scratch {
    acc: Acc,
    exact: Option<fallback::Scratch>,
    /// The chunk's angles, for grid sweeps.
    alpha: Vec<f64>,
    /// The chunk's per-pose reachability, when it is reduced per group.
    reach: Vec<bool>,
}

/// Sweeps every pose of `alpha_deg` (`N × n`, degrees) under every payload mass of `mass_kg`
/// (`M`, kg), writing `out` in place: [`sweep_poses`] with [`Poses::Rows`].
///
/// # Errors
/// As [`sweep_poses`].
pub fn sweep(
    arm: &Arm,
    effects: &EffectSet,
    alpha_deg: &[f64],
    mass_kg: &[f64],
    opts: SweepOptions,
    out: SweepOut<'_>,
    cancel: &(dyn Fn(usize) -> bool + Sync),
) -> Result<()> {
    sweep_poses(
        arm,
        effects,
        Poses::Rows(alpha_deg),
        mass_kg,
        opts,
        out,
        cancel,
    )
}

/// Sweeps every pose of `poses` under every payload mass of `mass_kg` (`M`, kg), writing
/// `out` in place; see the [module documentation](self).
///
/// `cancel` is called on the calling thread before any chunk starts and before each of its
/// later chunks, with the number of poses finished so far (by all threads); when it returns
/// true the sweep stops.
///
/// # Errors
/// * [`ArmError::Shape`] for input or output buffers of the wrong length;
/// * [`ArmError::NonFinite`] naming the first pose with a non-finite angle;
/// * [`ArmError::InvalidOption`] for a mass that is negative or not finite, a group that does
///   not divide N·M, zero threads, index buffers where values are due (and the reverse), or
///   a grid that does not fit the arm;
/// * [`ArmError::Cancelled`] when `cancel` returned true.
pub fn sweep_poses(
    arm: &Arm,
    effects: &EffectSet,
    poses_in: Poses<'_>,
    mass_kg: &[f64],
    opts: SweepOptions,
    out: SweepOut<'_>,
    cancel: &(dyn Fn(usize) -> bool + Sync),
) -> Result<()> {
    let n = arm.n();
    let poses = match poses_in {
        Poses::Rows(alpha_deg) => arm.pose_rows(alpha_deg)?,
        Poses::Grid(g) => g.check(n)?,
    };
    let masses = mass_kg.len();
    if let Some((j, m)) = mass_kg
        .iter()
        .enumerate()
        .find(|(_, m)| !(m.is_finite() && **m >= 0.0))
    {
        return Err(ArmError::InvalidOption(format!(
            "mass_kg[{j}] must be finite and >= 0, got {m}"
        )));
    }
    let rows = poses * masses;
    let group = match opts.reduce {
        Some(r) if r.group == 0 || !rows.is_multiple_of(r.group) => {
            return Err(ArmError::InvalidOption(format!(
                "reduce group {} does not divide the {rows} rows (N·M = {poses}·{masses})",
                r.group
            )))
        }
        Some(r) => r.group,
        None => 1,
    };
    // Reachability per group of whole poses: a reduction over groups of whole poses with a
    // `reachable` buffer of one value per group.
    let pose_group = match opts.reduce {
        Some(r)
            if masses > 0
                && r.group.is_multiple_of(masses)
                && r.group > masses
                && out.reachable.len() == rows / r.group =>
        {
            r.group / masses
        }
        _ => 1,
    };
    let want_idx = opts.reduce.is_some_and(|r| r.op.is_arg());
    check_out(&out, n, poses, rows / group, want_idx, pose_group)?;
    let threads = match opts.threads {
        Some(0) => return Err(ArmError::InvalidOption("threads must be >= 1".into())),
        Some(k) => k,
        None => rayon::current_num_threads(),
    };
    let mut plan = Plan {
        arm,
        effects,
        poses: poses_in,
        mass: mass_kg,
        n,
        self_weight: opts.self_weight,
        reduce: opts.reduce,
        pose_group,
        axis_trig: Vec::new(),
        kernel: Kernel::new(arm, effects, opts.self_weight),
        simd: if opts.baseline_simd {
            pulp::Arch::Scalar
        } else {
            pulp::Arch::new()
        },
    };
    if poses == 0 {
        return Ok(());
    }
    if let (Poses::Grid(g), false) = (poses_in, matches!(plan.kernel, Kernel::Exact)) {
        plan.axis_trig = axis_trig(&g);
    }
    let chunk_poses = match opts.chunk_rows {
        Some(rows) => (rows / masses.max(1)) / L * L,
        // Small sweeps: at least eight chunks per thread, of at least MIN_CHUNK_ROWS rows.
        None => {
            (CHUNK_ROWS / masses.max(1))
                .min(
                    poses
                        .div_ceil(8 * threads)
                        .max(MIN_CHUNK_ROWS / masses.max(1)),
                )
                .div_ceil(L)
                * L
        }
    }
    .max(L);
    let (chunks, gaps) = split_out(out, n, poses, masses, group, pose_group, chunk_poses);
    let nchunks = chunks.len();
    let inline = threads <= 1
        || nchunks <= 1
        || (opts.threads.is_none() && rayon::current_thread_index().is_some());
    let mut results: Vec<(usize, Result<Vec<Partial>>)> = Vec::with_capacity(nchunks);
    let mut cancelled = false;
    if inline {
        let mut scratch = Scratch::default();
        let mut finished = 0;
        for (k, chunk) in chunks.into_iter().enumerate() {
            if cancel(finished) {
                cancelled = true;
                break;
            }
            finished += chunk.poses;
            results.push((k, run_chunk(&plan, chunk, &mut scratch)));
        }
    } else {
        let queue = Mutex::new(chunks.into_iter().enumerate());
        let stop = AtomicBool::new(false);
        let done = Mutex::new(Vec::with_capacity(nchunks));
        let finished = AtomicUsize::new(0);
        let shared = Shared {
            plan: &plan,
            queue: &queue,
            stop: &stop,
            done: &done,
            finished: &finished,
        };
        // The calling thread works too: a pool of k − 1 threads for `threads: Some(k)`, and
        // one job fewer than the global pool has threads.
        cancelled = if opts.threads.is_some() {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads - 1)
                .build()
                .map_err(|e| ArmError::InvalidOption(format!("thread pool: {e}")))?;
            pool.in_place_scope(|s| drive(s, threads, shared, cancel))
        } else {
            rayon::in_place_scope(|s| drive(s, threads, shared, cancel))
        };
        results = done.into_inner().unwrap_or_else(|e| e.into_inner());
    }
    if cancelled {
        return Err(ArmError::Cancelled);
    }
    results.sort_by_key(|r| r.0);
    let mut partials = Vec::new();
    for (_, r) in results {
        partials.extend(r?);
    }
    if let Some(red) = opts.reduce {
        merge_partials(red.op, n, partials, gaps);
    }
    Ok(())
}

/// Chunks handed out to worker threads, and their results.
type Queue<'a> = Mutex<std::iter::Enumerate<std::vec::IntoIter<ChunkOut<'a>>>>;
type Done = Mutex<Vec<(usize, Result<Vec<Partial>>)>>;

/// What the workers share.
#[derive(Clone, Copy)]
struct Shared<'e, 'a> {
    plan: &'e Plan<'e>,
    queue: &'e Queue<'a>,
    stop: &'e AtomicBool,
    done: &'e Done,
    /// Poses of the chunks finished so far.
    finished: &'e AtomicUsize,
}

/// Runs the chunks on the calling thread and `threads − 1` workers of the scope's pool; the
/// calling thread calls `cancel` before any worker starts, then before each of its chunks
/// after its first. Returns whether it was cancelled.
fn drive<'e, 'a: 'e>(
    s: &rayon::Scope<'e>,
    threads: usize,
    sh: Shared<'e, 'a>,
    cancel: &(dyn Fn(usize) -> bool + Sync),
) -> bool {
    // Asked before the workers start, not when this thread takes its first chunk: on a busy
    // machine the workers can take every chunk before this thread gets one, and an interrupt
    // that came early went unseen (the sweep ran to the end; a test loop under load saw it).
    if cancel(0) {
        return true;
    }
    let work = move |k: usize, chunk: ChunkOut<'a>, scratch: &mut Scratch| {
        let poses = chunk.poses;
        let r = run_chunk(sh.plan, chunk, scratch);
        lock(sh.done).push((k, r));
        sh.finished.fetch_add(poses, Ordering::Relaxed);
    };
    for _ in 1..threads {
        s.spawn(move |_| {
            let mut scratch = Scratch::default();
            while !sh.stop.load(Ordering::Relaxed) {
                let next = lock(sh.queue).next();
                let Some((k, chunk)) = next else { break };
                work(k, chunk, &mut scratch);
            }
        });
    }
    let mut scratch = Scratch::default();
    let mut asked = true; // for the first chunk, above
    while !sh.stop.load(Ordering::Relaxed) {
        let next = lock(sh.queue).next();
        let Some((k, chunk)) = next else { break };
        if !asked && cancel(sh.finished.load(Ordering::Relaxed)) {
            sh.stop.store(true, Ordering::Relaxed);
            return true;
        }
        asked = false;
        work(k, chunk, &mut scratch);
    }
    false
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

fn check_out(
    out: &SweepOut<'_>,
    n: usize,
    poses: usize,
    rows: usize,
    idx: bool,
    pose_group: usize,
) -> Result<()> {
    let lens = match (&out.cells, idx) {
        (Cells::Values(c), false) => c.lens(n),
        (Cells::Indices(c), true) => c.lens(n),
        (_, want) => {
            return Err(ArmError::InvalidOption(format!(
                "the cell outputs must be {} for this reduction",
                if want { "indices" } else { "values" }
            )))
        }
    };
    for (what, got, width) in lens {
        if got != rows * width {
            return Err(ArmError::Shape {
                what,
                expected: rows * width,
                got,
            });
        }
    }
    let per_pose = [
        ("ok", out.ok.len(), rows, false),
        ("status", out.status.len(), rows, true),
        ("length_mm", out.length_mm.len(), poses * n, true),
        ("reachable", out.reachable.len(), poses / pose_group, true),
        ("effector_x_mm", out.effector_x_mm.len(), poses, true),
        ("effector_y_mm", out.effector_y_mm.len(), poses, true),
    ];
    for (what, got, expected, optional) in per_pose {
        if got != expected && !(optional && got == 0) {
            return Err(ArmError::Shape {
                what,
                expected,
                got,
            });
        }
    }
    Ok(())
}

/// A reduced group that no chunk holds whole: its output slices, written after the merge.
struct Gap<'a> {
    g: usize,
    cells: Cells<'a>,
    ok: &'a mut [bool],
    status: &'a mut [u8],
    /// Its `reachable` value when reachability is per group, else empty.
    reach: &'a mut [bool],
}

/// Splits the outputs into chunks of `chunk_poses` poses; the output rows of groups that
/// straddle two chunks are split off as gaps (at most one group between two chunks).
/// With `pose_group > 1`, `reachable` holds one value per group and is split like `ok`.
fn split_out<'a>(
    out: SweepOut<'a>,
    n: usize,
    poses: usize,
    masses: usize,
    group: usize,
    pose_group: usize,
    chunk_poses: usize,
) -> (Vec<ChunkOut<'a>>, Vec<Gap<'a>>) {
    let grouped = pose_group > 1 && !out.reachable.is_empty();
    let SweepOut {
        mut cells,
        mut ok,
        mut status,
        mut length_mm,
        mut reachable,
        mut effector_x_mm,
        mut effector_y_mm,
    } = out;
    let mut chunks = Vec::with_capacity(poses.div_ceil(chunk_poses));
    let mut gaps = Vec::new();
    let mut pos = 0; // output rows handed out so far
    let mut p0 = 0;
    while p0 < poses {
        let p1 = (p0 + chunk_poses).min(poses);
        let (r0, r1) = (p0 * masses, p1 * masses);
        let s = r0.div_ceil(group);
        let e = (r1 / group).max(s);
        if s > pos {
            // exactly one straddling group
            gaps.push(Gap {
                g: pos,
                cells: cells.split(0, s - pos, n),
                ok: cut(&mut ok, 0, s - pos),
                status: cut(&mut status, 0, s - pos),
                reach: if grouped {
                    cut(&mut reachable, 0, s - pos)
                } else {
                    Default::default()
                },
            });
        }
        let per_pose = |buf: &mut &'a mut [f64], w: usize| {
            if buf.is_empty() {
                Default::default()
            } else {
                cut(buf, 0, (p1 - p0) * w)
            }
        };
        let length = per_pose(&mut length_mm, n);
        let ex = per_pose(&mut effector_x_mm, 1);
        let ey = per_pose(&mut effector_y_mm, 1);
        let reach = if reachable.is_empty() {
            Default::default()
        } else if grouped {
            cut(&mut reachable, 0, e - s)
        } else {
            cut(&mut reachable, 0, p1 - p0)
        };
        chunks.push(ChunkOut {
            pose0: p0,
            poses: p1 - p0,
            out0: s,
            cells: cells.split(0, e - s, n),
            ok: cut(&mut ok, 0, e - s),
            status: cut(&mut status, 0, e - s),
            length,
            reachable: reach,
            ex,
            ey,
        });
        pos = e;
        p0 = p1;
    }
    (chunks, gaps)
}

/// Solves one chunk into its outputs; returns the accumulators of its straddling groups.
fn run_chunk(plan: &Plan<'_>, mut ch: ChunkOut<'_>, scratch: &mut Scratch) -> Result<Vec<Partial>> {
    let n = plan.n;
    let Scratch {
        acc,
        exact,
        alpha: alpha_buf,
        reach: reach_buf,
    } = scratch;
    let alpha: &[f64] = match plan.poses {
        Poses::Rows(all) => {
            let alpha = &all[ch.pose0 * n..(ch.pose0 + ch.poses) * n];
            // A branch-free scan first (vectorised); the position only when something is wrong.
            let finite = alpha.iter().fold(true, |all, v| all & v.is_finite());
            if let Some(bad) = (!finite)
                .then(|| alpha.iter().position(|v| !v.is_finite()))
                .flatten()
            {
                return Err(ArmError::NonFinite {
                    row: ch.pose0 + bad / n,
                    what: "alpha_deg",
                });
            }
            alpha
        }
        // Axes checked finite once, by `Grid::check`. The block kernel makes its poses
        // block by block itself; the per-cell path takes them from a buffer.
        Poses::Grid(g) if matches!(plan.kernel, Kernel::Exact) => {
            g.fill(ch.pose0, ch.poses, alpha_buf);
            alpha_buf
        }
        Poses::Grid(_) => &[],
    };
    let masses = plan.mass.len();
    let (r0, r1) = (ch.pose0 * masses, (ch.pose0 + ch.poses) * masses);
    let nf = n_fields(n);
    let Some(red) = plan.reduce else {
        let Cells::Values(cells) = &mut ch.cells else {
            return Ok(Vec::new()); // excluded by check_out
        };
        let mut sink = Sink::Store {
            row0: r0,
            n,
            cells,
            ok: ch.ok,
            status: ch.status,
        };
        let pose_out = PoseOut {
            length: ch.length,
            reachable: ch.reachable,
            ex: ch.ex,
            ey: ch.ey,
        };
        run_kernel(plan, ch.pose0, ch.poses, alpha, pose_out, &mut sink, exact);
        return Ok(Vec::new());
    };
    // No masses (r0 == r1): no cells, only the per-pose outputs (reachability per pose).
    let groups = (r0 < r1).then(|| (r0 / red.group, (r1 - 1) / red.group));
    if let Some((g0, g1)) = groups {
        acc.reset(g0, g1 - g0 + 1, nf);
    }
    // Reachability per group: per pose into scratch first, folded below.
    // (`pose_group > 1` only with masses and a `reachable` buffer; a chunk inside one group
    // has no slice of it, but its poses still count.)
    let grouped = plan.pose_group > 1;
    {
        let reachable: &mut [bool] = if grouped {
            reach_buf.clear();
            reach_buf.resize(ch.poses, false);
            reach_buf
        } else {
            ch.reachable
        };
        let pose_out = PoseOut {
            length: ch.length,
            reachable,
            ex: ch.ex,
            ey: ch.ey,
        };
        let mut sink = Sink::Reduce {
            group: red.group,
            op: red.op,
            acc,
        };
        run_kernel(plan, ch.pose0, ch.poses, alpha, pose_out, &mut sink, exact);
    }
    let Some((g0, g1)) = groups else {
        return Ok(Vec::new());
    };
    if grouped {
        for (p, &r) in reach_buf.iter().enumerate() {
            acc.reach[(ch.pose0 + p) / plan.pose_group - g0] |= r;
        }
    }
    let interior = ch.out0..ch.out0 + ch.ok.len();
    let mut partials = Vec::new();
    for g in g0..=g1 {
        let gi = g - g0;
        let (vals, at) = (
            &acc.vals[gi * nf..(gi + 1) * nf],
            &acc.at[gi * nf..(gi + 1) * nf],
        );
        if interior.contains(&g) {
            let o = g - ch.out0;
            let done = (acc.ok[gi], acc.status[gi]);
            write_group(&mut ch.cells, ch.ok, ch.status, o, n, vals, at, done);
            if grouped {
                ch.reachable[g - ch.out0] = acc.reach[gi];
            }
        } else {
            partials.push(Partial {
                g,
                vals: vals.to_vec(),
                at: at.to_vec(),
                ok: acc.ok[gi],
                status: acc.status[gi],
                reach: acc.reach[gi],
            });
        }
    }
    Ok(partials)
}

/// Folds the parts of each straddling group and writes it.
fn merge_partials(op: ReduceOp, n: usize, mut partials: Vec<Partial>, gaps: Vec<Gap<'_>>) {
    partials.sort_by_key(|p| p.g);
    let mut parts = partials.into_iter().peekable();
    for mut gap in gaps {
        let nf = n_fields(n);
        let mut vals = vec![f64::NAN; nf];
        let mut at = vec![-1i64; nf];
        let mut ok = false;
        let mut code = 0;
        let mut reach = false;
        while let Some(p) = parts.next_if(|p| p.g <= gap.g) {
            if p.g < gap.g {
                continue;
            }
            ok |= p.ok;
            reduce::fold_status(&mut code, p.status);
            reach |= p.reach;
            for f in 0..nf {
                reduce::fold(op, &mut vals[f], &mut at[f], p.vals[f], p.at[f]);
            }
        }
        write_group(
            &mut gap.cells,
            gap.ok,
            gap.status,
            0,
            n,
            &vals,
            &at,
            (ok, code),
        );
        if let Some(r) = gap.reach.first_mut() {
            *r = reach;
        }
    }
}

/// Solves poses `pose0 .. pose0 + poses`: from `alpha` (their rows), or, when `alpha` is
/// empty and the sweep is over a grid, generated block by block by the block kernel.
fn run_kernel(
    plan: &Plan<'_>,
    pose0: usize,
    poses: usize,
    alpha: &[f64],
    out: PoseOut<'_>,
    sink: &mut Sink<'_, '_>,
    exact: &mut Option<fallback::Scratch>,
) {
    match &plan.kernel {
        Kernel::F1(k) => run_fast(plan.simd, k, plan, pose0, poses, alpha, out, sink),
        Kernel::F2(k) => run_fast(plan.simd, k, plan, pose0, poses, alpha, out, sink),
        Kernel::F3(k) => run_fast(plan.simd, k, plan, pose0, poses, alpha, out, sink),
        Kernel::F4(k) => run_fast(plan.simd, k, plan, pose0, poses, alpha, out, sink),
        Kernel::F5(k) => run_fast(plan.simd, k, plan, pose0, poses, alpha, out, sink),
        Kernel::F6(k) => run_fast(plan.simd, k, plan, pose0, poses, alpha, out, sink),
        Kernel::Exact => {
            let s = exact.get_or_insert_with(|| {
                fallback::Scratch::new(plan.arm, plan.effects, plan.self_weight)
            });
            fallback::run(
                plan.arm,
                plan.effects,
                plan.self_weight,
                plan.mass,
                pose0,
                alpha,
                out,
                sink,
                s,
            );
        }
    }
}

#[allow(clippy::needless_range_loop)] // lanes and links index several arrays in step
#[allow(clippy::too_many_arguments)]
fn run_fast<const N: usize>(
    simd: pulp::Arch,
    k: &FastArm<N>,
    plan: &Plan<'_>,
    pose0: usize,
    poses: usize,
    alpha: &[f64],
    out: PoseOut<'_>,
    sink: &mut Sink<'_, '_>,
) {
    let mass = plan.mass;
    let masses = mass.len();
    let mut pb = PoseBlock::<N>::new();
    let mut cb = CellBlock::<N>::new();
    let mut cursor = match plan.poses {
        Poses::Grid(g) if alpha.is_empty() => GridCursor::<N>::new(&g, &plan.axis_trig, pose0),
        _ => None,
    };
    let (mut sn, mut cs) = ([[0.0; L]; N], [[0.0; L]; N]);
    let mut p = 0;
    while p < poses {
        let count = (poses - p).min(L);
        match &mut cursor {
            Some(c) => {
                c.fill(count, &mut sn, &mut cs);
                k.poses_trig(simd, &sn, &cs, &mut pb);
            }
            None => k.poses(simd, &alpha[p * N..(p + count) * N], count, &mut pb),
        }
        if !out.length.is_empty() {
            transpose_into(
                Shuffles::copies(),
                &pb.len,
                &mut out.length[p * N..(p + count) * N],
            );
        }
        if !out.reachable.is_empty() {
            out.reachable[p..p + count].copy_from_slice(&pb.reachable[..count]);
        }
        if !out.ex.is_empty() {
            out.ex[p..p + count].copy_from_slice(&pb.ex[..count]);
        }
        if !out.ey.is_empty() {
            out.ey[p..p + count].copy_from_slice(&pb.ey[..count]);
        }
        for (j, &m) in mass.iter().enumerate() {
            k.cells(simd, &pb, m, &mut cb);
            // (Cells of poses out of stroke or singular are never ok: `mask_unreachable`
            // has nothing to add here.)
            if let Sink::Store {
                row0,
                cells,
                ok,
                status,
                ..
            } = sink
            {
                cb.nan_failed();
                // Straight from the block into the row-major outputs: rows r0 + q·M.
                let r0 = (pose0 + p) * masses + j - *row0;
                if masses == 1 {
                    let rows = r0..r0 + count;
                    ok[rows.clone()].copy_from_slice(&cb.ok[..count]);
                    if !status.is_empty() {
                        status[rows.clone()].copy_from_slice(&cb.status[..count]);
                    }
                    cells.dx_mm[rows.clone()].copy_from_slice(&cb.dx[..count]);
                    cells.dy_mm[rows].copy_from_slice(&cb.dy[..count]);
                    let span = r0 * N..(r0 + count) * N;
                    transpose_into(
                        Shuffles::copies(),
                        &cb.force,
                        &mut cells.force_n[span.clone()],
                    );
                    transpose_into(
                        Shuffles::copies(),
                        &cb.dalpha,
                        &mut cells.dalpha_deg[span.clone()],
                    );
                    transpose_into(Shuffles::copies(), &cb.dl, &mut cells.dl_mm[span]);
                    continue;
                }
                for q in 0..count {
                    let r = r0 + q * masses;
                    ok[r] = cb.ok[q];
                    if let Some(s) = status.get_mut(r) {
                        *s = cb.status[q];
                    }
                    cells.dx_mm[r] = cb.dx[q];
                    cells.dy_mm[r] = cb.dy[q];
                    for i in 0..N {
                        cells.force_n[r * N + i] = cb.force[i][q];
                        cells.dalpha_deg[r * N + i] = cb.dalpha[i][q];
                        cells.dl_mm[r * N + i] = cb.dl[i][q];
                    }
                }
                continue;
            }
            if let Sink::Reduce { group, op, acc } = sink {
                let row = (pose0 + p) * masses + j;
                let (g, b) = (*group, &cb);
                match op {
                    ReduceOp::Max => fold_block::<N, MAX>(b, count, row, masses, g, acc),
                    ReduceOp::Min => fold_block::<N, MIN>(b, count, row, masses, g, acc),
                    ReduceOp::ArgMax => fold_block::<N, ARGMAX>(b, count, row, masses, g, acc),
                    ReduceOp::ArgMin => fold_block::<N, ARGMIN>(b, count, row, masses, g, acc),
                }
                continue;
            }
        }
        p += count;
    }
}

/// Sines and cosines of every value of every axis of a grid (by [`trig::sincos_deg`], so a
/// lookup gives the same bits as computing them per pose).
fn axis_trig(g: &Grid<'_>) -> Vec<(Vec<f64>, Vec<f64>)> {
    g.axes
        .iter()
        .map(|ax| {
            let (mut sin, mut cos) = (Vec::with_capacity(ax.len()), Vec::with_capacity(ax.len()));
            for part in ax.chunks(L) {
                let mut x = [0.0; L];
                x[..part.len()].copy_from_slice(part);
                let (mut s, mut c) = ([0.0; L], [0.0; L]);
                trig::sincos_deg(&x, &mut s, &mut c);
                sin.extend_from_slice(&s[..part.len()]);
                cos.extend_from_slice(&c[..part.len()]);
            }
            (sin, cos)
        })
        .collect()
}

/// The odometer of a grid sweep in the block kernel: the multi-index of the next pose, and
/// the sine and cosine tables of the axes.
struct GridCursor<'g, const N: usize> {
    sin: [&'g [f64]; N],
    cos: [&'g [f64]; N],
    links: [usize; N],
    idx: [usize; N],
}

impl<'g, const N: usize> GridCursor<'g, N> {
    /// At grid pose `start + p0` (None if the grid is not `N`-dimensional: never, checked).
    fn new(g: &Grid<'g>, trig: &'g [(Vec<f64>, Vec<f64>)], p0: usize) -> Option<Self> {
        if trig.len() != N || g.links.len() != N {
            return None;
        }
        let sin: [&'g [f64]; N] = std::array::from_fn(|d| trig[d].0.as_slice());
        let cos: [&'g [f64]; N] = std::array::from_fn(|d| trig[d].1.as_slice());
        let links: [usize; N] = std::array::from_fn(|d| g.links[d]);
        let mut idx = [0; N];
        let mut f = g.start + p0;
        for d in (0..N).rev() {
            idx[d] = f % sin[d].len();
            f /= sin[d].len();
        }
        Some(Self {
            sin,
            cos,
            links,
            idx,
        })
    }

    /// Writes the sines and cosines of the next `count` poses into lanes `0..count` (the
    /// remaining lanes repeat the last pose) and advances.
    #[inline]
    fn fill(&mut self, count: usize, sn: &mut [[f64; L]; N], cs: &mut [[f64; L]; N]) {
        for q in 0..count {
            for d in 0..N {
                let i = self.links[d];
                sn[i][q] = self.sin[d][self.idx[d]];
                cs[i][q] = self.cos[d][self.idx[d]];
            }
            for d in (0..N).rev() {
                self.idx[d] += 1;
                if self.idx[d] < self.sin[d].len() {
                    break;
                }
                self.idx[d] = 0;
            }
        }
        for i in 0..N {
            for q in count..L {
                sn[i][q] = sn[i][count - 1];
                cs[i][q] = cs[i][count - 1];
            }
        }
    }
}

/// Folds the cells of a block (one mass; lane q at row `row + q·stride`) into `acc`, with the
/// group of each row found without a division per cell.
#[inline(always)]
fn fold_block<const N: usize, const OP: u8>(
    cb: &CellBlock<N>,
    count: usize,
    row: usize,
    stride: usize,
    group: usize,
    acc: &mut Acc,
) {
    let nf = 3 * N + 2;
    let mut g = row / group;
    let mut off = row - g * group;
    for q in 0..count {
        let gi = g - acc.g0;
        reduce::fold_status(&mut acc.status[gi], cb.status[q]);
        if cb.ok[q] {
            acc.ok[gi] = true;
            let vals = &mut acc.vals[gi * nf..(gi + 1) * nf];
            let at = &mut acc.at[gi * nf..(gi + 1) * nf];
            let o = off as i64;
            for i in 0..N {
                fold_op::<OP>(&mut vals[i], &mut at[i], cb.force[i][q], o);
                let f = N + 2 + i;
                fold_op::<OP>(&mut vals[f], &mut at[f], cb.dalpha[i][q], o);
                let f = 2 * N + 2 + i;
                fold_op::<OP>(&mut vals[f], &mut at[f], cb.dl[i][q], o);
            }
            fold_op::<OP>(&mut vals[N], &mut at[N], cb.dx[q], o);
            fold_op::<OP>(&mut vals[N + 1], &mut at[N + 1], cb.dy[q], o);
        }
        off += stride;
        if off >= group {
            g += off / group;
            off %= group;
        }
    }
}
