//! The numerical model: a planar frame finite-element model of the arm, solved with faer.
//!
//! An independent check of the analytic core (`crate::solve`) and the way to what closed
//! forms cannot do: links with real section properties and several flexible parts at once.
//! Built from the same arm and effects, for any pose:
//!
//! * links: Euler–Bernoulli beam elements along their local x axis ([`mesh`], [`element`]),
//!   pins on rigid offsets; a link without section properties is one rigid body;
//! * actuators: axial bars, body and mount stiffness in series;
//! * rotary drives: torsional springs between the housing (body i−1 at O_i) and the flange
//!   (link i, whose beam is clamped to it) ([`assemble::Kind::Spring`]);
//! * joints: pins with the rotation released (shared translation, one rotation per body),
//!   and the base on a rotational spring about its pivot ([`maps`]);
//! * joint clearance, actuator play and drive backlash: gap elements closed by an active-set
//!   iteration ([`gap`]);
//! * a sparse symmetric positive definite K ([`assemble`]) factorised by faer's sparse
//!   Cholesky, whose symbolic analysis is done once per model and reused by every pose
//!   ([`solve`]).
//!
//! The model is linear: it solves the payload's load increment on the undeformed geometry,
//! `u = K⁻¹·f`, and so agrees with the analytic model's exact pose to first order in the load.
//! `docs/fem.md` in the repository derives every equation and states the sign conventions.
//!
//! ```
//! use arm_core::fem::{FemModel, FemOptions, FemWorkspace};
//! use arm_core::{Actuator, Arm, EffectSet, Link, V2};
//! let link = |next: V2, a: V2, b: V2| Link { next, a, b, c: next * 0.5, mass_kg: 1.0 };
//! let act = Actuator { stiffness: 500.0, mass_kg: 0.5, min_length: None,
//!                      max_length: None, max_force: None };
//! let arm = Arm::new(9.81, V2::zeros(), V2::new(150.0, -60.0), V2::zeros(),
//!     vec![link(V2::new(400.0, 0.0), V2::new(80.0, 40.0), V2::new(-40.0, -40.0)),
//!          link(V2::new(300.0, 0.0), V2::new(60.0, -30.0), V2::zeros())],
//!     vec![act.clone(), act], V2::new(300.0, 0.0)).unwrap();
//! let model = FemModel::new(&arm, &EffectSet::empty(), &[], FemOptions::default()).unwrap();
//! let mut ws = FemWorkspace::new(&model);
//! ws.solve(&model, &[1.2, 0.1], V2::new(0.0, -50.0), true, 0).unwrap();
//! assert!(ws.dmeasure.y < 0.0); // a payload makes the arm sag
//! ```

pub mod assemble;
pub mod batch;
pub mod element;
pub mod forces;
pub mod gap;
pub mod maps;
pub mod mechanism;
pub mod mesh;
pub mod shape;
pub mod solve;
pub mod spec;
pub mod workspace;

use faer::sparse::linalg::cholesky::SymbolicCholesky;

use crate::arm::Arm;
use crate::effects::EffectSet;
use crate::error::{ArmError, Result};
use crate::kinematics::Frames;

pub use assemble::{Assembly, Kind};
pub use batch::{fem_solve_batch, FemBatchBuffers, FemBatchOutput};
pub use maps::Maps;
pub use mesh::Mesh;
pub use shape::{Segment, Shape};
pub use solve::LinearSolver;
pub use spec::{FemSpec, LinkSection};
pub use workspace::FemWorkspace;

/// Options of the FE model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FemOptions {
    /// Beam elements along each flexible link (at least; every pin also gets a node).
    pub elements_per_link: usize,
    /// Sample abscissae per link of the bending-moment diagrams.
    pub moment_samples: usize,
    /// How the linear system is solved.
    pub solver: LinearSolver,
}

impl Default for FemOptions {
    fn default() -> Self {
        Self {
            elements_per_link: 8,
            moment_samples: 101,
            solver: LinearSolver::Sparse,
        }
    }
}

/// A meshed, assembled and symbolically factorised FE model of one arm with its effects:
/// everything that does not depend on the pose. Shared (read-only) by every pose and thread.
#[derive(Debug)]
pub struct FemModel {
    /// The arm.
    pub arm: Arm,
    /// Element properties.
    pub spec: FemSpec,
    /// Stations and DOFs.
    pub mesh: Mesh,
    /// Elements and the sparsity pattern.
    pub asm: Assembly,
    /// The symbolic Cholesky analysis of the pattern, done once (the DOFs are numbered in
    /// its AMD order).
    pub symbolic: SymbolicCholesky<usize>,
    /// Options.
    pub options: FemOptions,
    /// Nodes and segments of the deformed-shape plot.
    pub shape: Shape,
    /// Sample abscissae of the moment diagrams (local x, mm), `n × moment_samples`.
    pub moment_x: Vec<f64>,
    /// Index of each link's first beam element in `asm.elements`.
    pub beam_start: Vec<usize>,
    /// Index of the first bar element.
    pub bar_start: usize,
}

impl FemModel {
    /// Builds the model of `arm` with `effects`; `sections` are the arm file's link sections
    /// (`ei_n_mm2`, `ea_n`; empty: none), `link_bending` overriding EI.
    ///
    /// # Errors
    /// Invalid sections or options ([`ArmError::InvalidArm`], [`ArmError::OutOfRange`],
    /// [`ArmError::Shape`]), a link the FE cannot mesh ([`ArmError::Unsupported`]).
    pub fn new(
        arm: &Arm,
        effects: &EffectSet,
        sections: &[LinkSection],
        options: FemOptions,
    ) -> Result<Self> {
        if options.moment_samples < 2 || options.moment_samples > 100_000 {
            return Err(ArmError::OutOfRange {
                row: 0,
                what: format!(
                    "moment_samples must be in 2..=100000, got {}",
                    options.moment_samples
                ),
            });
        }
        let spec = FemSpec::new(arm, effects, sections)?;
        let mut mesh = Mesh::new(arm, &spec, options.elements_per_link)?;
        // The DOF sets of the maps do not depend on the pose: fill them once for the pattern.
        let n = arm.n();
        let mut fr = Frames::new(n);
        fr.fill(arm, &vec![0.0; n]);
        let offsets = vec![Default::default(); n];
        let mut maps = Maps::new(&mesh);
        maps.fill(arm, &mesh, &fr, &offsets);
        let mut asm = Assembly::new(arm, &mesh, &spec, &maps);
        // Number the DOFs in the fill-reducing order, once: then no pose permutes K.
        let ordered = solve::analyse(&asm, true)?;
        if let Some(perm) = ordered.perm() {
            mesh.renumber(perm.arrays().1);
            maps.fill(arm, &mesh, &fr, &offsets);
            asm = Assembly::new(arm, &mesh, &spec, &maps);
        }
        let symbolic = solve::analyse(&asm, false)?;
        let shape = Shape::new(&mesh);
        let k = options.moment_samples;
        let mut moment_x = Vec::with_capacity(n * k);
        let mut beam_start = Vec::with_capacity(n);
        let mut count = 0;
        for lm in &mesh.links {
            let (lo, hi) = (lm.x[0], lm.x[lm.x.len() - 1]);
            moment_x.extend((0..k).map(|j| lo + (hi - lo) * j as f64 / (k - 1) as f64));
            beam_start.push(count);
            count += lm.elements().count();
        }
        Ok(Self {
            arm: arm.clone(),
            spec,
            mesh,
            asm,
            symbolic,
            options,
            shape,
            moment_x,
            beam_start,
            bar_start: count,
        })
    }

    /// Number of degrees of freedom.
    pub fn n_dof(&self) -> usize {
        self.mesh.n_dof
    }
}
