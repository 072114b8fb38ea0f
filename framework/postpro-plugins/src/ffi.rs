//! The one module that calls into plugin libraries: it loads a library, reads its entry and
//! capabilities into owned Rust values, and wraps the kinematics functions in safe methods.
//! Everything else in the crate is safe code over what this module returns.
//!
//! # Safety
//!
//! Every `unsafe` block here holds because of these invariants (each block's `SAFETY:` comment
//! names the ones it relies on):
//!
//! 1. **Trusted libraries.** Loading a library runs its initialisers, and calling it runs its
//!    code: postpro trusts the libraries the user names (`--plugin`, `POSTPRO_PLUGIN_PATH`, the
//!    `plugins` folder beside the binary) as it trusts its own binary, as any program that
//!    loads plugins does. A library that exports [`ENTRY_SYMBOL`] is taken to follow the ABI of
//!    `postpro-plugin-api`: the symbol is an [`EntryFn`] and the entry it returns begins with a
//!    `u32` ABI version. **Nothing else is read before that version, and then the entry's size,
//!    match this host's.** A library that lies about its types cannot be detected; it is
//!    undefined behaviour like a crash inside a plugin, which no host can catch.
//! 2. **The ABI's pointer rules.** A non-null [`StrView`] points to `len` readable bytes, a
//!    non-null [`List`] to `count` items, all static data of the library. Null pointers are
//!    checked here and never dereferenced; counts and lengths are bounded ([`MAX_ITEMS`],
//!    [`MAX_TEXT`]); structs are read with `read_unaligned`.
//! 3. **Lifetimes.** Every function pointer taken from a library is stored beside an
//!    `Arc<Handle>` that owns the library and is called only through that value; texts are
//!    copied while loading. So nothing points into a library once the last `Arc` drops and
//!    unloads it. **Rule: keep a [`Handle`] (an `Arc`) wherever a function pointer of its
//!    library may be called.**
//! 4. **Instances.** An [`Instance`] owns what `create` returned: it is used only between
//!    `create` and its `Drop`, which calls `destroy` once. The ABI makes the kinematics
//!    functions callable from any thread, concurrently on one instance (the plugin macro
//!    requires `Send + Sync`), which is what `Send` and `Sync` for [`Instance`] rest on.
//! 5. **No unwinding across the boundary.** The plugin macro catches panics and returns a
//!    status; a plugin written by hand must not unwind out of its functions.
//! 6. **Out-parameters are initialised** before each call (a default pose, empty solutions, a
//!    zero count), so that reading them is defined whatever the plugin wrote.

#![allow(unsafe_code)]

use std::ffi::c_void;
use std::path::{Path, PathBuf};
use std::ptr::NonNull;
use std::sync::Arc;

use postpro_plugin_api::{
    ABI_VERSION, ENTRY_SYMBOL, EntryFn, KinematicsConfig, KinematicsTable, List, MAX_SOLUTIONS, MachineDefinition,
    PluginEntry, Pose, Solution, Status, StrView, Template as CTemplate, capability,
};

use crate::error::PluginError;

/// The most items a capability list may have (more means a broken list).
pub(crate) const MAX_ITEMS: usize = 4096;
/// The longest text a plugin may hand over, bytes.
pub(crate) const MAX_TEXT: usize = 16 << 20;

/// A loaded library, and the entry's `last_error`. Dropping the last `Arc` unloads it.
pub(crate) struct Handle {
    /// Declared first, used by the functions below; unloaded when the handle drops.
    _library: libloading::Library,
    last_error: Option<unsafe extern "C" fn() -> StrView>,
}

impl Handle {
    /// The plugin's message for the last failed call on this thread.
    fn last_error(&self) -> String {
        let Some(f) = self.last_error else {
            return "(the plugin has no `last_error`)".into();
        };
        // SAFETY: invariants 1 and 3: a function of the entry, its library loaded (`self`
        // owns it); it takes nothing and returns a view of static or thread-local data
        // valid until the next call into the plugin on this thread, before which it is copied.
        let view = unsafe { f() };
        if view.len == 0 {
            return "(no message)".into();
        }
        // SAFETY: invariant 2, for the view just returned.
        match unsafe { text(view) } {
            Ok(t) => t,
            Err(problem) => format!("(the message {problem})"),
        }
    }
}

/// What is wrong with one item of a plugin (a definition, a template, a kinematics table).
#[derive(Clone, Debug)]
pub(crate) struct Malformed {
    /// Which item (`definition 2`, `kinematics table 1`).
    pub(crate) what: String,
    /// What is wrong with it.
    pub(crate) problem: String,
}

/// A library opened and read: owned copies of everything it declares.
pub(crate) struct Opened {
    pub(crate) name: String,
    pub(crate) version: String,
    /// Each definition's shown name and its text (or why it cannot be read).
    pub(crate) definitions: Vec<(String, Result<String, Malformed>)>,
    pub(crate) templates: Vec<Result<(String, String), Malformed>>,
    pub(crate) kinematics: Vec<Result<Arc<KinTable>, Malformed>>,
}

/// The functions of one machine's kinematics, with the library that holds them (invariant 3).
pub(crate) struct KinTable {
    handle: Arc<Handle>,
    /// The machine it solves.
    pub(crate) machine: String,
    /// Its number of axes.
    pub(crate) axis_count: u32,
    create: unsafe extern "C" fn(*const KinematicsConfig, *mut *mut c_void) -> Status,
    destroy: unsafe extern "C" fn(*mut c_void),
    forward: unsafe extern "C" fn(*const c_void, *const f64, u32, *mut Pose) -> Status,
    inverse: unsafe extern "C" fn(*const c_void, *const Pose, *mut Solution, u32, *mut u32) -> Status,
}

/// A call that did not return [`Status::OK`]: the status and the plugin's message.
#[derive(Clone, Debug)]
pub(crate) struct CallError {
    pub(crate) status: Status,
    pub(crate) message: String,
}

/// A text from a view.
///
/// # Safety
/// Invariant 2: a non-null `view.ptr` points to `view.len` readable bytes, valid during the call.
unsafe fn text(view: StrView) -> Result<String, String> {
    if view.len == 0 {
        return Ok(String::new());
    }
    if view.ptr.is_null() {
        return Err(format!("is a null pointer with a length of {} bytes", view.len));
    }
    if view.len > MAX_TEXT {
        return Err(format!("is {} bytes long, more than the {MAX_TEXT} postpro reads", view.len));
    }
    // SAFETY: not null, at most MAX_TEXT bytes, readable for `len` bytes by the caller's contract;
    // `u8` needs no alignment.
    let bytes = unsafe { std::slice::from_raw_parts(view.ptr, view.len) };
    String::from_utf8(bytes.to_vec()).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        format!("is not valid UTF-8 (at byte {at})")
    })
}

/// The items of a capability list.
///
/// # Safety
/// Invariants 1 and 2: `list` is null or points to a `List<T>` of the library, whose items are
/// `T`s of the library, which stays loaded while the returned slice is used.
unsafe fn items<'a, T>(list: *const c_void) -> Result<&'a [T], String> {
    if list.is_null() {
        return Ok(&[]);
    }
    // SAFETY: not null and a `List<T>` by the caller's contract; read unaligned, copied.
    let list = unsafe { list.cast::<List<T>>().read_unaligned() };
    if list.count == 0 {
        return Ok(&[]);
    }
    if list.items.is_null() {
        return Err(format!("lists {} items at a null pointer", list.count));
    }
    if list.count > MAX_ITEMS {
        return Err(format!("lists {} items, more than the {MAX_ITEMS} postpro reads", list.count));
    }
    if !list.items.is_aligned() {
        return Err("lists its items at a misaligned address".into());
    }
    // SAFETY: not null, aligned, `count` ≤ MAX_ITEMS items of static data by the contract.
    Ok(unsafe { std::slice::from_raw_parts(list.items, list.count) })
}

/// Opens a library and reads its entry and capabilities. `path` has a directory part, so that
/// the system's library search path plays no part.
pub(crate) fn open(path: &Path) -> Result<Opened, PluginError> {
    let library_path = || PathBuf::from(path);
    // SAFETY: invariant 1: loading runs the library's initialisers; postpro trusts the
    // libraries it is given.
    let library = unsafe { libloading::Library::new(path) }
        .map_err(|e| PluginError::Open { library: library_path(), reason: e.to_string() })?;
    // SAFETY: invariant 1: a library that exports this name follows the ABI, so the symbol
    // is an `EntryFn`. The function pointer is copied out; it is only called while `library`
    // lives (here, then never again).
    let entry_fn: EntryFn = match unsafe { library.get::<EntryFn>(ENTRY_SYMBOL.as_bytes()) } {
        Ok(symbol) => *symbol,
        Err(_) => return Err(PluginError::NotAPlugin { library: library_path(), symbol: ENTRY_SYMBOL }),
    };
    // SAFETY: invariants 1 and 5: the entry function takes nothing and returns a pointer to
    // static data of the library, which is loaded.
    let entry = unsafe { entry_fn() };
    if entry.is_null() {
        return Err(PluginError::Malformed {
            library: library_path(),
            what: format!("`{ENTRY_SYMBOL}`"),
            problem: "returned a null pointer".into(),
        });
    }
    // SAFETY: invariant 1: whatever its version, an entry begins with a `u32` ABI version;
    // `entry` is not null. Read unaligned: nothing else is assumed yet.
    let version = unsafe { entry.cast::<u32>().read_unaligned() };
    if version != ABI_VERSION {
        return Err(PluginError::abi(path, "ABI version", version, ABI_VERSION, ""));
    }
    // SAFETY: invariant 1: in ABI version 1 the entry's second `u32` is its size.
    let size = unsafe { entry.cast::<u32>().add(1).read_unaligned() };
    let expected = std::mem::size_of::<PluginEntry>();
    if size as usize != expected {
        return Err(PluginError::abi(path, "entry struct size", size, expected as u32, " bytes"));
    }
    // SAFETY: invariant 1: version and size are this host's: `entry` points to a whole
    // `PluginEntry`, copied out unaligned.
    let entry = unsafe { entry.read_unaligned() };
    let malformed = |what: &str, problem: String| PluginError::Malformed {
        library: library_path(),
        what: what.to_string(),
        problem,
    };
    // SAFETY: invariant 2 for the entry's views.
    let name = unsafe { text(entry.name) }.map_err(|p| malformed("the plugin's name", p))?;
    // SAFETY: as above.
    let plugin_version = unsafe { text(entry.version) }.map_err(|p| malformed("the plugin's version", p))?;
    let Some(get_capability) = entry.get_capability else {
        return Err(malformed("the entry's `get_capability`", "is a null pointer".into()));
    };
    let handle = Arc::new(Handle { _library: library, last_error: entry.last_error });
    // SAFETY: invariants 1, 3 and 5: a function of the entry, the library loaded (`handle`);
    // it returns null or a pointer to a static `List` of the id's type.
    let capability = |id: u32| unsafe { get_capability(id) };

    let mut definitions = Vec::new();
    // SAFETY: invariant 2: the MACHINES capability is a `List<MachineDefinition>`; `handle`
    // keeps the library loaded while the slice is read.
    let listed = unsafe { items::<MachineDefinition>(capability(capability::MACHINES)) }
        .map_err(|p| malformed("the machine definitions", p))?;
    for (i, d) in listed.iter().enumerate() {
        let what = format!("definition {}", i + 1);
        // SAFETY: invariant 2 for the definition's views.
        let file = unsafe { text(d.file) }.ok().filter(|f| !f.is_empty()).unwrap_or_else(|| what.clone());
        // SAFETY: as above.
        let yaml = unsafe { text(d.yaml) }.map_err(|p| Malformed { what: format!("definition `{file}`"), problem: p });
        definitions.push((file, yaml));
    }

    let mut templates = Vec::new();
    // SAFETY: invariant 2: the TEMPLATES capability is a `List<Template>`.
    let listed =
        unsafe { items::<CTemplate>(capability(capability::TEMPLATES)) }.map_err(|p| malformed("the templates", p))?;
    for (i, t) in listed.iter().enumerate() {
        let what = format!("template {}", i + 1);
        // SAFETY: invariant 2 for the template's views.
        let read = unsafe { text(t.name) }
            .map_err(|p| Malformed { what: what.clone(), problem: format!("its name {p}") })
            // SAFETY: as above.
            .and_then(|n| unsafe { text(t.text) }.map(|body| (n, body)).map_err(|p| Malformed { what, problem: p }));
        templates.push(read);
    }

    let mut kinematics = Vec::new();
    // SAFETY: invariant 2: the KINEMATICS capability is a `List<KinematicsTable>`.
    let listed = unsafe { items::<KinematicsTable>(capability(capability::KINEMATICS)) }
        .map_err(|p| malformed("the kinematics", p))?;
    for (i, t) in listed.iter().enumerate() {
        kinematics.push(table(&handle, i, t));
    }
    Ok(Opened { name, version: plugin_version, definitions, templates, kinematics })
}

/// A kinematics table with every function present.
fn table(handle: &Arc<Handle>, i: usize, t: &KinematicsTable) -> Result<Arc<KinTable>, Malformed> {
    // SAFETY: invariant 2 for the table's view.
    let machine = unsafe { text(t.machine) }
        .map_err(|p| Malformed { what: format!("kinematics table {}", i + 1), problem: format!("its machine {p}") })?;
    let what = format!("the kinematics of `{machine}`");
    let missing = |f: &str| Malformed { what: what.clone(), problem: format!("`{f}` is a null pointer") };
    Ok(Arc::new(KinTable {
        handle: Arc::clone(handle),
        axis_count: t.axis_count,
        create: t.create.ok_or_else(|| missing("create"))?,
        destroy: t.destroy.ok_or_else(|| missing("destroy"))?,
        forward: t.forward.ok_or_else(|| missing("forward"))?,
        inverse: t.inverse.ok_or_else(|| missing("inverse"))?,
        machine,
    }))
}

impl KinTable {
    fn failure(&self, status: Status) -> CallError {
        CallError { status, message: self.handle.last_error() }
    }

    /// An instance for a tool length (mm).
    pub(crate) fn create(self: &Arc<Self>, tool_length: f64) -> Result<Instance, CallError> {
        let config = KinematicsConfig { tool_length };
        let mut out: *mut c_void = std::ptr::null_mut();
        // SAFETY: invariants 1, 3, 5 and 6: the table's `create`, its library loaded
        // (`self.handle`); `config` and `out` are valid during the call, `out` initialised.
        let status = unsafe { (self.create)(&config, &mut out) };
        if status != Status::OK {
            return Err(self.failure(status));
        }
        match NonNull::new(out) {
            Some(ptr) => Ok(Instance { table: Arc::clone(self), ptr }),
            None => Err(CallError { status, message: "`create` returned no instance".into() }),
        }
    }
}

/// A live instance of a machine's kinematics (invariant 4).
pub(crate) struct Instance {
    table: Arc<KinTable>,
    ptr: NonNull<c_void>,
}

// SAFETY: invariant 4: the ABI makes the kinematics functions callable from any thread on one
// instance, and `destroy` is called once, by `Drop`, whichever thread that is.
unsafe impl Send for Instance {}
// SAFETY: invariant 4: concurrent calls on one instance are allowed by the ABI.
unsafe impl Sync for Instance {}

impl Instance {
    /// Forward kinematics.
    pub(crate) fn forward(&self, joints: &[f64]) -> Result<Pose, CallError> {
        let mut pose = Pose::default();
        let count = u32::try_from(joints.len()).unwrap_or(u32::MAX);
        // SAFETY: invariants 3 to 6: a live instance of this table, its library loaded;
        // `joints` holds `count` values and `pose` is valid for a write, both during the call.
        let status = unsafe { (self.table.forward)(self.ptr.as_ptr(), joints.as_ptr(), count, &mut pose) };
        if status == Status::OK { Ok(pose) } else { Err(self.table.failure(status)) }
    }

    /// Inverse kinematics into `out`; returns the number of solutions the plugin reports (it
    /// may exceed `out`'s length, which the caller checks: only `out` is ever read).
    pub(crate) fn inverse(&self, pose: &Pose, out: &mut [Solution; MAX_SOLUTIONS]) -> Result<usize, CallError> {
        *out = [Solution::EMPTY; MAX_SOLUTIONS];
        let mut count: u32 = 0;
        // SAFETY: invariants 3 to 6: a live instance of this table, its library loaded; `pose`
        // is valid during the call, `out` has room for `MAX_SOLUTIONS` solutions (the capacity
        // passed) and `count` is valid for a write; all initialised.
        let status = unsafe {
            (self.table.inverse)(self.ptr.as_ptr(), pose, out.as_mut_ptr(), MAX_SOLUTIONS as u32, &mut count)
        };
        if status == Status::OK { Ok(count as usize) } else { Err(self.table.failure(status)) }
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // SAFETY: invariants 3 and 4: `ptr` came from this table's `create`, nothing uses it
        // after this (the instance is being dropped), and `destroy` runs once; the library is
        // still loaded since `self.table` is dropped only after this.
        unsafe { (self.table.destroy)(self.ptr.as_ptr()) }
    }
}

/// The path with a directory part (`./lib.so` for `lib.so`), so that loading never searches the
/// system's library path.
pub(crate) fn explicit(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => path.to_path_buf(),
        _ => Path::new(".").join(path),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed unwrap is a failed test
mod tests {
    use super::*;

    #[test]
    fn texts_are_checked_before_they_are_read() {
        let bytes = b"ok \xff";
        // SAFETY: the view points into `bytes`, alive during the call.
        let e = unsafe { text(StrView { ptr: bytes.as_ptr(), len: bytes.len() }) }.unwrap_err();
        assert_eq!(e, "is not valid UTF-8 (at byte 3)");
        // SAFETY: a null pointer is checked before anything is read.
        let e = unsafe { text(StrView { ptr: std::ptr::null(), len: 3 }) }.unwrap_err();
        assert_eq!(e, "is a null pointer with a length of 3 bytes");
        // SAFETY: the length is checked before anything is read.
        let e = unsafe { text(StrView { ptr: bytes.as_ptr(), len: MAX_TEXT + 1 }) }.unwrap_err();
        assert!(e.contains("more than the"), "{e}");
        // SAFETY: a static string.
        assert_eq!(unsafe { text(StrView::new("fork-head")) }.unwrap(), "fork-head");
        // SAFETY: an empty view is never read.
        assert_eq!(unsafe { text(StrView::EMPTY) }.unwrap(), "");
    }

    #[test]
    fn lists_are_checked_before_they_are_read() {
        let null_items: List<u32> = List { count: 2, items: std::ptr::null() };
        // SAFETY: points to a `List<u32>` alive during the call; its null items are not read.
        let e = unsafe { items::<u32>((&raw const null_items).cast()) }.unwrap_err();
        assert_eq!(e, "lists 2 items at a null pointer");
        let values = [1u32, 2, 3];
        let too_many: List<u32> = List { count: MAX_ITEMS + 1, items: values.as_ptr() };
        // SAFETY: as above; the count is checked before the items are read.
        let e = unsafe { items::<u32>((&raw const too_many).cast()) }.unwrap_err();
        assert!(e.contains("more than the"), "{e}");
        let fine: List<u32> = List { count: 3, items: values.as_ptr() };
        // SAFETY: a list of three values alive during the call and the read below.
        assert_eq!(unsafe { items::<u32>((&raw const fine).cast()) }.unwrap(), &[1, 2, 3]);
        // SAFETY: null is "not provided".
        assert!(unsafe { items::<u32>(std::ptr::null()) }.unwrap().is_empty());
    }

    #[test]
    fn paths_get_a_folder() {
        assert_eq!(explicit(Path::new("libx.so")), Path::new("./libx.so"));
        assert_eq!(explicit(Path::new("target/libx.so")), Path::new("target/libx.so"));
    }
}
