//! Element stiffness matrices in their local frames.
//!
//! * **Beam** (Euler–Bernoulli, planar frame element) of length h along a link's axis, local
//!   DOFs `(u₁, v₁, θ₁, u₂, v₂, θ₂)`: u axial, v transverse (link frame), θ counter-clockwise.
//! * **Bar** (an actuator): one local DOF, the elongation δ = e·(t_A − t_B) of the pin-to-pin
//!   line, stiffness k (body and mount in series).

/// The 6×6 local stiffness of a beam element, row-major.
///
/// ```
/// use arm_core::fem::element::beam_stiffness;
/// let k = beam_stiffness(2.0e9, 3.0e6, 100.0);
/// // A rigid translation (u = 1 at both ends) costs nothing.
/// let f: f64 = (0..6).map(|j| k[j] * [1.0, 0.0, 0.0, 1.0, 0.0, 0.0][j]).sum();
/// assert!(f.abs() < 1e-6);
/// ```
pub fn beam_stiffness(ei: f64, ea: f64, h: f64) -> [f64; 36] {
    let a = ea / h;
    let b = 12.0 * ei / (h * h * h);
    let c = 6.0 * ei / (h * h);
    let d = 4.0 * ei / h;
    let e = 2.0 * ei / h;
    #[rustfmt::skip]
    let k = [
         a,  0.0, 0.0,  -a,  0.0, 0.0,
        0.0,  b,   c,  0.0,  -b,   c,
        0.0,  c,   d,  0.0,  -c,   e,
        -a,  0.0, 0.0,   a,  0.0, 0.0,
        0.0, -b,  -c,  0.0,   b,  -c,
        0.0,  c,   e,  0.0,  -c,   d,
    ];
    k
}

/// Bending moment at local abscissa `xi ∈ [0, h]` of a beam element from its end forces
/// `f = K·w` (the forces the nodes apply to the element): the moment of the loads beyond the
/// section, `M(x) = V₂·(h − x) + M₂`, so that `EI·v″ = M` (docs/fem.md).
#[inline]
pub fn section_moment(f: &[f64; 6], h: f64, xi: f64) -> f64 {
    f[4] * (h - xi) + f[5]
}
