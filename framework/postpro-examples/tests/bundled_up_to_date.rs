//! The example CL files stored in `examples/cl/` must equal what the generator produces.

use std::path::PathBuf;

#[test]
fn bundled_examples_are_up_to_date() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/cl");
    let mut stale = Vec::new();
    for (name, expected) in postpro_examples::bundled_examples().into_iter().chain(postpro_examples::extra_examples()) {
        let path = dir.join(name);
        match std::fs::read(&path) {
            Ok(actual) if actual == expected.as_bytes() => {}
            Ok(actual) => {
                let first_difference = actual
                    .split(|b| *b == b'\n')
                    .zip(expected.as_bytes().split(|b| *b == b'\n'))
                    .position(|(a, e)| a != e)
                    .map_or_else(
                        || "one file is a prefix of the other".to_owned(),
                        |line| format!("first difference on line {}", line + 1),
                    );
                stale.push(format!(
                    "{} differs ({} bytes stored, {} generated; {first_difference})",
                    path.display(),
                    actual.len(),
                    expected.len()
                ));
            }
            Err(e) => stale.push(format!("{} cannot be read: {e}", path.display())),
        }
    }
    assert!(
        stale.is_empty(),
        "the bundled example CL files are out of date:\n  {}\n\
         run `cargo run -p postpro-examples -- write` to regenerate them",
        stale.join("\n  ")
    );
}
