use super::*;
use crate::testing::{close, close3};

#[test]
fn every_block_gets_its_line_as_n_word() {
    let text = "%\nN85 G0 X1\n  g1 x2 f100\n\n/N9 G0 X3\n/ G0 X4\n(comment)\nn 12 M2\r\n%\n";
    assert_eq!(numbered(text), "%\nN2 G0 X1\nN3 g1 x2 f100\n\n/N5 G0 X3\n/N6 G0 X4\nN7 (comment)\nN8 M2\n%\n");
    assert_eq!(block_number("N123456 G0 X1"), Some(123_456));
    assert_eq!(block_number("/N5 G0"), Some(5));
    assert_eq!(block_number("G0 X1"), None);
}

#[test]
fn output_rows_give_the_line_and_the_call() {
    assert_eq!(split_row("    7 N3     STRAIGHT_FEED(1.0000)"), Some((3, "STRAIGHT_FEED(1.0000)")));
    assert_eq!(split_row("   12 N123456STRAIGHT_TRAVERSE(1.0000)"), Some((123_456, "STRAIGHT_TRAVERSE(1.0000)")));
    assert_eq!(
        split_row("    1 N..... USE_LENGTH_UNITS(CANON_UNITS_MM)"),
        Some((0, "USE_LENGTH_UNITS(CANON_UNITS_MM)"))
    );
    assert_eq!(split_row("executing"), None);
}

#[test]
fn the_tool_table_is_in_inches_without_tool_zero() {
    let table = tool_table(&[(0, 5.0, 1.0), (1, 25.4, 12.7), (12, 100.0, 6.0)]);
    let rows: Vec<&str> = table.lines().filter(|l| !l.starts_with(';')).collect();
    assert_eq!(
        rows,
        [
            "T1 P1 Z1 D0.5 ;length 25.4 mm, diameter 12.7 mm",
            "T12 P12 Z3.937007874015748 D0.2362204724409449 ;length 100 mm, diameter 6 mm"
        ]
    );
}

/// Canonical calls as rs274 prints them, read without running it: units switch after the first
/// motion (positions converted to the first motion's), a tool change with its length offset,
/// an XZ arc.
#[test]
fn canonical_calls_read_into_motions_and_events() {
    let canon = "\
    1 N..... USE_LENGTH_UNITS(CANON_UNITS_MM)
    2 N..... SET_G5X_OFFSET(1, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)
    6 N..... ON_RESET()
    7 N1     USE_LENGTH_UNITS(CANON_UNITS_MM)
    8 N2     SELECT_TOOL(4)
    9 N2     CHANGE_TOOL(1)
   10 N3     USE_TOOL_LENGTH_OFFSET(0.0000 0.0000 10.0000, 0.0000 0.0000 0.0000, 0.0000 0.0000 0.0000)
   11 N4     STRAIGHT_TRAVERSE(10.0000, 0.0000, 5.0000, 0.0000, 30.0000, 0.0000)
   12 N5     SET_FEED_RATE(100.0000)
   13 N5     SELECT_PLANE(CANON_PLANE_XZ)
   14 N6     ARC_FEED(-5.0000, 5.0000, 5.0000, 5.0000, -2, 0.0000, 0.0000, 30.0000, 0.0000)
   15 N7     USE_LENGTH_UNITS(CANON_UNITS_INCHES)
   16 N8     STRAIGHT_FEED(1.0000, 0.0000, 0.0000, 0.0000, 30.0000, 0.0000)
   17 N9     PROGRAM_END()
   18 N..... ON_RESET()";
    let p = read_canon("t.ngc", canon).expect("reads");
    assert_eq!(p.units, Units::Mm);
    assert_eq!(p.motions.len(), 3);
    let arc = p.motions[1];
    assert_eq!((arc.line, arc.from, arc.to), (6, [10.0, 0.0, 5.0], [5.0, 0.0, -5.0]));
    assert_eq!(arc.arc(), Some(&Arc { center: [5.0, 0.0, 5.0], plane: Plane::Zx, clockwise: true, full_turns: 1 }));
    assert_eq!(arc.rotary.b, Some(30.0));
    assert_eq!(arc.feed, Some(100.0));
    // In inches after line 7: converted back to the program's millimetres.
    assert!(close3(p.motions[2].to, [25.4, 0.0, 0.0], 1e-12));
    assert!(close(p.motions[2].feed.unwrap_or(0.0), 100.0, 1e-9));
    let kinds: Vec<&EventKind> = p.events.iter().map(|e| &e.kind).collect();
    assert!(kinds.contains(&&EventKind::ToolChange { tool: 4 }));
    assert!(kinds.contains(&&EventKind::LengthOffset { register: None, offset: Some([0.0, 0.0, 10.0]) }));
    assert!(kinds.contains(&&EventKind::End));
    // The offset moved the tip's work-frame position before the first motion.
    assert_eq!(p.motions[0].from, [0.0, 0.0, -10.0]);
}

#[test]
fn calls_the_harness_does_not_model_are_errors() {
    let probe = "    9 N4     STRAIGHT_PROBE(1.0000, 1.0000, -10.0000, 0.0000, 0.0000, 0.0000)\n";
    let e = read_canon("p.ngc", probe).expect_err("a probe");
    assert_eq!(
        e.to_string(),
        "p.ngc:4: rs274 printed `STRAIGHT_PROBE(1.0000, 1.0000, -10.0000, 0.0000, 0.0000, 0.0000)`: \
         a motion the harness does not model"
    );
    let unfinished = "    8 N2     STRAIGHT_TRAVERSE(1.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.0000)\n";
    let e = read_canon("p.ngc", unfinished).expect_err("no end");
    assert_eq!(e.to_string(), "p.ngc:?: rs274: the program did not reach its end (M2 or M30)");
}

/// Runs `text` through the installed rs274, if any.
fn run(text: &str, tools: &[(u32, f64, f64)]) -> Option<Result<Program, Error>> {
    Rs274::for_test().map(|rs274| rs274.run_text("t.ngc", text, tools))
}

/// In G93 with F1, rs274 gives each block the feed rate of its length per minute: so every
/// arc's length as the model computes it must equal the rate rs274 computed. Arcs in the three
/// planes, both senses, full circles, P turns and helices.
#[test]
fn arcs_read_from_rs274_are_as_long_as_rs274_says() {
    let text = "G21 G90 G93
G17 G0 X10 Y0 Z0
G3 X0 Y10 I-10 J0 F1
G2 X10 Y0 I0 J-10 F1
G3 X10 Y0 I-10 J0 P3 F1
G2 X0 Y10 I-10 J0 P2 Z5 F1
G18 G0 X10 Y0 Z0
G3 X0 Z-10 I-10 K0 F1
G2 X10 Z0 I0 K10 F1
G2 X0 Z-10 I-10 K0 Y7 P2 F1
G19 G0 X0 Y10 Z0
G3 Y0 Z10 J-10 K0 F1
G2 Y10 Z0 J0 K-10 X3 P2 F1
G94
M2
";
    let Some(result) = run(text, &[]) else { return };
    let p = result.expect("rs274 runs it");
    let arcs: Vec<&Motion> = p.motions.iter().filter(|m| m.arc().is_some()).collect();
    assert_eq!(arcs.len(), 9);
    let planes: Vec<Plane> = arcs.iter().filter_map(|m| m.arc().map(|a| a.plane)).collect();
    assert_eq!(
        planes,
        [Plane::Xy, Plane::Xy, Plane::Xy, Plane::Xy, Plane::Zx, Plane::Zx, Plane::Zx, Plane::Yz, Plane::Yz]
    );
    let senses: Vec<(bool, u32)> = arcs.iter().filter_map(|m| m.arc().map(|a| (a.clockwise, a.full_turns))).collect();
    assert_eq!(
        senses,
        [(false, 0), (true, 0), (false, 2), (true, 1), (false, 0), (true, 0), (true, 1), (false, 0), (true, 1)]
    );
    for m in &arcs {
        let rate = m.feed.unwrap_or(0.0);
        assert!(close(m.length(), rate, 1e-4), "line {}: length {} against rs274's {rate}", m.line, m.length());
    }
    // The quarter G3 in G18 turns about +Y from X10 Z0 to X0 Z-10 through X7.07 Z-7.07.
    assert!(close3(arcs[4].point_at(0.5), [50f64.sqrt(), 0.0, -(50f64.sqrt())], 1e-4));
    assert!(p.events.iter().any(|e| e.kind == EventKind::InverseTime(true)));
}

#[test]
fn the_tool_table_gives_the_lengths_in_millimetres_and_inches() {
    let tools = [(1, 10.0, 4.0), (7, 127.0, 12.0)];
    let Some(result) = run("G21\nT7 M6\nG43 H7\nG0 X1 Z2\nT1 M6\nG43 H1\nG0 Z2\nM30\n", &tools) else { return };
    let p = result.unwrap_or_else(|e| panic!("{e}"));
    let offsets: Vec<[f64; 3]> = p
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::LengthOffset { offset, .. } => offset,
            _ => None,
        })
        .collect();
    assert_eq!(offsets.len(), 2);
    assert!(close(offsets[0][2], 127.0, 1e-4) && close(offsets[1][2], 10.0, 1e-4), "{offsets:?}");
    let changes: Vec<u32> = p
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::ToolChange { tool } => Some(tool),
            _ => None,
        })
        .collect();
    assert_eq!(changes, [7, 1]);
    // The tool stays put when its offset changes: the next move starts 117 higher.
    assert!(close3(p.motions[1].from, [1.0, 0.0, 2.0 + 117.0], 1e-4), "{:?}", p.motions[1]);
    let Some(result) = run("G20\nT1 M6\nG43 H1\nG0 X1\nM30\n", &tools) else { return };
    let p = result.unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(p.units, Units::Inch);
    assert!(
        p.events.iter().any(
            |e| matches!(e.kind, EventKind::LengthOffset { offset: Some(o), .. } if close(o[2], 10.0 / 25.4, 1e-4))
        )
    );
}

#[test]
fn work_offsets_and_machine_moves_are_in_the_work_frame() {
    let text = "G21 G90\nG10 L2 P2 X100 Y200 Z-300\nG55\nG0 X1 Y2 Z3\nG53 G0 Z0\nM2\n";
    let Some(result) = run(text, &[]) else { return };
    let p = result.unwrap_or_else(|e| panic!("{e}"));
    assert!(p.events.iter().any(|e| e.kind
        == EventKind::WorkOffset { name: "G55".into(), offset: Some([Some(100.0), Some(200.0), Some(-300.0)]) }));
    let to: Vec<[f64; 3]> = p.motions.iter().map(|m| m.to).collect();
    // G53 Z0 is machine Z0: 300 above the work offset's zero.
    assert_eq!(to, [[1.0, 2.0, 3.0], [1.0, 2.0, 300.0]]);
}

/// rs274 expands canned cycles: the feeds of each reach the hole's depth, pecks included, and
/// the retracts are rapids (G85 feeds out).
#[test]
fn canned_cycles_come_expanded() {
    let text = "G21 G90 G17 G0 X0 Y0 Z10
G98 G81 X10 Y10 Z-5 R2 F100
G99 G82 X20 Z-5 R2 P0.5
G83 X30 Z-5 R2 Q2
G73 X40 Z-5 R2 Q2
G85 X50 Z-5 R2
G80
M2
";
    let Some(result) = run(text, &[]) else { return };
    let p = result.unwrap_or_else(|e| panic!("{e}"));
    for (line, x) in [(2, 10.0), (3, 20.0), (4, 30.0), (5, 40.0), (6, 50.0)] {
        let moves: Vec<&Motion> = p.motions.iter().filter(|m| m.line == line).collect();
        let deepest = moves.iter().map(|m| m.to[2]).fold(f64::INFINITY, f64::min);
        assert!(close(deepest, -5.0, 1e-9), "line {line}");
        assert!(moves.iter().all(|m| m.to[0] == x || m.from[0] != x), "line {line}");
        assert!(moves.iter().filter(|m| m.is_feed()).all(|m| m.from[0] == x && m.from[1] == 10.0), "line {line}");
    }
    let pecks = p.motions.iter().filter(|m| m.line == 4 && m.is_feed()).count();
    assert_eq!(pecks, 4, "G83 from R2 to Z-5 in pecks of 2: to 0, -2, -4, -5");
    assert!(p.motions.iter().any(|m| m.line == 6 && m.is_feed() && m.to[2] == 2.0), "G85 feeds out");
    assert!(p.events.iter().any(|e| e.line == 3 && e.kind == EventKind::Dwell { seconds: 0.5 }));
}

#[test]
fn an_error_of_rs274_names_its_line_and_message() {
    let Some(result) = run("G21\nG0 X1\n  G1 X2\nM2\n", &[]) else { return };
    let e = result.expect_err("no feed");
    assert_eq!(e.to_string(), "t.ngc:3: rs274: Cannot do g1 with zero feed rate (`G1 X2`)");
    let Some(result) = run("G21\nT3 M6\nM2\n", &[(1, 10.0, 4.0)]) else { return };
    assert_eq!(
        result.expect_err("no tool 3").to_string(),
        "t.ngc:2: rs274: Requested tool 3 not found in the tool table (`T3 M6`)"
    );
    let Some(result) = run("G21\nG0 X1\n", &[]) else { return };
    assert_eq!(
        result.expect_err("no end").to_string(),
        "t.ngc:2: rs274: File ended with no percent sign or program end (`G0 X1`)"
    );
}
