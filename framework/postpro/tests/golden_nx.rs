//! Our programs against the ones Siemens NX's own Haas UMC-750 post wrote from the same CLSFs
//! (`../shared/data/peers/userFour__MECH491-postprocessor`): postpro on `haas-umc750`, in its
//! defaults (the haas dialect, inches, the mode chosen from the tool path), must write the same
//! motion. Every motion block of NX's program appears in ours, in order, with the same X Y Z
//! (1e-4 in) and B C (0.001°); every NX arc is one of ours with the same end point, centre and
//! sense. Ours has more blocks (the approach across at the clearance, the retracts), never other
//! ones.

mod common;

use std::path::Path;

use tests::compare::{arcs_match, motions_in_order};
use tests::golden::{self, Case, fanuc};
use tests::nc::{MotionKind, Program, Units};

use common::{postpro, scratch, stderr};

fn read(path: &Path) -> Program {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    fanuc::read(&path.display().to_string(), &text).unwrap_or_else(|e| panic!("{e}"))
}

/// Our program of a case (written into a scratch folder), with `extra` options.
fn ours(case: &Case, extra: &[&str]) -> (Program, String) {
    let dir = scratch("golden_nx", &case.name.replace('/', "_"), &[]);
    let out = dir.join("ours.nc");
    let input = case.input.display().to_string();
    let mut args = vec!["--machine", "haas-umc750", "--no-predict", "-o", "ours.nc"];
    args.extend_from_slice(extra);
    args.push(&input);
    let o = postpro(&args, &dir);
    assert!(o.status.success(), "{}: {}", case.name, stderr(&o));
    let text = std::fs::read_to_string(&out).expect("our program");
    (read(&out), text)
}

fn case(name: &str) -> Case {
    let cases = golden::nx_haas_cases();
    assert_eq!(cases.len(), 5, "the five NX pairs: {cases:?}");
    cases.into_iter().find(|c| c.name.ends_with(name)).unwrap_or_else(|| panic!("no case {name}"))
}

#[test]
fn the_simultaneous_five_axis_program_is_nx_s_block_for_block() {
    let case = case("/Variable_Axis");
    let theirs = read(&case.expected[0]);
    let (ours, text) = ours(&case, &[]);
    assert_eq!((ours.units, theirs.units), (Units::Inch, Units::Inch));
    // TCP with the machine's angles: G234 H…, B and C on the moves.
    assert!(text.contains("\nG234 H1\n"), "{text}");
    assert!(text.contains("mode tcp"), "auto mode is TCP for a simultaneous program:\n{text}");
    let c = motions_in_order(&ours.motions, &theirs.motions, 1e-4 + 1e-9, 1e-3 + 1e-9);
    assert!(c.is_match(), "{c}");
    assert_eq!(c.compared, theirs.motions.len());
    assert!(c.compared > 340, "{c}");
    eprintln!("Variable_Axis: NX's motion blocks in ours: {c}");
    // The pole passages NX writes (its README): C swings 79° in one block, B changes sign once.
    for block in ["B-.613 C-407.836", "B1.54 C-372.487", "B3.19 C-285.651"] {
        let expected: Vec<f64> = block.split(' ').map(|w| w[1..].parse::<f64>().expect("a number")).collect::<Vec<_>>();
        let found = ours.motions.iter().any(|m| {
            m.rotary.b.is_some_and(|b| (b - expected[0]).abs() < 1e-3)
                && m.rotary.c.is_some_and(|c| (c - expected[1]).abs() < 1e-3)
        });
        assert!(found, "{block} is in ours");
    }
}

/// In G1 the points linearization adds are written, and on this file they go round the pole:
/// NX's passages swing C by up to 79° in one block (the controller's TCP keeps the tip on the
/// part). Ours must bring every block within the tolerance, which needs the axes continuous
/// along each move: a point on the other branch turned C by half a turn in one block, the tip
/// 76 mm off the path (line 224).
#[test]
fn in_g1_the_moves_round_the_pole_stay_within_tolerance() {
    let case = case("/Variable_Axis");
    let dir = scratch("golden_nx", "Variable_Axis_g1", &[]);
    let input = case.input.display().to_string();
    let o = postpro(&["--machine", "haas-umc750", "--no-predict", "--mode", "g1", "-o", "g1.nc", &input], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("stray"), "every move within tolerance:\n{}", stderr(&o));
    let ours = read(&dir.join("g1.nc"));
    let (mut largest, mut previous): (f64, Option<f64>) = (0.0, None);
    for m in &ours.motions {
        if let (Some(c), Some(before)) = (m.rotary.c, previous)
            && m.kind == MotionKind::Feed
        {
            largest = largest.max((c - before).abs());
        }
        previous = m.rotary.c.or(previous);
    }
    assert!(largest > 10.0 && largest < 79.0, "the largest turn of C in one feed block: {largest}°");
}

#[test]
fn the_three_axis_programs_are_nx_s_positions_and_arcs() {
    for name in ["/SimpleMillPlane", "/SimpleMillPlane_ZIG", "/Zig_Zag_Smoothed", "/Zig_Zag_Smoothed_61c3654"] {
        let case = case(name);
        let theirs = read(&case.expected[0]);
        let (ours, text) = ours(&case, &[]);
        assert!(text.contains("mode g1"), "{name}: a 3-axis program stays in G1");
        // The rotaries set at the start and locked, as NX does.
        assert!(text.contains("M12 (B-AXIS LOCK)") && text.contains("M10 (C-AXIS LOCK)"), "{name}:\n{text}");
        let c = motions_in_order(&ours.motions, &theirs.motions, 1e-4 + 1e-9, 1e-3 + 1e-9);
        assert!(c.is_match(), "{name}: {c}");
        let arcs = arcs_match(&ours.motions, &theirs.motions, 1e-4);
        assert!(arcs.is_match(), "{name}: {arcs}");
        assert!(arcs.compared >= 1, "{name}: {arcs}");
        eprintln!("{name}: NX's motion blocks in ours: {c}; NX's arcs in ours: {arcs}");
    }
}
