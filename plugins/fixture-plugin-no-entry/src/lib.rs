//! Test fixture: a shared library that is not a postpro plugin. It exports no
//! `postpro_plugin_entry` (as if its author forgot `export_plugin!`, or another library was put
//! in the plugins folder): the host must say so and go on with the other plugins.

/// A function of the library (not exported under a C name).
pub fn answer() -> u32 {
    42
}
