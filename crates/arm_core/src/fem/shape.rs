//! The deformed shape for plots: a fixed list of nodes (stations and pins of every body) and
//! the segments that draw the members between them. Positions are of the undeformed pose;
//! displacements are the payload increment, gaps included.

use crate::arm::Arm;
use crate::geometry::{rot_sc, V2};
use crate::kinematics::Frames;

use super::maps::Maps;
use super::mesh::{Attach, Mesh};

/// A plotted point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Node {
    /// The base tilt point (never moves).
    Pivot,
    /// The chassis point O1 (bore of joint 1).
    O1,
    /// Actuator i's base pin B_{i−1} (B_0 on the chassis).
    BasePin(usize),
    /// Station k of link i (on its axis).
    Station(usize, usize),
    /// Pin A_i.
    A(usize),
    /// The next joint (last link: load point) on link i.
    Next(usize),
    /// Centre of mass of link i.
    C(usize),
    /// The measure point.
    Measure,
}

/// What a segment draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Segment {
    /// A piece of a link's axis (beam element, or the rigid link's axis).
    Axis = 0,
    /// A rigid offset from the axis to a pin.
    Offset = 1,
    /// An actuator, pin to pin.
    Actuator = 2,
    /// The chassis, from its pivot to its pins.
    Chassis = 3,
}

/// Nodes and segments of an arm's mesh.
#[derive(Debug, Clone, Default)]
pub struct Shape {
    /// Every node.
    pub nodes: Vec<Node>,
    /// Node index pairs.
    pub segments: Vec<[usize; 2]>,
    /// What each segment is.
    pub kinds: Vec<Segment>,
}

impl Shape {
    /// The shape of `mesh`.
    pub fn new(mesh: &Mesh) -> Self {
        let n = mesh.links.len();
        let mut s = Self::default();
        let pivot = s.node(Node::Pivot);
        let o1 = s.node(Node::O1);
        s.seg(pivot, o1, Segment::Chassis);
        // Per actuator, its base pin and its pin A (none at a rotary drive).
        let mut base_pins = vec![None; n];
        let mut a_pins = vec![None; n];
        if !mesh.links[0].rotary {
            let b0 = s.node(Node::BasePin(0));
            s.seg(pivot, b0, Segment::Chassis);
            base_pins[0] = Some(b0);
        }
        for (i, lm) in mesh.links.iter().enumerate() {
            let first = s.nodes.len();
            for k in 0..lm.x.len() {
                s.node(Node::Station(i, k));
                if k > 0 {
                    s.seg(first + k - 1, first + k, Segment::Axis);
                }
            }
            let hang = |s: &mut Self, node: Node, at: Attach| {
                let j = s.node(node);
                if at.y != 0.0 {
                    s.seg(first + at.station, j, Segment::Offset);
                }
                j
            };
            if let Some(a) = lm.a {
                a_pins[i] = Some(hang(&mut s, Node::A(i), a));
            }
            hang(&mut s, Node::Next(i), lm.next);
            hang(&mut s, Node::C(i), lm.c);
            if let Some(b) = lm.b {
                base_pins[i + 1] = Some(hang(&mut s, Node::BasePin(i + 1), b));
            }
            if let Some(m) = lm.measure {
                hang(&mut s, Node::Measure, m);
            }
        }
        for (b, a) in base_pins.into_iter().zip(a_pins) {
            if let (Some(b), Some(a)) = (b, a) {
                s.seg(b, a, Segment::Actuator);
            }
        }
        s
    }

    /// Per node, a kind code and its body, for plots: 0 pivot, 1 chassis point O1, 2 base pin
    /// of actuator `body`, 3 axis station, 4 a link's joint station (its pin O_i), 5 pin A,
    /// 6 next joint (last link: load point), 7 centre of mass, 8 measure point; `body` is the
    /// 1-based link (actuator for kind 2), 0 for the chassis. A joint turned by a rotary drive
    /// has no nodes of kinds 2 and 5.
    pub fn codes(&self, mesh: &Mesh) -> Vec<[i64; 2]> {
        let b = |i: usize| i as i64 + 1;
        self.nodes
            .iter()
            .map(|node| match *node {
                Node::Pivot => [0, 0],
                Node::O1 => [1, 0],
                Node::BasePin(i) => [2, b(i)],
                Node::Station(i, k) if k == mesh.links[i].origin => [4, b(i)],
                Node::Station(i, _) => [3, b(i)],
                Node::A(i) => [5, b(i)],
                Node::Next(i) => [6, b(i)],
                Node::C(i) => [7, b(i)],
                Node::Measure => [8, b(mesh.links.len() - 1)],
            })
            .collect()
    }

    fn node(&mut self, n: Node) -> usize {
        self.nodes.push(n);
        self.nodes.len() - 1
    }

    fn seg(&mut self, a: usize, b: usize, k: Segment) {
        self.segments.push([a, b]);
        self.kinds.push(k);
    }

    /// Undeformed position of every node in the pose `fr`.
    pub fn positions(&self, arm: &Arm, mesh: &Mesh, fr: &Frames, out: &mut [V2]) {
        for (o, node) in out.iter_mut().zip(&self.nodes) {
            *o = match *node {
                Node::Pivot => arm.pivot,
                Node::O1 => arm.o1,
                Node::BasePin(i) => fr.b[i],
                Node::Station(i, k) => {
                    fr.joint[i] + rot_sc(fr.sin[i], fr.cos[i], V2::new(mesh.links[i].x[k], 0.0))
                }
                Node::A(i) => fr.a[i],
                Node::Next(i) => fr.joint[i + 1],
                Node::C(i) => fr.c[i],
                Node::Measure => fr.measure,
            };
        }
    }

    /// Displacement of every node for the DOF vector `u` (offsets of `maps` included).
    pub fn displacements(&self, maps: &Maps, u: &[f64], out: &mut [V2]) {
        for (o, node) in out.iter_mut().zip(&self.nodes) {
            *o = match *node {
                Node::Pivot => V2::zeros(),
                Node::O1 => maps.o1.eval(u),
                Node::BasePin(i) => maps.b[i].eval(u),
                Node::Station(i, k) => maps.station[i][k].eval(u),
                Node::A(i) => maps.a[i].eval(u),
                Node::Next(i) => maps.next[i].eval(u),
                Node::C(i) => maps.c[i].eval(u),
                Node::Measure => maps.measure.eval(u),
            };
        }
    }
}
