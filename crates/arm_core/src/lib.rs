//! # arm_core
//!
//! The physics of eodarm, in pure Rust (no Python): a planar arm of `n` links, each turned
//! by a linear actuator (as in Ștefan et al., *Electronics* 2022, 11, 2355) or by a rotary
//! drive at its joint, in any mix ([`drive`]).
//!
//! * [`kinematics`]: frame transforms (the seed's relation 1), actuator lengths, angles from
//!   lengths and inverse kinematics;
//! * [`statics`]: actuator forces and joint reactions (relations 2–8 for `n` links), of both
//!   states for many poses in [`statics_batch`];
//! * [`effects`]: the catalogue of physical effects (compliance, play, clearance, bending,
//!   base tilt), one module each;
//! * [`pose`]: the loaded pose, closed exactly;
//! * [`solve`]: all of it for many poses at once, in parallel, with per-pose extra
//!   deformations from user-written effects ([`solve_batch_extra`]);
//! * [`solve_sequence`]: load sequences, the states of each loaded and unloaded in order from
//!   one reference, with the friction elements' memory;
//! * [`mod@sweep`]: poses × payloads in bounded memory, with per-group reductions (fast kernel);
//! * [`lanes`]: what the block kernels of `solve` and `sweep` share: a block of poses in
//!   lanes, its trigonometry and its transposes back into rows;
//! * [`compensate`]: the angles to command so that the loaded measure point lands on the
//!   nominal one (Gauss–Newton on the exact model, minimum change for n > 3);
//! * [`sensitivity`]: predicted channels and their derivatives by effect parameter, for fits;
//! * [`fem`]: the numerical model, a frame finite-element model of the same arm solved with
//!   faer's sparse Cholesky, an independent check of all of the above;
//! * [`validity`]: where the small-deflection model can be trusted, a [`Status`] per pose;
//! * [`examples`]: the contract's example arm (`examples/example_arm.toml`), the shared fixture
//!   of tests and benchmarks.
//!
//! Units: mm, N, kg, rad inside (degrees at the batch API). Global frame: x forward, y up,
//! angles counter-clockwise. `docs/model.md` in the repository derives every equation.

pub mod arm;
pub mod compensate;
pub mod drive;
pub mod effects;
pub mod error;
pub mod examples;
pub mod fem;
pub mod geometry;
pub mod kinematics;
pub mod lanes;
pub mod pose;
pub mod sensitivity;
pub mod solve;
pub mod statics;
pub mod sweep;
pub mod validity;

pub use arm::{Actuator, Arm, Link};
pub use compensate::{
    compensate_batch, CompensateBuffers, CompensateOptions, CompensateOutput, CompensateStatus,
    Compensator, JacobianKind,
};
pub use drive::{Drive, RotaryDrive};
pub use effects::ExtraDeformations;
pub use effects::{Effect, EffectSet, Mechanism};
pub use error::{ArmError, Result};
pub use geometry::V2;
pub use solve::sequence::{cycle_returns, solve_sequence, solve_sequence_masses, SequenceInput};
pub use solve::{
    solve_batch, solve_batch_extra, solve_batch_general, solve_batch_masses, solve_batch_status,
    BatchBuffers, BatchInput, BatchOutput, Masses, SolveOptions, Workspace,
};
pub use statics::{statics_batch, StaticsBuffers, StaticsOutput};
pub use sweep::{sweep, CellFields, Cells, Reduce, ReduceOp, SweepOptions, SweepOut};
pub use validity::Status;
