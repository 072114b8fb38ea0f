//! # postpro-orient: the 3+2 set-up that makes the machine fastest (paper 004)
//!
//! In 3+2-axis machining the rotary axes are fixed during a path, so the tool tip moves in the
//! part frame by the three linear axes alone, seen through a rotation that the rotary angles
//! choose. Each linear axis has its own velocity, acceleration and jerk limit: the reachable
//! joint set is a **box**, and its image in the part frame a turned box, a kinematic polytope
//! (`../shared/DOMAIN.md` §6). Along a feed direction `d` the largest tangential norm is where
//! `d` leaves the polytope; it is largest at a vertex (5·√3 ≈ 8.7 m/s³ of jerk on the Mikron
//! UCP 710). Choosing the rotary angles so that the feed direction points at a jerk vertex
//! maximises the tangential jerk, the limit that saturates first in a jerk-limited law.
//!
//! - [`polytope`]: the joint boxes of the linear axes ([`JointBoxes`]), the map from linear
//!   joint motion to tip motion in the part frame at given rotary angles, taken from the
//!   forward kinematics ([`JointMap`]), the polytope it gives ([`Polytope`]: the norm along a
//!   direction, the vertices or preferred directions) and the bounds of the best tangential
//!   norm over all set-ups (paper 004 eq. 21, [`bounds`]).
//! - [`candidates`](mod@candidates): the rotary angles that point a part-frame feed direction
//!   at each vertex, every IK branch (8 vertices × 2 branches on a table-table machine, paper
//!   004 appendix A), solved by the generic chain's inverse of a tool axis, kept within the
//!   rotary travels and an admissible cone around a reference tool axis, each checked by the
//!   forward kinematics.
//! - [`paths`]: the paths of a CL program (runs of feed moves between rapids, plunges and
//!   retracts) and their length-weighted feed direction, sign-free (the principal axis of
//!   `Σ Lᵢ dᵢ dᵢᵀ`), per path and for the whole part (paper 004 eqs. 23–24).
//! - [`setup`]: a chosen set-up applied to the CL program (the tool axis replaced, the ball
//!   centre kept).
//!
//! Units are the machine model's: millimetres, radians, seconds (norms in mm/s, mm/s², mm/s³).
//!
//! ```
//! use postpro_orient::{JointBoxes, Level, Options, bounds, candidates};
//! let registry = postpro_machine::Registry::builtin().unwrap();
//! let mikron = &registry.find("mikron").unwrap().machine;
//! let kin = postpro_kin::solver_for(mikron);
//! let boxes = JointBoxes::new(mikron).unwrap();
//! let jerk = bounds(kin.as_ref(), &boxes, Level::Jerk).unwrap();
//! assert!((jerk.upper - 5000.0 * 3f64.sqrt()).abs() < 1e-6); // mm/s³
//! assert!((jerk.lower - 5000.0 * 2f64.sqrt()).abs() < 1e-6);
//! // A horizontal feed along the hyperbolic paraboloid's rulings, tool within 60° of +z.
//! let d = nalgebra::Vector3::new(1.0, 1.0, 0.0);
//! let options = Options { cone_half_angle_deg: 60.0, ..Options::default() };
//! let found = candidates(kin.as_ref(), &boxes, &d, &options).unwrap();
//! assert!(!found.is_empty() && (found[0].jerk - jerk.upper).abs() < 1e-6);
//! ```

pub mod candidates;
pub mod paths;
pub mod polytope;
pub mod setup;

pub use candidates::{Candidate, Options, best_in_cone, candidates, nearest_of_the_best, rotary_distance};
pub use paths::{PartDirection, Path, SplitOptions, part_direction, split};
pub use polytope::{Bounds, JointBoxes, JointMap, Level, Polytope, Vertex, bounds};
pub use setup::{Applied, Setup, apply};

/// Why an orientation cannot be computed. Unreachable directions are not errors: they give no
/// candidate.
#[derive(Clone, Debug, PartialEq, thiserror::Error, miette::Diagnostic)]
pub enum OrientError {
    /// The polytopes need three linear axes.
    #[error("{machine} has {found} linear axes; the kinematic polytopes need three")]
    #[diagnostic(code(orient::linear_axes))]
    LinearAxes {
        /// The machine.
        machine: String,
        /// How many it has.
        found: usize,
    },
    /// An axis limit is not a positive number.
    #[error("axis {axis} of {machine}: its {level} limit {value} is not a positive number")]
    #[diagnostic(code(orient::limit))]
    Limit {
        /// The machine.
        machine: String,
        /// The axis letter.
        axis: String,
        /// `velocity`, `acceleration` or `jerk`.
        level: &'static str,
        /// The value.
        value: f64,
    },
    /// The axis values do not fit the machine.
    #[error("{machine} has {expected} axes, the set-up gives {found} values or a value that is not finite")]
    #[diagnostic(code(orient::joints))]
    Joints {
        /// The machine.
        machine: String,
        /// Axes of the machine.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// The linear axes do not span space in the part frame at these angles.
    #[error("the linear axes of {machine} do not span space at this set-up (forward kinematics)")]
    #[diagnostic(code(orient::singular))]
    Singular {
        /// The machine.
        machine: String,
    },
    /// A feed or reference direction is not a direction.
    #[error("the {what} ({x}, {y}, {z}) is not a direction")]
    #[diagnostic(code(orient::direction), help("give a non-zero, finite vector"))]
    Direction {
        /// Which one.
        what: &'static str,
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z.
        z: f64,
    },
    /// The admissible cone is not a cone.
    #[error("the admissible cone half-angle {0}° is not between 0° and 180°")]
    #[diagnostic(code(orient::cone))]
    Cone(f64),
    /// The forward kinematics disagrees with the inverse (a plugin or closed form that does not
    /// match the machine's chain).
    #[error("the forward kinematics of {machine} misses the vertex its inverse aimed the feed at (off by {error:e})")]
    #[diagnostic(code(orient::inconsistent), help("the machine's solver and its chain definition disagree"))]
    Inconsistent {
        /// The machine.
        machine: String,
        /// |J·v̂ − d|.
        error: f64,
    },
}

/// An angle in (−π, π].
pub(crate) fn wrap(angle: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let w = angle - tau * (angle / tau).round();
    if w <= -std::f64::consts::PI { w + tau } else { w }
}
