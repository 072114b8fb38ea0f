//! A small model of an NC program as a machine runs it: the motions in the work frame (rapid,
//! straight feed, circular or helical arc) with their end points, rotary values and feeds, and
//! the events between them (tool changes, offsets, machine-frame moves, holes, dwells).
//!
//! Every reader of the harness ([`crate::rs274`], [`crate::golden`]) produces a [`Program`];
//! the comparators ([`crate::compare`]) read them. Positions are in the program's
//! [`Units`]; rotary values in degrees; feeds in program units per minute.

mod geometry;

/// A program's length unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Units {
    /// Millimetres (G21, `BEGIN PGM … MM`).
    Mm,
    /// Inches (G20, `BEGIN PGM … INCH`).
    Inch,
}

impl Units {
    /// Millimetres per unit.
    pub fn to_mm(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::Inch => 25.4,
        }
    }

    /// The factor that turns a length in `self` into one in `to`.
    pub fn factor(self, to: Units) -> f64 {
        self.to_mm() / to.to_mm()
    }
}

/// The plane of an arc, named as RS274 selects it (G17, G18, G19).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    /// G17: the arc turns about Z.
    Xy,
    /// G18: the arc turns about Y (from Z towards X when counter-clockwise).
    Zx,
    /// G19: the arc turns about X (from Y towards Z when counter-clockwise).
    Yz,
}

impl Plane {
    /// The indices (0 = X, 1 = Y, 2 = Z) of the plane's first and second axes and of its
    /// normal, ordered so that first × second = normal: XY → (X, Y, Z), ZX → (Z, X, Y),
    /// YZ → (Y, Z, X). Counter-clockwise in (first, second) is counter-clockwise about the
    /// normal.
    pub fn axes(self) -> [usize; 3] {
        match self {
            Plane::Xy => [0, 1, 2],
            Plane::Zx => [2, 0, 1],
            Plane::Yz => [1, 2, 0],
        }
    }
}

/// A circular or helical arc: the geometry a G2/G3 block, LinuxCNC's `ARC_FEED` or a
/// Heidenhain `C`/`CP` block gives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arc {
    /// The centre. Its coordinate along the plane's normal is the start point's: a helix rises
    /// from there to the end point.
    pub center: [f64; 3],
    /// The plane the arc turns in.
    pub plane: Plane,
    /// Clockwise seen from the positive end of the plane's normal (Z for XY, Y for ZX, X for
    /// YZ): G2 in G17, G18 and G19 (checked with LinuxCNC's rs274), Heidenhain `DR-`.
    pub clockwise: bool,
    /// Full turns on top of the sweep from start to end: 0 for an ordinary arc, whose sweep is
    /// in (0, 360°] (360° when start and end coincide in the plane). LinuxCNC's `P` minus 1,
    /// Siemens `TURN`.
    pub full_turns: u32,
}

/// How a motion moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MotionKind {
    /// At rapid traverse, straight (G0, `FMAX`, `STRAIGHT_TRAVERSE`).
    Rapid,
    /// Straight at the programmed feed (G1, `L … F`, `STRAIGHT_FEED`).
    Feed,
    /// Along an arc at the programmed feed.
    Arc(Arc),
}

/// The rotary axes' values at a motion's end, degrees; `None` where the program has not set
/// that axis (or has no such axis).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rotary {
    /// A.
    pub a: Option<f64>,
    /// B.
    pub b: Option<f64>,
    /// C.
    pub c: Option<f64>,
}

impl Rotary {
    /// The value of the axis named by `letter` (`A`, `B` or `C`, either case).
    pub fn get(&self, letter: char) -> Option<f64> {
        match letter.to_ascii_uppercase() {
            'A' => self.a,
            'B' => self.b,
            'C' => self.c,
            _ => None,
        }
    }

    /// Sets the axis named by `letter`; false when `letter` names no rotary axis.
    pub fn set(&mut self, letter: char, value: f64) -> bool {
        let slot = match letter.to_ascii_uppercase() {
            'A' => &mut self.a,
            'B' => &mut self.b,
            'C' => &mut self.c,
            _ => return false,
        };
        *slot = Some(value);
        true
    }
}

/// One motion block (or one of the moves a canned cycle expands into).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Rapid, feed or arc.
    pub kind: MotionKind,
    /// The start point (X, Y, Z) in the work frame.
    pub from: [f64; 3],
    /// False for a rapid out of a position the program leaves unknown in the work frame (the
    /// first positioning after a machine-frame move such as G53, G28 or M91): along the axes
    /// not known, `from` is `to`. Feed moves and arcs always start from a known point.
    pub from_known: bool,
    /// The end point (X, Y, Z) in the work frame.
    pub to: [f64; 3],
    /// The rotary axes at the end.
    pub rotary: Rotary,
    /// The tool vector in force at the end, where the program gives the orientation as one
    /// (Fanuc `G43.5` I J K, Heidenhain `LN` TX TY TZ, Siemens `ORIVECT` A3 B3 C3), as written
    /// (not normalised); `None` where it does not (the rotary axes orient the tool).
    pub vector: Option<[f64; 3]>,
    /// The feed, program units per minute (LinuxCNC's inverse-time feeds as the rate it
    /// computes); `None` for rapids.
    pub feed: Option<f64>,
    /// The 1-based program line of the block.
    pub line: usize,
}

impl Motion {
    /// True for straight feeds and arcs: the motions that cut.
    pub fn is_feed(&self) -> bool {
        !matches!(self.kind, MotionKind::Rapid)
    }

    /// The arc, when the motion is one.
    pub fn arc(&self) -> Option<&Arc> {
        match &self.kind {
            MotionKind::Arc(arc) => Some(arc),
            _ => None,
        }
    }

    /// The length of the tool tip's path (X, Y, Z): straight, or along the arc (helix and full
    /// turns included).
    pub fn length(&self) -> f64 {
        match &self.kind {
            MotionKind::Arc(arc) => geometry::ArcPath::new(self, arc).length(),
            _ => geometry::distance(self.from, self.to),
        }
    }

    /// The point at fraction `t` ∈ [0, 1] of the motion (of the sweep, for an arc).
    pub fn point_at(&self, t: f64) -> [f64; 3] {
        match &self.kind {
            MotionKind::Arc(arc) => geometry::ArcPath::new(self, arc).point_at(t),
            _ => geometry::lerp(self.from, self.to, t),
        }
    }

    /// The shortest distance from `p` to the motion's path (exact for arcs: closed form for
    /// planar circular arcs, a bracketed minimisation to 1e-12 of the sweep for helices and
    /// spirals).
    pub fn distance_to_point(&self, p: [f64; 3]) -> f64 {
        match &self.kind {
            MotionKind::Arc(arc) => geometry::ArcPath::new(self, arc).distance_to_point(p),
            _ => geometry::segment_distance(self.from, self.to, p),
        }
    }

    /// The swept angle of an arc in radians (positive, full turns included); `None` for a
    /// straight motion.
    pub fn sweep(&self) -> Option<f64> {
        self.arc().map(|arc| geometry::ArcPath::new(self, arc).sweep())
    }

    /// The motion with every length multiplied by `factor` (a change of units).
    pub(crate) fn scaled(mut self, factor: f64) -> Motion {
        self.from = self.from.map(|v| v * factor);
        self.to = self.to.map(|v| v * factor);
        self.feed = self.feed.map(|f| f * factor);
        if let MotionKind::Arc(arc) = &mut self.kind {
            arc.center = arc.center.map(|v| v * factor);
        }
        self
    }
}

/// Something a program does between motions.
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    /// The 1-based program line (0: the interpreter's own set-up or reset).
    pub line: usize,
    /// The index in [`Program::motions`] of the first motion after the event.
    pub before: usize,
    /// What happened.
    pub kind: EventKind,
}

impl Event {
    /// The event with every length multiplied by `factor` (a change of units).
    pub(crate) fn scaled(&self, factor: f64) -> Event {
        let scale = |v: f64| v * factor;
        let kind = match &self.kind {
            EventKind::ToolDefinition { tool, length, radius } => {
                EventKind::ToolDefinition { tool: *tool, length: length.map(scale), radius: radius.map(scale) }
            }
            EventKind::LengthOffset { register, offset } => {
                EventKind::LengthOffset { register: *register, offset: offset.map(|o| o.map(scale)) }
            }
            EventKind::WorkOffset { name, offset } => {
                EventKind::WorkOffset { name: name.clone(), offset: offset.map(|o| o.map(|v| v.map(scale))) }
            }
            EventKind::Positioning { rapid, to } => {
                EventKind::Positioning { rapid: *rapid, to: to.map(|v| v.map(scale)) }
            }
            EventKind::Hole { cycle, at, bottom } => {
                EventKind::Hole { cycle: cycle.clone(), at: at.map(scale), bottom: scale(*bottom) }
            }
            EventKind::WorkingPlane { code, frame } => EventKind::WorkingPlane {
                code: code.clone(),
                frame: frame.map(|f| Frame { origin: f.origin.map(scale), axes: f.axes }),
            },
            other => other.clone(),
        };
        Event { line: self.line, before: self.before, kind }
    }
}

/// What an [`Event`] is.
#[derive(Clone, Debug, PartialEq)]
pub enum EventKind {
    /// The arc plane changed (G17/G18/G19, `SELECT_PLANE`).
    Plane(Plane),
    /// A tool change (`M6`, `CHANGE_TOOL`, `TOOL CALL`).
    ToolChange {
        /// The tool number.
        tool: u32,
    },
    /// A tool's geometry defined in the program (Heidenhain `TOOL DEF`).
    ToolDefinition {
        /// The tool number.
        tool: u32,
        /// Its length (or length delta), program units.
        length: Option<f64>,
        /// Its radius, program units.
        radius: Option<f64>,
    },
    /// A tool length offset applied: the register (G43 H) and, where the interpreter says, the
    /// offset itself (rs274's `USE_TOOL_LENGTH_OFFSET`: X, Y, Z, program units). An offset of
    /// zero is a cancel (G49).
    LengthOffset {
        /// The H register, when the program names one.
        register: Option<u32>,
        /// The offset, when known.
        offset: Option<[f64; 3]>,
    },
    /// Tool centre point control on or off (Haas G234 H / G49, Heidenhain `M128`/`M129`,
    /// `FUNCTION TCPM`).
    Tcp {
        /// On or off.
        on: bool,
    },
    /// A work offset selected or a datum shifted: its name (`G54`, `G54.1 P3`, `G5X 1`,
    /// `G92`, `CYCL DEF 7`) and, where the program says, its value (X, Y, Z; `None` per axis
    /// where not known).
    WorkOffset {
        /// The name.
        name: String,
        /// The offset, when given.
        offset: Option<[Option<f64>; 3]>,
    },
    /// A move in the machine frame (G53, G28, G30, M91, M92), not a motion in the work frame:
    /// after it, the axes it moved are unknown in the work frame until programmed again.
    MachineFrameMove {
        /// The code (`G53`, `G28`, `M91`…).
        code: String,
        /// The axes it moved.
        axes: Vec<char>,
    },
    /// A move in the work frame whose end is not fully known (it leaves an axis where a
    /// machine-frame move put it), or a feed from a start not fully known (a probing move from
    /// where the operator left the tool): where it goes, as far as known.
    Positioning {
        /// At rapid traverse or at the feed.
        rapid: bool,
        /// X, Y, Z where known.
        to: [Option<f64>; 3],
    },
    /// A block whose position the parser cannot know (coordinates from Q parameters or
    /// machine data, Heidenhain probing), with its text: the axes it moved become unknown.
    Unresolved {
        /// The block.
        text: String,
    },
    /// A canned-cycle hole (its moves are expanded into [`Program::motions`]): the hole's
    /// position with the cycle's start height (R plane or set-up clearance) and the bottom.
    Hole {
        /// The cycle (`G81`, `CYCL DEF 200`…).
        cycle: String,
        /// X, Y and the start height (Z).
        at: [f64; 3],
        /// The Z of the bottom of the hole.
        bottom: f64,
    },
    /// A dwell, seconds (as written: Fanuc/Haas `P` units are the controller's).
    Dwell {
        /// The time.
        seconds: f64,
    },
    /// A working plane comes into force (`frame`: Fanuc `G68.2`, Siemens `CYCLE800(…)`,
    /// Heidenhain `PLANE VECTOR`), or is reset (`None`: `G69`, `CYCLE800()`, `PLANE RESET`): the
    /// coordinates that follow are the plane's. The position is not known in the new frame
    /// until programmed again (the machine's kinematics relate the two).
    WorkingPlane {
        /// The command (`G68.2`, `G69`, `CYCLE800`, `PLANE VECTOR`, `PLANE RESET`).
        code: String,
        /// The plane in the frame before it, or `None` for a reset.
        frame: Option<Frame>,
    },
    /// The controller turns the rotary axes so that the tool lies along the working plane's z
    /// (Fanuc `G53.1`, Siemens `CYCLE800` with a direction, Heidenhain `PLANE … MOVE|TURN`): the
    /// rotary values it chooses are the machine's; the readers keep those written before.
    ToolAxisToPlane {
        /// The command.
        code: String,
    },
    /// The feed mode changed (LinuxCNC's `feed mode set to …` comment): true for inverse time.
    InverseTime(bool),
    /// A program stop (M0, `STOP`), or an optional one (M1).
    Stop {
        /// M1.
        optional: bool,
    },
    /// The program ended (M2, M30, `END PGM`, `PROGRAM_END`).
    End,
}

/// A working plane's frame: its origin and its x, y and z axes (unit vectors, right-handed) in
/// the frame before it. A point `p` of the plane is `origin + p[0]·x + p[1]·y + p[2]·z` there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// The plane's zero in the frame before it.
    pub origin: [f64; 3],
    /// The plane's x, y and z axes in the frame before it.
    pub axes: [[f64; 3]; 3],
}

impl Frame {
    /// The frame turned by Euler angles in degrees about Z, then the new X, then the new Z
    /// (Fanuc `G68.2 X Y Z I J K`): the rotation Rz(I)·Rx(J)·Rz(K).
    pub fn euler_zxz(origin: [f64; 3], degrees: [f64; 3]) -> Frame {
        Frame::rotated(origin, &[(2, degrees[0]), (0, degrees[1]), (2, degrees[2])])
    }

    /// The frame turned axis by axis by angles in degrees about X, then the new Y, then the new Z
    /// (Siemens `CYCLE800` in mode 57, its `_A _B _C`): the rotation Rx(A)·Ry(B)·Rz(C).
    pub fn euler_xyz(origin: [f64; 3], degrees: [f64; 3]) -> Frame {
        Frame::rotated(origin, &[(0, degrees[0]), (1, degrees[1]), (2, degrees[2])])
    }

    /// The frame of a base vector (its x) and a normal vector (its z), as Heidenhain's `PLANE
    /// VECTOR BX BY BZ NX NY NZ` defines it: both normalised, y = z × x. An error when either is
    /// zero or they are not perpendicular (to 1e-6 after normalising).
    pub fn from_vectors(origin: [f64; 3], base: [f64; 3], normal: [f64; 3]) -> Result<Frame, String> {
        let unit = |v: [f64; 3], what: &str| {
            let n = dot(v, v).sqrt();
            if n < 1e-9 { Err(format!("the {what} vector is zero")) } else { Ok(v.map(|c| c / n)) }
        };
        let (x, z) = (unit(base, "base")?, unit(normal, "normal")?);
        if dot(x, z).abs() > 1e-6 {
            return Err(format!(
                "the base vector is not perpendicular to the normal vector (cosine {:.2e})",
                dot(x, z)
            ));
        }
        Ok(Frame { origin, axes: [x, cross(z, x), z] })
    }

    /// `axes` rotations (axis index 0 = X, 1 = Y, 2 = Z; degrees), each about the frame's axis
    /// as turned by those before it.
    fn rotated(origin: [f64; 3], turns: &[(usize, f64)]) -> Frame {
        let mut axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for &(k, degrees) in turns {
            let (s, c) = degrees.to_radians().sin_cos();
            let (i, j) = ((k + 1) % 3, (k + 2) % 3);
            let (a, b) = (axes[i], axes[j]);
            axes[i] = [0, 1, 2].map(|n| c * a[n] + s * b[n]);
            axes[j] = [0, 1, 2].map(|n| c * b[n] - s * a[n]);
        }
        Frame { origin, axes }
    }

    /// A point of the plane in the frame before it.
    pub fn outer(&self, p: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|n| self.origin[n] + (0..3).map(|k| p[k] * self.axes[k][n]).sum::<f64>())
    }

    /// A direction of the plane in the frame before it.
    pub fn outer_direction(&self, v: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|n| (0..3).map(|k| v[k] * self.axes[k][n]).sum::<f64>())
    }

    /// A point of the frame before it in the plane's coordinates.
    pub fn inner(&self, p: [f64; 3]) -> [f64; 3] {
        self.inner_direction([0, 1, 2].map(|n| p[n] - self.origin[n]))
    }

    /// A direction of the frame before it in the plane's coordinates.
    pub fn inner_direction(&self, v: [f64; 3]) -> [f64; 3] {
        self.axes.map(|axis| dot(axis, v))
    }

    /// The plane's z axis (the tool axis of a 3+2 set-up) in the frame before it.
    pub fn z(&self) -> [f64; 3] {
        self.axes[2]
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// An NC program as a machine runs it.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// Where it came from (a path or a name).
    pub name: String,
    /// The length unit of every position, centre and feed.
    pub units: Units,
    /// The motions, in the order the machine makes them.
    pub motions: Vec<Motion>,
    /// The events, in order; each says before which motion it happens.
    pub events: Vec<Event>,
}

impl Program {
    /// The same program in `units` (positions, centres, feeds and event lengths converted).
    pub fn in_units(&self, units: Units) -> Program {
        let factor = self.units.factor(units);
        Program {
            name: self.name.clone(),
            units,
            motions: self.motions.iter().map(|m| m.scaled(factor)).collect(),
            events: self.events.iter().map(|e| e.scaled(factor)).collect(),
        }
    }
}

#[cfg(test)]
mod tests;
