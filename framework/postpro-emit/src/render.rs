//! Rendering the program with the dialect's template (minijinja, strict undefined: a template
//! that names a field the context lacks is an error, never an empty string).

use minijinja::{Environment, UndefinedBehavior};

use crate::EmitError;
use crate::program::Program;

/// The built-in templates, by dialect name.
pub const TEMPLATES: &[(&str, &str)] = &[
    ("siemens-840d", include_str!("../../../templates/siemens-840d.j2")),
    ("fanuc", include_str!("../../../templates/fanuc.j2")),
    ("heidenhain", include_str!("../../../templates/heidenhain.j2")),
    ("linuxcnc", include_str!("../../../templates/linuxcnc.j2")),
];

/// The built-in template of a dialect.
pub fn builtin_template(dialect: &str) -> Option<&'static str> {
    TEMPLATES.iter().find(|(d, _)| *d == dialect).map(|(_, t)| *t)
}

/// Renders `program` with the template `source` (named `name` in errors).
pub fn render(program: &Program, name: &str, source: &str) -> Result<String, EmitError> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    env.set_keep_trailing_newline(true);
    env.add_template(name, source)
        .map_err(|e| EmitError::Template { name: name.to_string(), message: describe(&e) })?;
    let template =
        env.get_template(name).map_err(|e| EmitError::Template { name: name.to_string(), message: describe(&e) })?;
    template.render(program).map_err(|e| EmitError::Template { name: name.to_string(), message: describe(&e) })
}

/// minijinja's error with its template line and the chain of causes.
fn describe(e: &minijinja::Error) -> String {
    let mut s = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(cause) = source {
        s.push_str(&format!(": {cause}"));
        source = cause.source();
    }
    s
}
