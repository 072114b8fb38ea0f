//! Poses in the part frame and joint vectors in the machine's axis order.

use nalgebra::{Point3, Unit, Vector3};

/// A tool pose in the part frame: the tip and the unit tool axis (tip → spindle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Tool tip, mm.
    pub tip: Point3<f64>,
    /// Tool axis.
    pub axis: Unit<Vector3<f64>>,
}

/// How fast a pose changes: the tip's velocity and the tool axis's rate of turn (per unit of
/// whatever parameter the axes move along).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PoseRate {
    /// The tip's velocity, mm per unit.
    pub tip: Vector3<f64>,
    /// The tool axis's derivative (orthogonal to the axis), per unit.
    pub axis: Vector3<f64>,
}

/// Upper bounds on how the tool bends while the axes move linearly between two sets of values
/// (`t` from 0 to 1): the largest `|d²tip/dt²|` (mm) and `|d²axis/dt²|`. The tip never strays
/// more than `tip / 8` from the chord of its ends (the linear interpolant's error bound).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bend {
    /// Bound of the tip's second derivative, mm.
    pub tip: f64,
    /// Bound of the tool axis's second derivative.
    pub axis: f64,
}

/// The most axes a machine may have: three linear and two rotary (3-, 4- and 5-axis machines).
pub const MAX_AXES: usize = 5;

/// Axis values in the order of `Machine::axes` (mm and rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Joints {
    values: [f64; MAX_AXES],
    len: u8,
}

impl Joints {
    /// No axes.
    pub const EMPTY: Joints = Joints { values: [0.0; MAX_AXES], len: 0 };

    /// `len` zeros.
    pub fn zeros(len: usize) -> Joints {
        Joints { values: [0.0; MAX_AXES], len: len.min(MAX_AXES) as u8 }
    }

    /// From a slice (at most [`MAX_AXES`] values are kept).
    pub fn from_slice(values: &[f64]) -> Joints {
        let mut j = Joints::zeros(values.len());
        let n = j.len();
        j.values[..n].copy_from_slice(&values[..n]);
        j
    }

    /// From an array whose first `len` values are used (the others are set to zero).
    pub(crate) fn from_array(mut values: [f64; MAX_AXES], len: usize) -> Joints {
        let len = len.min(MAX_AXES);
        for v in values.iter_mut().skip(len) {
            *v = 0.0;
        }
        Joints { values, len: len as u8 }
    }

    /// Every value of the array, zeros past [`Joints::len`]: for arithmetic on whole arrays.
    pub(crate) fn array(&self) -> [f64; MAX_AXES] {
        self.values
    }

    /// The values.
    pub fn as_slice(&self) -> &[f64] {
        &self.values[..self.len as usize]
    }

    /// The values, mutable.
    pub fn as_mut_slice(&mut self) -> &mut [f64] {
        &mut self.values[..self.len as usize]
    }

    /// Number of axes.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// True without axes.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Linear interpolation `self + (other − self)·t`.
    pub fn lerp(&self, other: &Joints, t: f64) -> Joints {
        let mut out = *self;
        for (o, (a, b)) in out.as_mut_slice().iter_mut().zip(self.as_slice().iter().zip(other.as_slice())) {
            *o = a + (b - a) * t;
        }
        out
    }
}

impl std::ops::Index<usize> for Joints {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        &self.as_slice()[i]
    }
}

impl std::ops::IndexMut<usize> for Joints {
    fn index_mut(&mut self, i: usize) -> &mut f64 {
        &mut self.as_mut_slice()[i]
    }
}
