use super::*;
use crate::compare::{arcs_match, feed_path_length, motions_in_order};
use crate::nc::{Frame, Plane};
use crate::rs274::Rs274;

fn kinds(p: &Program) -> Vec<&'static str> {
    p.motions
        .iter()
        .map(|m| match m.kind {
            MotionKind::Rapid => "rapid",
            MotionKind::Feed => "feed",
            MotionKind::Arc(_) => "arc",
        })
        .collect()
}

fn close3(a: [f64; 3], b: [f64; 3]) -> bool {
    crate::testing::close3(a, b, 1e-9)
}

/// Each text is refused by `read` with the message.
fn refused(read: fn(&str, &str) -> Result<Program, Error>, name: &str, cases: &[(&str, &str)]) {
    for (text, expected) in cases {
        let e = read(name, text).expect_err(text);
        assert_eq!(e.to_string(), *expected);
    }
}

#[test]
fn pecks_end_at_the_bottom() {
    assert_eq!(peck_depths(2.0, -5.0, Some(2.0)), [0.0, -2.0, -4.0, -5.0]);
    assert_eq!(peck_depths(2.0, -4.0, Some(2.0)), [0.0, -2.0, -4.0]);
    assert_eq!(peck_depths(2.0, -5.0, Some(10.0)), [-5.0]);
    assert_eq!(peck_depths(2.0, -5.0, None), [-5.0]);
}

/// The shape of the NX Haas post's programs: listing lines outside `%`, a named `O` line, block
/// numbers, machine-frame moves, B/C, G43 with its Z, modal G0/G1/G3, I J centres and R.
#[test]
fn fanuc_reads_a_program_as_the_nx_haas_post_writes_it() {
    let text = "\u{feff}Information listing created by\tx
%
Otest_part
(PROGRAMMED  UNIT: IN)
N5 G40 G17 G94 G98 G90 G00 G49 G20
N10 G53 G00 Z0.0
N15 G91 G28 X0.0 Y0.0
N20 G91 G28 B0.0 C0.0
N25 G90
N30 T1 M06
N55 G17 G54 G90
N70 G00 B0.0 C0.0
N85 G90 G00 X-1. Y1. M08
N90 G43 H01 D01 Z2.
N95 G01 Z1. F10.
N100 G03 X0.0 Y0.0 I1. J0.0
N105 G01 X2.
N110 G02 X3. Y1. R1.
N115 G03 X2. Y2. R-1.
N120 M30
%
Tool Path Listing has 20 lines.";
    let p = fanuc::read("t.txt", text).expect("reads");
    assert_eq!(p.units, Units::Inch);
    assert_eq!(kinds(&p), ["rapid", "feed", "arc", "feed", "arc", "arc"]);
    assert_eq!(p.motions.iter().map(|m| m.line).collect::<Vec<_>>(), [14, 15, 16, 17, 18, 19]);
    // N90 leaves Z0 of the machine: its start is not known in the work frame along Z.
    assert!(!p.motions[0].from_known && p.motions[1].from_known);
    assert_eq!(p.motions[0].to, [-1.0, 1.0, 2.0]);
    assert_eq!(p.motions[0].rotary.b, Some(0.0));
    assert_eq!(p.motions[1].feed, Some(10.0));
    // A quarter counter-clockwise about (0, 1) from (-1, 1) to (0, 0).
    let quarter = p.motions[2].arc().copied().expect("an arc");
    assert_eq!((quarter.center, quarter.plane, quarter.clockwise), ([0.0, 1.0, 1.0], Plane::Xy, false));
    assert!((p.motions[2].sweep().unwrap_or(0.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    // R1 clockwise from (2, 0) to (3, 1): the short way, about (3, 0); R-1 counter-clockwise
    // from (3, 1) to (2, 2): the long way, about (3, 2).
    let short = p.motions[4].arc().copied().expect("an arc");
    assert!(close3(short.center, [3.0, 0.0, 1.0]) && short.clockwise, "{short:?}");
    assert!((p.motions[4].sweep().unwrap_or(0.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    let long = p.motions[5];
    assert!(close3(long.arc().map(|a| a.center).unwrap_or_default(), [3.0, 2.0, 1.0]), "{long:?}");
    assert!((long.sweep().unwrap_or(0.0) - 1.5 * std::f64::consts::PI).abs() < 1e-12);
    let events: Vec<&EventKind> = p.events.iter().map(|e| &e.kind).collect();
    let machine: Vec<(&str, &[char])> = events
        .iter()
        .filter_map(|e| match e {
            EventKind::MachineFrameMove { code, axes } => Some((code.as_str(), axes.as_slice())),
            _ => None,
        })
        .collect();
    assert_eq!(machine, [("G53", &['Z'][..]), ("G28", &['X', 'Y'][..]), ("G28", &['B', 'C'][..])]);
    assert!(events.contains(&&EventKind::ToolChange { tool: 1 }));
    assert!(events.contains(&&EventKind::WorkOffset { name: "G54".into(), offset: None }));
    assert!(events.contains(&&EventKind::LengthOffset { register: Some(1), offset: None }));
    assert!(events.contains(&&EventKind::Positioning { rapid: true, to: [Some(-1.0), Some(1.0), None] }));
    assert_eq!(events.last(), Some(&&EventKind::End));
}

#[test]
fn fanuc_errors_name_the_line_and_column() {
    let cases = [
        ("G20\nG0 X1 Y1 Z1\nG41 D1 G1 X2 F10\n", "t:3:1: cutter radius compensation: the path is not the tool's"),
        ("G0 X1\n", "t:1:1: a length before the units: expected G20 or G21 first"),
        ("G21 G0 X0 Y0 Z0\nG1 X1 E5 F100\n", "t:2:7: `E` is not a word this reader knows"),
        ("G21 G0 X0 Y0 Z0\nG1 X1\n", "t:2:1: a feed move without a feed rate (no F yet)"),
        ("G21 G0 X0 Y0 Z0\nG2 X10 Y0 I3 F100\n", "t:2:1: the arc's end radius 7 differs from its start radius 3"),
        ("G21 G0 X0 Y0 Z0\nM98 P100\n", "t:2:1: subprogram calls are not followed"),
        ("G21 G0 X0 Y0 Z0\nG1 X1 (open\n", "t:2:7: a comment without its `)`"),
        ("G21 G0 X0 Y0 Z0\nG68 X0 Y0 R45\n", "t:2:1: G68 is not read by this parser"),
        ("G21 G0 X0 Y0 Z0\nG1 X1 X2 F1\n", "t:2:7: `X` twice in one block"),
    ];
    refused(fanuc::read, "t", &cases);
}

/// The same program read by the Fanuc reader and by LinuxCNC's rs274 (arcs in the three
/// planes, by centre and by radius, a helix, the drilling cycles with G98 and G99): the same
/// motions both ways, the same arcs, the same feed path.
#[test]
fn fanuc_reads_programs_as_rs274_does() {
    let text = "G21 G90 G94 G17
G0 X0 Y0 Z10
G1 Z0 F500
G2 X10 Y10 I10 J0
G3 X20 Y0 R10
G2 X20 Y0 I-5 J0 Z-2
G18 G2 X30 Z-12 I0 K-10
G3 X20 Z-2 R-10
G19 G3 Y10 Z8 J10 K0
G17 G0 Z20
G98 G81 X40 Y40 Z-5 R2 F200
G83 X60 Z-7 R2 Q2
G73 X70 Z-7 R2 Q2
G85 X80 Z-5 R2
G99 G82 X50 Z-5 R2 P1
X60
G80
G0 X0 Y0 Z30
M2
";
    let ours = fanuc::read("t.ngc", text).unwrap_or_else(|e| panic!("{e}"));
    let Some(rs274) = Rs274::for_test() else { return };
    let theirs = rs274.run_text("t.ngc", text, &[]).unwrap_or_else(|e| panic!("{e}"));
    for (a, b, what) in [(&ours, &theirs, "rs274's in the reader's"), (&theirs, &ours, "the reader's in rs274's")] {
        let c = motions_in_order(&a.motions, &b.motions, 1e-4, 1e-4);
        assert!(c.is_match(), "{what}: {c}");
        let c = arcs_match(&a.motions, &b.motions, 1e-4);
        assert!(c.is_match() && c.compared == 6, "{what}: {c}");
    }
    let (a, b) = (feed_path_length(&ours.motions), feed_path_length(&theirs.motions));
    assert!((a - b).abs() < 1e-3, "{a} against {b}");
    let holes = ours.events.iter().filter(|e| matches!(e.kind, EventKind::Hole { .. })).count();
    assert_eq!(holes, 6);
}

/// A Heidenhain program in clsplit's style, with a datum shift, machine-frame retracts, a
/// pecking cycle at two holes, arcs, a full circle and a helix.
#[test]
fn heidenhain_reads_a_program_as_clsplit_writes_it() {
    let text = "2 BEGIN PGM 11 MM
3 ;First setup
19 CYCL DEF 7.0 DATUM SHIFT
20 CYCL DEF 7.1 X+10.000
21 CYCL DEF 7.2 Y+0.000
22 CYCL DEF 7.3 Z+0.000
24 L Z-10 FMAX M91
26 TOOL DEF 114 L+1.000 R+0.000
27 TOOL CALL 114 Z S1500
35 L X+0 Y+0 Z+25 FMAX M09
39 CYCL DEF 1.0 PECKING
40 CYCL DEF 1.1 DIST25.000
41 CYCL DEF 1.2 DEPTH-5.000
42 CYCL DEF 1.3 PLNGNG3.0
43 CYCL DEF 1.4 DWELL0
44 CYCL DEF 1.5 F500
46 L FMAX M99
48 L X+20 FMAX M99
50 L Z 2.000 FMAX
51 L Z-1 F100 M08
52 L X+30
53 CC X+30 Y+10
54 C X+40 Y+10 DR+ F200
55 C DR-
56 CP IPA+720 IZ-2 DR+
57 L Z-10 R0 FMAX M91 M9
58 M30
59 END PGM 11 MM
";
    let p = heidenhain::read("11.h", text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(p.units, Units::Mm);
    // The datum is shifted 10 in X: every X is 10 more in the program's start frame.
    assert_eq!(p.motions[0].to, [10.0, 0.0, 25.0]);
    assert!(!p.motions[0].from_known);
    // Cycle 1 at each hole: from 25 (the set-up clearance over the surface at 0) to −5 in
    // pecks of 3, retracting to 25 and back to 0.6 above the depth reached. (Lines are the
    // file's: block 46 is line 17.)
    let hole: Vec<(&str, f64)> = p
        .motions
        .iter()
        .filter(|m| m.line == 17)
        .map(|m| (if m.is_feed() { "feed" } else { "rapid" }, m.to[2]))
        .collect();
    assert_eq!(hole, [("feed", -3.0), ("rapid", 25.0), ("rapid", -2.4), ("feed", -5.0), ("rapid", 25.0)]);
    let holes: Vec<[f64; 3]> = p
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Hole { at, bottom, .. } => Some([at[0], at[1], bottom]),
            _ => None,
        })
        .collect();
    assert_eq!(holes, [[10.0, 0.0, -5.0], [30.0, 0.0, -5.0]]);
    // FMAX holds for its block; F is modal.
    let by_line = |line: usize| p.motions.iter().find(|m| m.line == line).copied().expect("a motion");
    assert_eq!((by_line(19).feed, by_line(20).feed, by_line(21).feed), (None, Some(100.0), Some(100.0)));
    assert_eq!(by_line(19).to, [30.0, 0.0, 2.0]);
    // C about CC (40, 10) (30 + the shift): a quarter counter-clockwise from (40, 0) to (50, 10),
    // then a full circle clockwise, then two turns of helix down 2.
    let quarter = by_line(23);
    assert_eq!(quarter.arc().map(|a| (a.center, a.clockwise)), Some(([40.0, 10.0, -1.0], false)));
    assert!((quarter.length() - 5.0 * std::f64::consts::PI).abs() < 1e-9);
    let full = by_line(24);
    assert!(full.arc().is_some_and(|a| a.clockwise) && close3(full.to, [50.0, 10.0, -1.0]));
    assert!((full.length() - 20.0 * std::f64::consts::PI).abs() < 1e-9);
    let helix = by_line(25);
    assert!(close3(helix.to, [50.0, 10.0, -3.0]), "{helix:?}");
    assert_eq!(helix.arc().map(|a| a.full_turns), Some(1));
    assert!((helix.length() - (40.0 * std::f64::consts::PI).hypot(2.0)).abs() < 1e-9);
    let events: Vec<&EventKind> = p.events.iter().map(|e| &e.kind).collect();
    assert!(events.contains(&&EventKind::WorkOffset {
        name: "CYCL DEF 7".into(),
        offset: Some([Some(10.0), Some(0.0), Some(0.0)])
    }));
    assert!(events.contains(&&EventKind::ToolChange { tool: 114 }));
    assert!(events.contains(&&EventKind::ToolDefinition { tool: 114, length: Some(1.0), radius: Some(0.0) }));
    let retracts =
        events.iter().filter(|e| matches!(e, EventKind::MachineFrameMove { code, .. } if code == "M91")).count();
    assert_eq!(retracts, 2);
}

/// Cycles 200 and 203 as the TNC manual describes them.
#[test]
fn heidenhain_drilling_cycles_200_and_203_expand_as_the_manual_says() {
    let text = "0 BEGIN PGM C MM
1 TOOL CALL 1 Z S3000
2 L X+0 Y+0 Z+50 R0 FMAX
3 CYCL DEF 200 DRILLING ~
  Q200=+2 ;SET-UP CLEARANCE ~
  Q201=-15 ;DEPTH ~
  Q206=+150 ;FEED RATE FOR PLUNGING ~
  Q202=+5 ;PLUNGING DEPTH ~
  Q210=+0 ;DWELL TIME AT TOP ~
  Q203=+0 ;SURFACE COORDINATE ~
  Q204=+50 ;2ND SET-UP CLEARANCE ~
  Q211=+0.5 ;DWELL TIME AT DEPTH
4 L X+10 FMAX M99
5 CYCL DEF 203 UNIVERSAL DRILLING
  Q200=2
  Q201=-20
  Q206=150
  Q202=8
  Q210=0
  Q203=-1
  Q204=50
  Q212=2
  Q213=1
  Q205=3
  Q211=0
  Q208=500
  Q256=0.2
6 L X+20 FMAX
7 CYCL CALL
8 END PGM C MM
";
    let p = heidenhain::read("c.h", text).unwrap_or_else(|e| panic!("{e}"));
    // The moves of a call's line, but the move across at the clearance height.
    let steps = |line: usize| -> Vec<(&'static str, f64)> {
        p.motions
            .iter()
            .filter(|m| m.line == line && (m.from[2], m.to[2]) != (50.0, 50.0))
            .map(|m| (if m.is_feed() { "feed" } else { "rapid" }, (m.to[2] * 1e9).round() / 1e9))
            .collect()
    };
    // (Lines are the file's: the calls are on lines 13 and 29.)
    // 200: down to 2 above the surface, pecks of 5 with a retract to the set-up clearance and a
    // rapid back to 2 above the depth reached; at the bottom a dwell, then up to 50 (the 2nd
    // set-up clearance, straight up through the first).
    assert_eq!(
        steps(13),
        [
            ("rapid", 2.0),
            ("feed", -5.0),
            ("rapid", 2.0),
            ("rapid", -3.0),
            ("feed", -10.0),
            ("rapid", 2.0),
            ("rapid", -8.0),
            ("feed", -15.0),
            ("rapid", 50.0)
        ]
    );
    assert!(p.events.iter().any(|e| e.line == 13 && e.kind == EventKind::Dwell { seconds: 0.5 }));
    // 203 on a surface at −1: pecks of 8, then 6, then 4 (decrement 2), to −21; one chip break
    // (0.2 back) before each full retract at Q208's feed; out at Q208's feed.
    assert_eq!(
        steps(29),
        [
            ("rapid", 1.0),
            ("feed", -9.0),
            ("rapid", -8.8),
            ("feed", -15.0),
            ("feed", 1.0),
            ("rapid", -13.0),
            ("feed", -19.0),
            ("rapid", -18.8),
            ("feed", -21.0),
            ("feed", 1.0),
            ("rapid", 49.0)
        ]
    );
    assert!(p.motions.iter().filter(|m| m.line == 29 && m.to[2] == 1.0 && m.is_feed()).all(|m| m.feed == Some(500.0)));
}

#[test]
fn heidenhain_leaves_q_parameters_unresolved_and_refuses_what_it_cannot_read() {
    let probing = "BEGIN PGM 0TREF MM
L Z-10 FMAX M91
CYCL DEF 7.0 DATUM SHIFT
CYCL DEF 7.3  Z+Q12
L IZ+2 R0 F200
L IX-Q3 R0 F200
FN9: IF +Q18 EQU -10 GOTO LBL1
Q4 = Q18 -  Q5
LBL1
END PGM 0TREF MM
";
    let p = heidenhain::read("0TREF.h", probing).unwrap_or_else(|e| panic!("{e}"));
    assert!(p.motions.is_empty());
    let unresolved: Vec<&str> = p
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::Unresolved { text } => Some(text.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(unresolved, ["L IX-Q3 R0 F200"]);
    assert!(p.events.iter().any(|e| e.kind == EventKind::Positioning { rapid: false, to: [None, None, None] }));
    let cases = [
        (
            "BEGIN PGM A MM\nL X+0 Y+0 Z+0 FMAX\nFN9: IF +Q1 EQU 0 GOTO LBL2\nL X+5 F100\nLBL2\n",
            "a:4:1: a motion between a conditional jump (line 3) and its LBL 2",
        ),
        ("BEGIN PGM A MM\nL X+0 Y+0 Z+0 FMAX\nL Xnan FMAX\n", "a:3:3: not a number: `Xnan`"),
        (
            "BEGIN PGM A MM\nL X+0 Y+0 Z+0 FMAX\nL X+5 RL F100\n",
            "a:3:7: radius compensation: the path is not the tool's",
        ),
        ("BEGIN PGM A MM\nL X+0 Y+0 Z+0 FMAX\nC X+5 Y+0 DR+ F100\n", "a:3:1: an arc before any CC"),
        ("BEGIN PGM A MM\nL X+0 Y+0 Z+0 FMAX\nCC X+5\n", "a:3:4: a circle centre other than in X and Y is not read"),
        (
            "BEGIN PGM A MM\nPLANE SPATIAL SPA+0 SPB+45 SPC+0 STAY\n",
            "a:2:1: PLANE SPATIAL is not read (PLANE VECTOR and PLANE RESET are)",
        ),
        ("BEGIN PGM A MM\nCYCL DEF 262 THREAD MILLING\n", "a:2:1: cycle 262 is not read"),
        ("L X+0 Y+0 Z+0 FMAX\nEND PGM A MM\n", "a:1:1: no units: expected G20/G21 or BEGIN PGM … MM|INCH"),
    ];
    refused(heidenhain::read, "a", &cases);
}

#[test]
fn heidenhain_inch_feeds_are_tenths_of_an_inch_per_minute() {
    let p = heidenhain::read("i.h", "BEGIN PGM I INCH\nL X+0 Y+0 Z+1 FMAX\nL Z+0 F100\nEND PGM I INCH\n")
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((p.units, p.motions[1].feed), (Units::Inch, Some(10.0)));
}

/// The peers' folders are found with their inputs and programs.
/// What postpro's Heidenhain programs hold besides clsplit's: a `TOOL CALL S…` (a new spindle
/// speed, no tool change) and a preset activated by `CYCL DEF 247` (a work offset, the
/// positions in its frame).
#[test]
fn heidenhain_reads_a_speed_change_and_a_datum_setting() {
    let text = "0 BEGIN PGM P MM\n1 TOOL CALL 3 Z\n2 TOOL CALL S9000\n3 CYCL DEF 247 DATUM SETTING ~\n  Q339=+1 ;DATUM NUMBER\n\
                4 L X+1.000 Y+2.000 Z+3.000 FMAX\n5 L Z+0.000 F100\n6 END PGM P MM\n";
    let p = heidenhain::read("p.h", text).unwrap_or_else(|e| panic!("{e}"));
    let tools: Vec<&EventKind> =
        p.events.iter().map(|e| &e.kind).filter(|k| matches!(k, EventKind::ToolChange { .. })).collect();
    assert_eq!(tools, [&EventKind::ToolChange { tool: 3 }]);
    assert!(p.events.iter().any(|e| e.kind == EventKind::WorkOffset { name: "CYCL DEF 247".into(), offset: None }));
    assert_eq!(kinds(&p), ["rapid", "feed"]);
    assert!(close3(p.motions[1].to, [1.0, 2.0, 0.0]), "{:?}", p.motions);
}

#[test]
fn the_peer_cases_are_found() {
    let nx = nx_haas_cases();
    assert_eq!(nx.len(), 5);
    assert!(nx.iter().all(|c| c.expected.len() == 1 && c.input.extension().is_some_and(|e| e == "txt")));
    let clsplit = clsplit_cases();
    assert_eq!(clsplit.len(), 12);
    let basemach = clsplit.iter().find(|c| c.name.ends_with("basemach")).expect("basemach");
    let names: Vec<String> =
        basemach.expected.iter().filter_map(|p| p.file_name()).map(|n| n.to_string_lossy().into_owned()).collect();
    assert_eq!(names, ["0TREF.h", "11.h", "11setup.h"]);
    assert!(basemach.input.ends_with("basemach.apt"));
}

/// Fanuc's tool centre point control: G43.5 H (and G43.4 H) switch it on with the tool's length
/// register, as Haas's G234 does; the tool vector's I J K on linear moves are not arc centres.
#[test]
fn fanuc_reads_tool_centre_point_control() {
    let text =
        "G21 G90 G94 G17\nG54\nT3 M6\nG43.5 H13\nG0 X1 Y2 Z30 I0 J0 K1\nG1 Z-1 I0.1 J0 K0.995 F500\nG49\nG0 Z50\nM30\n";
    let p = fanuc::read("t", text).unwrap_or_else(|e| panic!("{e}"));
    let kinds: Vec<&EventKind> = p.events.iter().map(|e| &e.kind).collect();
    assert!(kinds.contains(&&EventKind::LengthOffset { register: Some(13), offset: None }), "{kinds:?}");
    assert!(
        kinds.contains(&&EventKind::Tcp { on: true }) && kinds.contains(&&EventKind::Tcp { on: false }),
        "{kinds:?}"
    );
    let ends: Vec<[f64; 3]> = p.motions.iter().map(|m| m.to).collect();
    assert_eq!(ends, [[1.0, 2.0, 30.0], [1.0, 2.0, -1.0], [1.0, 2.0, 50.0]]);
    assert_eq!(p.motions[1].kind, MotionKind::Feed);
}

/// Fanuc's tilted working plane as postpro writes it: `G68.2` defines the plane (its X Y Z and
/// Euler angles, not a move), `G53.1` turns the tool to it, the position is not known in the
/// plane until programmed (`G0 Z…` alone is a positioning); `G69` resets it. Haas's `G254` and
/// `G255` leave the position unknown too. `G43.5`'s I J K are the tool vector of straight moves
/// (modal, components left out 0), an error outside it.
#[test]
fn fanuc_reads_tilted_planes_dynamic_offsets_and_tool_vectors() {
    let text = "G21 G90 G94 G17\nG54\nG0 B90 C0\nG0 X10 Y20\nG68.2 X1 Y2 Z3 I90 J90 K-90\nG53.1\nG0 Z50\n\
                G0 X10 Y20 Z5\nG1 Z-1 F100\nG17 G2 X12 Y20 Z-1 I1 J0\nG0 Z50\nG69\nG254\nG0 X1 Y2 Z3\nG255\n\
                G43.5 H1\nG0 X0 Y0 Z10 I0 J0 K1\nG1 Z9 I0.6 K0.8\nG1 Z8\nG49\nM30\n";
    let p = fanuc::read("t", text).unwrap_or_else(|e| panic!("{e}"));
    let planes: Vec<(&str, Option<Frame>)> = p
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::WorkingPlane { code, frame } => Some((code.as_str(), *frame)),
            _ => None,
        })
        .collect();
    assert_eq!(planes, [("G68.2", Some(Frame::euler_zxz([1.0, 2.0, 3.0], [90.0, 90.0, -90.0]))), ("G69", None)]);
    assert!(p.events.iter().any(|e| e.kind == EventKind::ToolAxisToPlane { code: "G53.1".into() } && e.line == 6));
    assert!(p.events.iter().any(|e| e.kind == EventKind::Positioning { rapid: true, to: [None, None, Some(50.0)] }));
    assert_eq!(kinds(&p), ["rapid", "feed", "arc", "rapid", "rapid", "rapid", "feed", "feed"]);
    // In the plane, from where the machine's kinematics left it; the B of the set-up kept.
    assert!(!p.motions[0].from_known && p.motions[0].to == [10.0, 20.0, 5.0] && p.motions[0].rotary.b == Some(90.0));
    // After G254, the part's coordinates: again from a position not known.
    assert!(!p.motions[4].from_known && p.motions[4].to == [1.0, 2.0, 3.0]);
    let vectors: Vec<Option<[f64; 3]>> = p.motions[5..].iter().map(|m| m.vector).collect();
    assert_eq!(vectors, [Some([0.0, 0.0, 1.0]), Some([0.6, 0.0, 0.8]), Some([0.6, 0.0, 0.8])]);
    assert!(p.motions[..5].iter().all(|m| m.vector.is_none()));
    let cases = [
        ("G21 G0 X0 Y0 Z0\nG1 X1 I0.5 F100\n", "t:2:7: I J K on a straight move outside G43.5"),
        ("G21\nG68.2 X0 Y0 Z0 I0 J10 K0 R5\n", "t:2:26: `R` in a G68.2 block is not read"),
    ];
    refused(fanuc::read, "t", &cases);
}

/// Heidenhain's `LN` blocks (every coordinate and normal component, the tool vector TX TY TZ)
/// and working planes: `PLANE VECTOR … STAY` about the datum (a datum shift before it is its
/// zero; the coordinates in the plane are not shifted again), `PLANE RESET`; the TNC's rules are
/// errors here.
#[test]
fn heidenhain_reads_ln_blocks_and_vector_planes() {
    let text = "0 BEGIN PGM P MM\n1 TOOL CALL 1 Z\n2 CYCL DEF 7.0 DATUM SHIFT\n3 CYCL DEF 7.1 X+10\n\
                4 L B+90 C+0 FMAX\n5 PLANE VECTOR BX+0 BY+0 BZ-1 NX+1 NY+0 NZ+0 STAY ; plane\n6 L Z+50 FMAX\n\
                7 L X+1 Y+2 Z+5 FMAX\n8 PLANE RESET STAY\n9 L M128\n\
                10 LN X+1 Y+2 Z+3 NX+0 NY+0 NZ+1 TX+0 TY+0 TZ+1 FMAX\n11 LN X+1 Y+2 Z+2 NX+0.6 NY+0 NZ+0.8 F100\n\
                12 L M129\n13 END PGM P MM\n";
    let p = heidenhain::read("p.h", text).unwrap_or_else(|e| panic!("{e}"));
    let planes: Vec<Option<Frame>> = p
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::WorkingPlane { frame, .. } => Some(*frame),
            _ => None,
        })
        .collect();
    let plane = Frame::from_vectors([10.0, 0.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]).expect("a frame");
    assert_eq!(planes, [Some(plane), None]);
    assert!(p.events.iter().any(|e| e.kind == EventKind::Positioning { rapid: true, to: [None, None, Some(50.0)] }));
    // In the plane: its own coordinates; after the reset, the datum shift's again.
    assert_eq!(p.motions[0].to, [1.0, 2.0, 5.0]);
    assert_eq!((p.motions[1].to, p.motions[2].to), ([11.0, 2.0, 3.0], [11.0, 2.0, 2.0]));
    // The tool vector: TX TY TZ, kept while the normal alone changes.
    assert_eq!((p.motions[1].vector, p.motions[2].vector), (Some([0.0, 0.0, 1.0]), Some([0.0, 0.0, 1.0])));
    let cases = [
        (
            "BEGIN PGM A MM\nL X+0 Y+0 Z+0 FMAX\nLN X+1 Y+0 Z+0 TX+0 TY+0 TZ+1 F100\n",
            "a:3:1: an LN block without NX NY NZ: the TNC wants every coordinate and normal component in each LN block",
        ),
        ("BEGIN PGM A MM\nLN B+10 FMAX\n", "a:2:4: `B` in an LN block: its tool orientation is TX TY TZ"),
        ("BEGIN PGM A MM\nLN X+1 Y+0 Z+0 NX+0 NY+0 NZ+1 TX+0 TZ+1 F100\n", "a:2:31: TX TY TZ: all three or none"),
        ("BEGIN PGM A MM\nPLANE VECTOR BX+1 BY+0 BZ+0 NX+0 NY+0 NZ+1\n", "a:2:1: a PLANE without STAY, MOVE or TURN"),
        (
            "BEGIN PGM A MM\nPLANE VECTOR BX+1 BY+0 BZ+0.5 NX+0 NY+0 NZ+1 STAY\n",
            "a:2:1: the base vector is not perpendicular to the normal vector (cosine 4.47e-1)",
        ),
        (
            "BEGIN PGM A MM\nPLANE VECTOR BX+1 BY+0 BZ+0 NX+0 NY+0 NZ+1 STAY\nCYCL DEF 7.0 DATUM SHIFT\n",
            "a:3:1: a datum shift in a tilted working plane is not read",
        ),
    ];
    refused(heidenhain::read, "a", &cases);
}

/// The Siemens reader takes the positions from the interpreter's rows and the rest from the text:
/// TCP with the tool vector of `ORIVECT`, a `CYCLE800` plane (mode 57) that swivels, a modal
/// drilling call's hole, an arc with its I J, a `SUPA` retract.
#[test]
fn siemens_reads_the_interpreters_rows_and_the_frames_of_the_text() {
    let text = "G90 G17 G710 G94\nT1 D1 M6\nG0 SUPA Z200 D0\nG0 B90 C0\nG0 X10 Y20\n\
                CYCLE800(0, \"TC1\", 0, 57, 0, 0, 0, 0, 90, 0, 0, 0, 0, 1, 100, 1) ; plane\nG0 Z50\n\
                G0 X10 Y20 Z5\nF100\nMCALL CYCLE81(5, 0, 2, -10)\nX12 Y20\nMCALL\nG1 Z0\nG17 G3 X14 Y20 I1 J0\n\
                CYCLE800()\nTRAORI D1\nORIWKS ORIVECT\nG0 X0 Y0 Z10 A3=0 B3=0 C3=1\nTRAFOOF\nM30\n";
    let row = |motion: &str, programmed: &str, values: &[(char, f64)]| siemens::Row {
        motion: (!motion.is_empty()).then(|| motion.to_string()),
        feed: None,
        programmed: programmed.to_string(),
        values: values.iter().copied().collect(),
    };
    let mut rows = vec![row("", "", &[]); text.lines().count()];
    rows[2] = row("G0", "Z", &[('Z', 200.0)]);
    rows[3] = row("G0", "BC", &[('Z', 200.0), ('B', 90.0), ('C', 0.0)]);
    rows[4] = row("G0", "XY", &[('X', 10.0), ('Y', 20.0), ('B', 90.0), ('C', 0.0)]);
    rows[6] = row("G0", "Z", &[('X', 10.0), ('Y', 20.0), ('Z', 50.0), ('B', 90.0), ('C', 0.0)]);
    rows[7] = row("G0", "XYZ", &[('X', 10.0), ('Y', 20.0), ('Z', 5.0), ('B', 90.0), ('C', 0.0)]);
    rows[8] = siemens::Row { feed: Some(100.0), ..row("G0", "", &[]) };
    rows[10] = row("G0", "XY", &[('X', 12.0), ('Y', 20.0), ('Z', 5.0), ('B', 90.0), ('C', 0.0)]);
    rows[12] = row("G1", "Z", &[('X', 12.0), ('Y', 20.0), ('Z', 0.0), ('B', 90.0), ('C', 0.0)]);
    rows[13] = row("G3", "XYIJ", &[('X', 14.0), ('Y', 20.0), ('Z', 0.0), ('I', 1.0), ('J', 0.0), ('B', 90.0)]);
    rows[17] = row("G0", "XYZ", &[('X', 0.0), ('Y', 0.0), ('Z', 10.0), ('B', 90.0), ('C', 0.0)]);
    let p = siemens::read("s.mpf", text, &rows).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(p.units, Units::Mm);
    let codes: Vec<&str> = p
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::WorkingPlane { code, .. } | EventKind::ToolAxisToPlane { code } => Some(code.as_str()),
            EventKind::MachineFrameMove { code, .. } => Some(code.as_str()),
            EventKind::Hole { cycle, .. } => Some(cycle.as_str()),
            EventKind::Tcp { on: true } => Some("TRAORI"),
            EventKind::Tcp { on: false } => Some("TRAFOOF"),
            _ => None,
        })
        .collect();
    assert_eq!(codes, ["SUPA", "CYCLE800", "CYCLE800", "CYCLE81", "CYCLE800()", "TRAORI", "TRAFOOF"]);
    let plane = p.events.iter().find_map(|e| match &e.kind {
        EventKind::WorkingPlane { frame: Some(f), .. } => Some(*f),
        _ => None,
    });
    assert!(close3(plane.map_or([0.0; 3], |f| f.z()), [1.0, 0.0, 0.0]));
    let hole = p.events.iter().find_map(|e| match &e.kind {
        EventKind::Hole { at, bottom, .. } => Some((*at, *bottom)),
        _ => None,
    });
    assert_eq!(hole, Some(([12.0, 20.0, 2.0], -10.0)));
    assert_eq!(kinds(&p), ["rapid", "feed", "arc", "rapid"]);
    let arc = p.motions[2].arc().copied().expect("an arc");
    assert!(close3(arc.center, [13.0, 20.0, 0.0]) && !arc.clockwise, "{arc:?}");
    assert_eq!(p.motions[3].vector, Some([0.0, 0.0, 1.0]));
    assert_eq!(p.motions[1].from, [12.0, 20.0, 5.0]);
}
