//! What the code of [`crate::export_plugin!`] calls: the safe half of the shims (panics caught,
//! arguments checked, the last error kept per thread). The pointer handling, the unsafe half,
//! is in the macro's expansion. Not part of the API.

use std::any::Any;
use std::cell::{Cell, RefCell};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Once;

use crate::{Error, KinematicsConfig, MAX_SOLUTIONS, PluginKinematics, Pose, Solutions, Status, StrView};

thread_local! {
    /// The message of the last failed call on this thread, for `last_error`.
    static LAST_ERROR: RefCell<String> = const { RefCell::new(String::new()) };
    /// True while a guarded call runs on this thread: the panic hook then records the panic
    /// instead of printing it.
    static IN_CALL: Cell<bool> = const { Cell::new(false) };
    /// The message and location of a panic inside a guarded call.
    static PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Sets the message `last_error` returns on this thread.
pub fn set_last_error(message: &str) {
    LAST_ERROR.with(|e| {
        let mut e = e.borrow_mut();
        e.clear();
        e.push_str(message);
    });
}

/// The `last_error` of the entry: a view of this thread's last message, valid until the next
/// call into the plugin on this thread.
pub extern "C" fn last_error() -> StrView {
    LAST_ERROR.with(|e| StrView::borrowed(&e.borrow()))
}

/// Installs (once) the plugin's panic hook: a panic inside a guarded call is recorded with its
/// location for the host instead of being printed; any other panic goes to the previous hook.
/// The plugin links its own copy of std, so this hook is the plugin's alone.
pub fn install_panic_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_CALL.with(Cell::get) {
                let message = payload_text(info.payload());
                let text = match info.location() {
                    Some(l) => format!("{message} (at {}:{}:{})", l.file(), l.line(), l.column()),
                    None => message,
                };
                PANIC.with(|p| *p.borrow_mut() = Some(text));
            } else {
                previous(info);
            }
        }));
    });
}

fn payload_text(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic without a message".to_string()
    }
}

/// Runs `f`, catching a panic: an error becomes [`Status::ERROR`], a panic [`Status::PANIC`],
/// each with its message for `last_error`.
pub fn guard<R>(f: impl FnOnce() -> Result<R, Error>) -> Result<R, Status> {
    install_panic_hook();
    let outer = IN_CALL.with(|c| c.replace(true));
    let result = catch_unwind(AssertUnwindSafe(f));
    IN_CALL.with(|c| c.set(outer));
    match result {
        Ok(Ok(r)) => Ok(r),
        Ok(Err(e)) => {
            set_last_error(e.message());
            Err(Status::ERROR)
        }
        Err(payload) => {
            let text = PANIC.with(|p| p.borrow_mut().take()).unwrap_or_else(|| payload_text(&*payload));
            // A payload whose drop panics must not unwind out of an `extern "C"` function.
            let _ = catch_unwind(AssertUnwindSafe(move || drop(payload)));
            set_last_error(&text);
            Err(Status::PANIC)
        }
    }
}

/// [`Status::INVALID_ARGUMENT`], with this message for `last_error`.
pub fn invalid_argument(message: &str) -> Status {
    set_last_error(message);
    Status::INVALID_ARGUMENT
}

/// `create`: a boxed instance.
pub fn create<K: PluginKinematics>(config: &KinematicsConfig) -> Result<Box<K>, Status> {
    if !(config.tool_length.is_finite() && config.tool_length >= 0.0) {
        return Err(invalid_argument(&format!(
            "create: tool length {} mm, expected a finite length ≥ 0",
            config.tool_length
        )));
    }
    guard(|| K::new(config).map(Box::new))
}

/// `destroy`: drops the instance, catching a panic in its `Drop`.
pub fn destroy<K: PluginKinematics>(instance: Box<K>) {
    let _ = guard(move || {
        drop(instance);
        Ok(())
    });
}

/// `forward`, with the number of axis values checked.
pub fn forward<K: PluginKinematics>(k: &K, joints: &[f64]) -> Result<Pose, Status> {
    if joints.len() != K::AXES {
        return Err(invalid_argument(&format!("forward: {} axis values, expected {}", joints.len(), K::AXES)));
    }
    guard(|| k.forward(joints))
}

/// `inverse`: every solution, at most `capacity` of them.
pub fn inverse<K: PluginKinematics>(k: &K, pose: &Pose, capacity: usize) -> Result<Solutions, Status> {
    let solutions = guard(|| {
        let mut out = Solutions::new();
        k.inverse(pose, &mut out)?;
        Ok(out)
    })?;
    let most = capacity.min(MAX_SOLUTIONS);
    if solutions.len() > most {
        set_last_error(&format!(
            "inverse: {} solutions, more than the {most} the host takes (the two branches of a 5-axis machine, or \
             one)",
            solutions.len()
        ));
        return Err(Status::ERROR);
    }
    Ok(solutions)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn last() -> String {
        LAST_ERROR.with(|e| e.borrow().clone())
    }

    #[test]
    fn panics_become_a_status_with_the_location() {
        let r: Result<(), Status> = guard(|| panic!("boom {}", 42));
        assert_eq!(r, Err(Status::PANIC));
        let m = last();
        assert!(m.starts_with("boom 42 (at "), "{m}");
        assert!(m.contains("__private.rs:"), "{m}");
        // The next call works.
        assert_eq!(guard(|| Ok(7)), Ok(7));
    }

    #[test]
    fn errors_become_a_status_with_the_message() {
        let r: Result<(), Status> = guard(|| Err(Error::new("not calibrated")));
        assert_eq!(r, Err(Status::ERROR));
        assert_eq!(last(), "not calibrated");
        let view = last_error();
        assert_eq!(view.len, "not calibrated".len());
    }
}
