//! Test fixture: a plugin built for another ABI. It exports `postpro_plugin_entry`, but the entry
//! is that of an imagined ABI version 7, with another layout (smaller than version 1's): the host
//! must read its first field alone, refuse the library with "ABI version 7, expected 1", and go
//! on with the other plugins.
//!
//! Written by hand, without `postpro_plugin_api::export_plugin!` (which always writes the current
//! version), so the exported symbol needs the one `unsafe` attribute below.

/// The entry of the imagined ABI version 7: the version first, as in every version.
#[repr(C)]
#[derive(Debug)]
pub struct EntryV7 {
    /// The ABI version: 7.
    pub abi_version: u32,
    /// Whatever version 7 has next.
    pub flags: u32,
}

const ENTRY: EntryV7 = EntryV7 { abi_version: 7, flags: 0 };

/// The entry symbol, with the version-7 entry.
#[allow(unsafe_code)] // `no_mangle` exports the symbol by name: the fixture has no macro to do it
#[unsafe(no_mangle)]
pub extern "C" fn postpro_plugin_entry() -> *const EntryV7 {
    &ENTRY
}
