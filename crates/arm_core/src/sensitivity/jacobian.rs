//! The Jacobian's entry points: check the batch, build its effect sets ([`Sets`]) and run
//! them through the block kernel ([`block`]) or the general path ([`general`]). Above the
//! parameterisation and the sets (`sensitivity.rs`), which its runners share
//! (docs/architecture.md).

use super::{block, general, Place, Sets};
use crate::arm::Arm;
use crate::error::Result;
use crate::solve::fast::Kernel;
use crate::solve::{BatchInput, SolveOptions};

/// Model prediction `y` (N × C) and sensitivities `jac` (N × C × P) for `probes`.
///
/// `model` holds the model's effects with their θ; a probe that is in the model is
/// differentiated at its θ, any other at its neutral θ (the model without it).
/// Channels: dx, dy (mm), dα (deg), dl (mm) as the `dlK_mm` sensor sees it. Row `r`, channel
/// `k`, probe `j` is `jac[(r·C + k)·P + j]`.
///
/// With `opts.nan_on_failure`, a row that cannot be solved for the model or for any of the
/// stepped models gets NaN in all its `y` and `jac` entries.
///
/// # Errors
/// Shape or non-finite input, duplicate or misplaced effects, singular or unreachable poses
/// (naming the lowest failing row).
pub fn jacobian_batch(
    arm: &Arm,
    model: &[(Place, f64)],
    probes: &[Place],
    input: BatchInput<'_>,
    opts: SolveOptions,
    y: &mut [f64],
    jac: &mut [f64],
) -> Result<()> {
    let sets = Sets::new(arm, model, probes, &input, y, jac)?;
    let kernels: Option<Vec<Kernel>> = sets
        .sets
        .iter()
        .map(|s| Kernel::new(arm, s, opts.self_weight))
        .collect();
    match kernels {
        Some(kernels) => block::run(arm, &sets, &kernels, input, opts, y, jac),
        None => general::run(arm, &sets, input, opts, y, jac),
    }
}

/// [`jacobian_batch`] through the general path only ([`crate::solve::Workspace::solve`] pose by
/// pose for every effect set): the reference the block kernel's Jacobian is tested against.
///
/// # Errors
/// As [`jacobian_batch`].
pub fn jacobian_batch_general(
    arm: &Arm,
    model: &[(Place, f64)],
    probes: &[Place],
    input: BatchInput<'_>,
    opts: SolveOptions,
    y: &mut [f64],
    jac: &mut [f64],
) -> Result<()> {
    let sets = Sets::new(arm, model, probes, &input, y, jac)?;
    general::run(arm, &sets, input, opts, y, jac)
}
