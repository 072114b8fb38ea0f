//! # postpro-plugin-api: the C ABI between postpro and its plugins
//!
//! A plugin is a shared library (`.so`, `.dylib`, `.dll`) that adds machines to postpro without
//! recompiling it: their YAML definitions and, where the shop wants, their own compiled
//! kinematics (a closed-form inverse). `docs/writing-a-plugin.md` walks through writing one.
//!
//! This crate has no dependency besides std, and no postpro type crosses the boundary: only
//! `#[repr(C)]` plain data and `extern "C"` functions, so that a plugin built with another
//! compiler version, or written in C, works as well.
//!
//! ## The ABI (version [`ABI_VERSION`])
//!
//! - The library exports the symbol [`ENTRY_SYMBOL`] (`postpro_plugin_entry`), a function
//!   [`EntryFn`] returning a pointer to a [`PluginEntry`]. Its **first field is the ABI
//!   version** (`u32`): the host reads it before anything else and refuses another version;
//!   then the struct's size, the plugin's name and version, [`PluginEntry::get_capability`]
//!   and [`PluginEntry::last_error`].
//! - Capabilities are looked up by id ([`capability`]); a null pointer means "not provided":
//!   - [`capability::MACHINES`]: a [`List`] of [`MachineDefinition`]s (YAML texts in the format
//!     of `docs/machine-defs.md`);
//!   - [`capability::KINEMATICS`]: a [`List`] of [`KinematicsTable`]s, one per machine whose
//!     definition says `solver: plugin`: `create`/`destroy` an instance for a tool length,
//!     `forward` (axis values → [`Pose`]) and `inverse` (pose → **every** [`Solution`]);
//!   - [`capability::TEMPLATES`]: a [`List`] of [`Template`]s (name and text), for the NC
//!     emitter.
//! - Every function returns a [`Status`]; on anything but [`Status::OK`] the message is fetched
//!   with `last_error`, a view valid until the next call into the plugin on the same thread.
//!
//! ## Rules both sides keep
//!
//! - **Lifetimes.** Everything the entry and the capabilities point to (texts, lists, tables,
//!   functions) is static data of the library: valid while the library is loaded. The host
//!   copies the texts when it loads the library and keeps the library loaded as long as it may
//!   call any of its functions. An instance lives from `create` to `destroy`.
//! - **Threads.** The kinematics functions may be called from any thread, concurrently on one
//!   instance (the Rust trait requires `Send + Sync`).
//! - **Panics and errors.** No unwinding crosses the boundary: [`export_plugin!`] catches every
//!   panic (`std::panic::catch_unwind`) and turns it into [`Status::PANIC`] with the panic
//!   message and location. A plugin therefore must not be built with `panic = "abort"` (the
//!   macro refuses to compile then).
//! - **Units and frames.** Millimetres and radians; joint values in the order of the
//!   definition's `axes`; poses in the **part frame**, tool axis from the tip towards the
//!   spindle, a unit vector.
//!
//! ## Writing a plugin in Rust
//!
//! Implement [`PluginKinematics`] for a type per machine and export everything with
//! [`export_plugin!`], which writes the entry symbol and the `extern "C"` shims:
//!
//! ```ignore
//! use postpro_plugin_api::{Error, KinematicsConfig, PluginKinematics, Pose, Solution, Solutions};
//!
//! struct MyHead { pivot_to_tip: f64 }
//!
//! impl PluginKinematics for MyHead {
//!     const MACHINE: &'static str = "my-head";
//!     const AXES: usize = 5;
//!     fn new(config: &KinematicsConfig) -> Result<Self, Error> { /* … */ }
//!     fn forward(&self, joints: &[f64]) -> Result<Pose, Error> { /* … */ }
//!     fn inverse(&self, pose: &Pose, out: &mut Solutions) -> Result<(), Error> { /* … */ }
//! }
//!
//! postpro_plugin_api::export_plugin! {
//!     name: "my-plugin",
//!     machines: ["machines/my-head.yaml"],   // paths from the crate's Cargo.toml folder
//!     kinematics: [MyHead],
//! }
//! ```

use std::ffi::c_void;
use std::fmt;

#[doc(hidden)]
pub mod __private;
mod export;

/// The ABI version this crate describes. The host refuses a plugin whose entry carries another.
pub const ABI_VERSION: u32 = 1;

/// The name of the symbol every plugin exports: a function [`EntryFn`].
pub const ENTRY_SYMBOL: &str = "postpro_plugin_entry";

/// The most axis values a [`Solution`] carries (postpro itself handles up to five).
pub const MAX_AXES: usize = 8;

/// The most solutions one `inverse` call may return (postpro itself takes at most two: the two
/// branches of a 5-axis machine).
pub const MAX_SOLUTIONS: usize = 8;

/// [`Solution::pole_axis`] when the solution is near no singularity.
pub const NO_POLE: i32 = -1;

/// The capability ids of [`PluginEntry::get_capability`].
pub mod capability {
    /// A [`crate::List`] of [`crate::MachineDefinition`]s.
    pub const MACHINES: u32 = 1;
    /// A [`crate::List`] of [`crate::KinematicsTable`]s.
    pub const KINEMATICS: u32 = 2;
    /// A [`crate::List`] of [`crate::Template`]s.
    pub const TEMPLATES: u32 = 3;
}

/// The type of the exported entry function: returns the plugin's [`PluginEntry`], static data
/// of the library (never null for a working plugin).
pub type EntryFn = unsafe extern "C" fn() -> *const PluginEntry;

/// A UTF-8 string that is not NUL-terminated: `len` bytes from `ptr` (`ptr` may be null when
/// `len` is 0). In C: `struct { const uint8_t *ptr; size_t len; }`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct StrView {
    /// The first byte.
    pub ptr: *const u8,
    /// The number of bytes.
    pub len: usize,
}

impl StrView {
    /// The empty string.
    pub const EMPTY: StrView = StrView { ptr: std::ptr::null(), len: 0 };

    /// A view of a static string (usable in constants).
    pub const fn new(s: &'static str) -> StrView {
        StrView { ptr: s.as_ptr(), len: s.len() }
    }

    /// A view of any string; the caller keeps the string alive and unchanged as long as the
    /// view is read.
    pub fn borrowed(s: &str) -> StrView {
        StrView { ptr: s.as_ptr(), len: s.len() }
    }
}

/// The outcome of a call. A plain `i32` rather than an enum, so that an unknown value from a
/// plugin is an error the host reports, not undefined behaviour.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Status(pub i32);

impl Status {
    /// Success.
    pub const OK: Status = Status(0);
    /// The plugin reported an error (its message: `last_error`).
    pub const ERROR: Status = Status(1);
    /// The plugin panicked; the panic was caught at the boundary (message and location:
    /// `last_error`).
    pub const PANIC: Status = Status(2);
    /// The host passed a null pointer or a wrong count.
    pub const INVALID_ARGUMENT: Status = Status(3);

    /// A name for messages: `ok`, `error`, `panic`, `invalid argument` or `status 42`.
    pub fn name(self) -> String {
        match self {
            Status::OK => "ok".into(),
            Status::ERROR => "error".into(),
            Status::PANIC => "panic".into(),
            Status::INVALID_ARGUMENT => "invalid argument".into(),
            Status(other) => format!("status {other}"),
        }
    }
}

/// What the entry function returns. **The first field is the ABI version**, whatever the
/// version: the host reads that `u32` alone first.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct PluginEntry {
    /// [`ABI_VERSION`] of the crate the plugin was built with.
    pub abi_version: u32,
    /// `size_of::<PluginEntry>()` in bytes, checked by the host once the version matches.
    pub struct_size: u32,
    /// The plugin's name (shown in messages).
    pub name: StrView,
    /// The plugin's own version (its crate version).
    pub version: StrView,
    /// The capability with this id ([`capability`]), or null if the plugin does not provide it.
    pub get_capability: Option<unsafe extern "C" fn(id: u32) -> *const c_void>,
    /// The message of the last failed call on this thread; valid until the next call into the
    /// plugin on this thread.
    pub last_error: Option<unsafe extern "C" fn() -> StrView>,
}

/// A counted array of static items. In C: `struct { size_t count; const T *items; }`.
#[repr(C)]
#[derive(Debug)]
pub struct List<T> {
    /// The number of items.
    pub count: usize,
    /// The first item (may be null when `count` is 0).
    pub items: *const T,
}

impl<T> Clone for List<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for List<T> {}

impl<T> List<T> {
    /// A list over a static slice (usable in constants).
    pub const fn new(items: &'static [T]) -> List<T> {
        List { count: items.len(), items: items.as_ptr() }
    }
}

/// One machine definition: a YAML text in the format of `docs/machine-defs.md`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct MachineDefinition {
    /// The name errors show for the text (`machines/my-head.yaml`).
    pub file: StrView,
    /// The YAML text.
    pub yaml: StrView,
}

/// One template for the NC emitter.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct Template {
    /// The template's name.
    pub name: StrView,
    /// Its text.
    pub text: StrView,
}

/// What an instance of a machine's kinematics is created for.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KinematicsConfig {
    /// The tool length from the spindle nose to the tip (mm, ≥ 0): the definition's
    /// `chain.tool_length` or the command line's `--tool-length`.
    pub tool_length: f64,
}

/// A tool pose in the part frame.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    /// The tool tip (mm).
    pub tip: [f64; 3],
    /// The tool axis, from the tip towards the spindle, a unit vector.
    pub axis: [f64; 3],
}

/// One inverse solution.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution {
    /// Axis values in the order of the definition's `axes` (mm and rad); the first `axis_count`
    /// are used.
    pub joints: [f64; MAX_AXES],
    /// How many axis values (the definition's number of axes).
    pub axis_count: u32,
    /// The branch: a small number that stays the same along a path on one branch (for a 5-axis
    /// machine, 0 for one sign of the tilt and 1 for the other).
    pub branch: u32,
    /// The index of the rotary axis that becomes free at the nearest singularity, or
    /// [`NO_POLE`].
    pub pole_axis: i32,
    /// The angle (rad) between the pose and that singularity (0 at the singularity, where the
    /// free axis's value is arbitrary).
    pub pole_angle: f64,
}

impl Solution {
    /// No axis values.
    pub const EMPTY: Solution =
        Solution { joints: [0.0; MAX_AXES], axis_count: 0, branch: 0, pole_axis: NO_POLE, pole_angle: 0.0 };

    /// A solution with these axis values on this branch, near no singularity. More than
    /// [`MAX_AXES`] values are cut off (and `axis_count` tells the host).
    pub fn new(joints: &[f64], branch: u32) -> Solution {
        let mut s = Solution::EMPTY;
        let n = joints.len().min(MAX_AXES);
        s.joints[..n].copy_from_slice(&joints[..n]);
        s.axis_count = u32::try_from(joints.len()).unwrap_or(u32::MAX);
        s.branch = branch;
        s
    }

    /// The same solution, `angle` (rad) away from the singularity where rotary axis `axis`
    /// becomes free.
    pub fn with_pole(mut self, axis: usize, angle: f64) -> Solution {
        self.pole_axis = i32::try_from(axis).unwrap_or(NO_POLE);
        self.pole_angle = angle;
        self
    }

    /// The axis values used.
    pub fn joints(&self) -> &[f64] {
        &self.joints[..(self.axis_count as usize).min(MAX_AXES)]
    }

    /// The free axis at the nearest singularity and the angle to it, if any.
    pub fn pole(&self) -> Option<(usize, f64)> {
        usize::try_from(self.pole_axis).ok().map(|a| (a, self.pole_angle))
    }
}

/// The functions of one machine's kinematics. Every function pointer must be set; `instance`
/// is what `create` returned.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct KinematicsTable {
    /// The `name` of the machine definition (shipped by the same plugin) this solves.
    pub machine: StrView,
    /// The number of axes (the definition's).
    pub axis_count: u32,
    /// Creates an instance for a configuration, written to `*instance`.
    pub create: Option<unsafe extern "C" fn(config: *const KinematicsConfig, instance: *mut *mut c_void) -> Status>,
    /// Destroys an instance; called once, after the last call on it.
    pub destroy: Option<unsafe extern "C" fn(instance: *mut c_void)>,
    /// Forward kinematics: `count` axis values → the pose in the part frame, written to `*out`.
    pub forward:
        Option<unsafe extern "C" fn(instance: *const c_void, joints: *const f64, count: u32, out: *mut Pose) -> Status>,
    /// Inverse kinematics: **every** solution for `*pose` (none when the orientation cannot be
    /// reached), without range checks; writes up to `capacity` solutions to `out` and their
    /// number to `*count`.
    pub inverse: Option<
        unsafe extern "C" fn(
            instance: *const c_void,
            pose: *const Pose,
            out: *mut Solution,
            capacity: u32,
            count: *mut u32,
        ) -> Status,
    >,
}

/// An error a plugin's kinematics reports: the host shows its message for the machine.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Error(String);

impl Error {
    /// An error with this message.
    pub fn new(message: impl Into<String>) -> Error {
        Error(message.into())
    }

    /// The message.
    pub fn message(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

impl From<&str> for Error {
    fn from(message: &str) -> Error {
        Error::new(message)
    }
}

impl From<String> for Error {
    fn from(message: String) -> Error {
        Error(message)
    }
}

/// The solutions an `inverse` writes: up to [`MAX_SOLUTIONS`], without allocating.
#[derive(Clone, Debug)]
pub struct Solutions {
    items: [Solution; MAX_SOLUTIONS],
    kept: usize,
    pushed: usize,
}

impl Default for Solutions {
    fn default() -> Self {
        Solutions::new()
    }
}

impl Solutions {
    /// No solution.
    pub fn new() -> Solutions {
        Solutions { items: [Solution::EMPTY; MAX_SOLUTIONS], kept: 0, pushed: 0 }
    }

    /// Adds a solution. Past [`MAX_SOLUTIONS`] the call fails (the host is told how many were
    /// pushed).
    pub fn push(&mut self, s: Solution) {
        if self.kept < MAX_SOLUTIONS {
            self.items[self.kept] = s;
            self.kept += 1;
        }
        self.pushed += 1;
    }

    /// The solutions kept.
    pub fn as_slice(&self) -> &[Solution] {
        &self.items[..self.kept]
    }

    /// The number of solutions pushed (more than are kept if [`MAX_SOLUTIONS`] was exceeded).
    pub fn len(&self) -> usize {
        self.pushed
    }

    /// True without solutions.
    pub fn is_empty(&self) -> bool {
        self.pushed == 0
    }

    /// Removes every solution.
    pub fn clear(&mut self) {
        self.kept = 0;
        self.pushed = 0;
    }
}

/// One machine's kinematics, written in Rust. [`export_plugin!`] turns it into a
/// [`KinematicsTable`]; the shims catch panics and check the arguments, so these methods see
/// only valid Rust values.
///
/// The host checks the plugin against the machine's YAML definition: when it creates an
/// instance it compares `forward` with the definition's kinematic chain on sample axis values,
/// and that `inverse` returns every solution the chain finds; during a solve every solution's
/// forward kinematics must return the pose (1e-6 mm and 1e-6 rad; aim for 1e-9).
pub trait PluginKinematics: Sized + Send + Sync + 'static {
    /// The `name` of the machine definition (shipped by the same plugin) this solves.
    const MACHINE: &'static str;

    /// The number of axes, as in the definition: `forward` gets exactly this many values and
    /// every solution must have this many.
    const AXES: usize;

    /// The kinematics for a tool length (`config.tool_length`, mm).
    fn new(config: &KinematicsConfig) -> Result<Self, Error>;

    /// The pose in the part frame for axis values in the definition's order (mm, rad).
    fn forward(&self, joints: &[f64]) -> Result<Pose, Error>;

    /// Every solution for a pose, without range checks (the host's policy chooses among them
    /// and checks the travels): none when the tool axis cannot be reached at all.
    fn inverse(&self, pose: &Pose, out: &mut Solutions) -> Result<(), Error>;
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    #[test]
    fn the_version_is_the_first_field() {
        assert_eq!(std::mem::offset_of!(PluginEntry, abi_version), 0);
        assert_eq!(std::mem::size_of::<u32>(), 4);
        assert_eq!(std::mem::offset_of!(PluginEntry, struct_size), 4);
    }

    #[test]
    fn solutions_count_what_they_drop() {
        let mut s = Solutions::new();
        for k in 0..MAX_SOLUTIONS + 2 {
            s.push(Solution::new(&[k as f64], 0));
        }
        assert_eq!(s.len(), MAX_SOLUTIONS + 2);
        assert_eq!(s.as_slice().len(), MAX_SOLUTIONS);
        s.clear();
        assert!(s.is_empty());
    }

    #[test]
    fn solution_accessors() {
        let s = Solution::new(&[1.0, 2.0, 3.0], 1).with_pole(4, 0.25);
        assert_eq!(s.joints(), &[1.0, 2.0, 3.0]);
        assert_eq!(s.pole(), Some((4, 0.25)));
        assert_eq!(Solution::new(&[0.0; 10], 0).axis_count, 10);
        assert_eq!(Solution::EMPTY.pole(), None);
    }

    #[test]
    fn status_names() {
        assert_eq!(Status::PANIC.name(), "panic");
        assert_eq!(Status(42).name(), "status 42");
    }
}
