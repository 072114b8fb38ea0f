//! The validated machine model. Units: millimetres, radians, seconds. Directions are unit
//! vectors; every position is in the **base frame** (the machine frame in which the linear axes
//! move) with **every axis at zero**. Kinematics sees only these types, never the YAML ones.

use nalgebra::{Isometry3, Point3, Unit, Vector3};

/// A machine: its axes, its kinematic chain, the CNC parameters the prediction uses, and the
/// defaults of the IKT policy.
#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    /// The name users type (`mikron-ucp710`).
    pub name: String,
    /// Other names (`mikron`).
    pub aliases: Vec<String>,
    /// One line for `postpro machines`.
    pub description: String,
    /// The controller dialect of the NC output (`siemens-840d`, `fanuc`, `haas`, `heidenhain`, `linuxcnc`).
    pub dialect: String,
    /// Every axis, in the order the NC program writes them.
    pub axes: Vec<Axis>,
    /// How the axes are stacked between the part and the tool.
    pub chain: Chain,
    /// CNC parameters for the prediction.
    pub cnc: CncParams,
    /// Defaults of the IKT policy (the command line overrides them).
    pub policy: PolicyDefaults,
    /// Which IKT solver to use.
    pub solver: SolverKind,
    /// Where the tool goes to re-orient the rotary axes and around tool changes.
    pub clearance: Clearance,
    /// The program's units unless the set-up or the command line says otherwise.
    pub units: ProgramUnits,
}

/// Where the tool goes to re-orient the rotary axes and around tool changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clearance {
    /// A safe height in machine coordinates: the value (mm) of the linear axis parallel to the
    /// spindle direction ([`Machine::spindle_linear_axis`]), written with the dialect's
    /// machine-frame word (G53, SUPA, M91).
    SafeZ(f64),
    /// A retract by this distance (mm) along the tool axis, from where the tool is.
    Retract(f64),
}

impl std::fmt::Display for Clearance {
    /// As in the definition file: `safe_z: 500 mm` or `retract: 50 mm`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Clearance::SafeZ(z) => write!(f, "safe_z: {} mm", z + 0.0),
            Clearance::Retract(d) => write!(f, "retract: {d} mm"),
        }
    }
}

/// The units an NC program is written in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ProgramUnits {
    /// Millimetres (G21, G71, `MM`).
    #[default]
    Mm,
    /// Inches (G20, G70, `INCH`).
    Inch,
}

impl ProgramUnits {
    /// The text users write: `mm` or `inch`.
    pub fn as_str(self) -> &'static str {
        match self {
            ProgramUnits::Mm => "mm",
            ProgramUnits::Inch => "inch",
        }
    }
}

impl std::fmt::Display for ProgramUnits {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for ProgramUnits {
    type Err = String;

    /// `mm` or `inch`, without case.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            t if t.eq_ignore_ascii_case("mm") => Ok(ProgramUnits::Mm),
            t if t.eq_ignore_ascii_case("inch") => Ok(ProgramUnits::Inch),
            t => Err(format!("unknown units `{t}`: expected `mm` or `inch`")),
        }
    }
}

/// Which IKT solver a machine uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverKind {
    /// The generic serial-chain solver (closed-form rotary angles for any axis directions).
    Generic,
    /// A hand-derived closed form for a known machine.
    ClosedForm(ClosedForm),
    /// The compiled kinematics of the plugin that ships the definition (`solver: plugin`).
    /// Outside a plugin (a YAML file) the generic chain of the definition is used.
    Plugin,
}

/// The machines with a hand-derived closed form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClosedForm {
    /// Mikron UCP 710, CAXYZ (paper 000).
    MikronUcp710,
    /// MAHO 600E, TTTRR (paper 002).
    Maho600e,
}

/// A linear or rotary axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisKind {
    /// Translates (mm).
    Linear,
    /// Rotates (rad).
    Rotary,
}

/// How far an axis may move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Travel {
    /// Between two limits (mm or rad; a rotary range may exceed one turn).
    Limited {
        /// Lower limit.
        min: f64,
        /// Upper limit.
        max: f64,
    },
    /// A rotary axis that turns without limit.
    Endless,
}

impl Travel {
    /// True when `v` is within the travel (with a tolerance of 1e-9).
    pub fn contains(&self, v: f64) -> bool {
        match *self {
            Travel::Limited { min, max } => v >= min - 1e-9 && v <= max + 1e-9,
            Travel::Endless => true,
        }
    }
}

/// One axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The NC address letter (`X`, `A`, `C`).
    pub letter: String,
    /// Linear or rotary.
    pub kind: AxisKind,
    /// Linear: the direction in which the **tool moves relative to the part** when the axis value
    /// grows (ISO 841). Rotary: the axis of rotation; a positive angle turns the carried body
    /// counter-clockwise about it (right-hand rule).
    pub direction: Unit<Vector3<f64>>,
    /// Rotary: a point on the axis line (base frame, all axes at zero). Linear: unused (origin).
    pub center: Point3<f64>,
    /// Travel limits.
    pub travel: Travel,
    /// Home position (mm or rad).
    pub home: f64,
    /// Maximum velocity (mm/s or rad/s).
    pub vmax: f64,
    /// Maximum acceleration (mm/s² or rad/s²).
    pub amax: f64,
    /// Maximum jerk (mm/s³ or rad/s³).
    pub jmax: f64,
    /// Decimals written in the NC program.
    pub decimals: u8,
    /// A rotary axis's brake, when it has one the program must work: locked while the axis
    /// stands for a 3+2 set-up, unlocked before it turns.
    pub clamp: Option<Clamp>,
}

/// The M codes of a rotary axis's brake.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Clamp {
    /// Locks the axis (`M10`).
    pub lock: String,
    /// Unlocks it (`M11`).
    pub unlock: String,
}

/// The kinematic chain. Rotary axes are listed **from the machine base outwards**: for the part
/// side, from the base towards the part; for the tool side, from the base towards the spindle.
#[derive(Clone, Debug, PartialEq)]
pub struct Chain {
    /// The linear axes (indices into `Machine::axes`), 1 to 3 of them.
    pub linear: Vec<usize>,
    /// The rotary axes that carry the part (indices), base first.
    pub part: Vec<usize>,
    /// The rotary axes that carry the tool (indices), base first.
    pub tool: Vec<usize>,
    /// The part (programming) frame at all-zero, in the base frame: the set-up.
    pub part_origin: Isometry3<f64>,
    /// The spindle nose (gauge point) at all-zero, in the base frame.
    pub spindle_nose: Point3<f64>,
    /// The tool axis (tip → spindle) at all-zero, in the base frame.
    pub tool_direction: Unit<Vector3<f64>>,
    /// Tool length from the spindle nose to the tip (mm); the command line may override it.
    pub tool_length: f64,
}

impl Chain {
    /// The tool tip at all-zero, in the base frame.
    pub fn tool_tip(&self) -> Point3<f64> {
        self.spindle_nose - self.tool_direction.into_inner() * self.tool_length
    }
}

/// [`Machine::spindle_linear_axis`], for validation (before the machine exists).
pub(crate) fn spindle_linear_axis(axes: &[Axis], chain: &Chain) -> Option<usize> {
    let parallel = (1e-6f64).cos(); // within 1e-6 rad
    chain.linear.iter().copied().find(|&i| axes[i].direction.dot(&chain.tool_direction).abs() >= parallel)
}

/// What the machine's shape is, for `postpro machines`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Topology {
    /// Three linear axes.
    ThreeAxis,
    /// One rotary axis, on the table.
    FourAxisTable,
    /// One rotary axis, on the head.
    FourAxisHead,
    /// Both rotaries on the table (TTTRR, CAXYZ).
    TableTable,
    /// Both rotaries on the head.
    HeadHead,
    /// One rotary on the table, one on the head.
    HeadTable,
}

impl Machine {
    /// The machine's topology, from its chain.
    pub fn topology(&self) -> Topology {
        match (self.chain.part.len(), self.chain.tool.len()) {
            (0, 0) => Topology::ThreeAxis,
            (1, 0) => Topology::FourAxisTable,
            (0, 1) => Topology::FourAxisHead,
            (2, 0) => Topology::TableTable,
            (0, 2) => Topology::HeadHead,
            _ => Topology::HeadTable,
        }
    }

    /// The index of the axis with this letter.
    pub fn axis_index(&self, letter: &str) -> Option<usize> {
        self.axes.iter().position(|a| a.letter.eq_ignore_ascii_case(letter))
    }

    /// The linear axis parallel (or antiparallel) to the spindle direction at all-zero: the axis
    /// of [`Clearance::SafeZ`] (index into `axes`), if there is one.
    pub fn spindle_linear_axis(&self) -> Option<usize> {
        spindle_linear_axis(&self.axes, &self.chain)
    }
}

impl Topology {
    /// A short label: `3-axis`, `4-axis (table)`, `table-table`, …
    pub fn label(self) -> &'static str {
        match self {
            Topology::ThreeAxis => "3-axis",
            Topology::FourAxisTable => "4-axis (table)",
            Topology::FourAxisHead => "4-axis (head)",
            Topology::TableTable => "5-axis table-table",
            Topology::HeadHead => "5-axis head-head",
            Topology::HeadTable => "5-axis head-table",
        }
    }
}

/// CNC parameters used by the prediction.
#[derive(Clone, Debug, PartialEq)]
pub struct CncParams {
    /// Interpolation cycle time (s).
    pub cycle_time: f64,
    /// Blocks beyond the current one the CNC plans with (its look-ahead).
    pub look_ahead: usize,
    /// Contour tolerance for corner rounding (mm).
    pub contour_tolerance: f64,
    /// Share of the acceleration given to curvature (Siemens `CURV_EFFECT_ON_PATH_ACCEL`), 0…1.
    pub curvature_accel_share: f64,
    /// Tangential (path) acceleration limit (mm/s²), if the CNC has one.
    pub tangential_accel: Option<f64>,
    /// Tangential (path) jerk limit (mm/s³), if the CNC has one.
    pub tangential_jerk: Option<f64>,
    /// Smallest programmable feed (mm/min).
    pub feed_min: f64,
    /// Largest programmable feed (mm/min).
    pub feed_max: f64,
    /// The spindle's largest speed (rpm), when the definition gives it.
    pub spindle_max: Option<f64>,
}

/// Defaults of the IKT policy.
#[derive(Clone, Debug, PartialEq)]
pub struct PolicyDefaults {
    /// Which branch to prefer.
    pub branch: BranchPreference,
    /// Whole-path (dynamic programming) or greedy choice.
    pub choice: PathChoice,
    /// Half-angle of the cone around the primary rotary axis inside which the pose is treated as
    /// singular (rad).
    pub singular_cone: f64,
    /// Within this angle of the pole (rad, at least the singular cone), a branch change between
    /// two feed points whose tool axes pass it is a pole passage, not a discontinuity: the axes
    /// pass the pole continuously (a tilt axis through zero).
    pub pole_passage: f64,
    /// A rotary step between two consecutive feed points larger than this (rad) is reported as
    /// a warning; it is still motion (only a branch change away from the pole or a travel limit
    /// is a discontinuity).
    pub max_rotary_step: f64,
    /// What to do at a discontinuity.
    pub on_discontinuity: OnDiscontinuity,
    /// Largest deviation of the tool tip from the programmed segment (mm).
    pub linearization_tolerance: f64,
    /// Turns an endless rotary axis may wind from its home position before it is unwound at the
    /// next rapid (the equivalent angle nearest home is taken there); `None`: never unwound.
    /// A number of turns, not an angle.
    pub unwind: Option<f64>,
    /// A feed move before any feed is programmed: an error, or a rapid with a warning.
    pub missing_feed: MissingFeed,
}

/// What a feed move with no feed programmed before it becomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MissingFeed {
    /// An error naming the CL line: nothing is written.
    #[default]
    Error,
    /// A rapid, with a warning naming the line.
    Rapid,
}

/// Which IKT branch to prefer.
#[derive(Clone, Debug, PartialEq)]
pub enum BranchPreference {
    /// The solution closest to the previous point (in rotary travel).
    Closest,
    /// Solutions where the named rotary axis is ≥ 0.
    Positive(String),
    /// Solutions where the named rotary axis is ≤ 0.
    Negative(String),
}

/// How the branch sequence is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathChoice {
    /// Dynamic programming over the whole path: least rotary travel and fewest switches.
    WholePath,
    /// Point by point.
    Greedy,
}

/// What to do where no continuous feasible sequence exists.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OnDiscontinuity {
    /// Stop with an error naming the CL line.
    Error,
    /// Retract along the tool axis by `clearance` (mm), reorient, re-engage.
    Retract {
        /// Retract distance (mm).
        clearance: f64,
    },
}
