//! NC programs of the bundled examples and of real 5-axis CL files on the built-in machines, in
//! every mode: pinned by insta (the head and tail of each program, its line count and a SHA-256
//! of the whole), read back and checked through the forward kinematics, and inverse time checked
//! block by block (F × Δt = 1).

use std::path::PathBuf;

use nalgebra::Point3;
use postpro_cl::{ItemKind, Motion, Source, ToolPath, read};
use postpro_emit::{Mode, Options, build, builtin_template, dialect, render};
use postpro_kin::{Joints, solve, solver_for};
use postpro_machine::Registry;
use postpro_machine::model::{AxisKind, Machine};
use sha2::{Digest, Sha256};

mod common;
use common::motion;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn machine(name: &str) -> Machine {
    Registry::builtin().expect("built-ins").find(name).expect("machine").machine.clone()
}

fn source(relative: &str) -> Source {
    let path = repo().join(relative);
    let bytes = std::fs::read(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (../shared must sit beside the repository)", path.display()));
    Source::from_bytes(relative, bytes)
}

/// The program text of a CL file on a machine in a mode and dialect.
fn program(relative: &str, machine_name: &str, mode: Mode, dialect_name: Option<&str>) -> String {
    let src = source(relative);
    let path = read(&src);
    assert!(!path.has_errors(), "{relative} reads");
    let m = machine(machine_name);
    let kin = solver_for(&m);
    let solved = solve(kin.as_ref(), &path, &m.policy).unwrap_or_else(|e| panic!("{relative} on {machine_name}: {e}"));
    let d = dialect(dialect_name.unwrap_or(&m.dialect)).expect("dialect");
    let options = Options {
        units: postpro_machine::model::ProgramUnits::Mm,
        program_name: "TEST".into(),
        source_name: relative.into(),
        block_numbers: false,
        tcp_orientation: Default::default(),
        insert_verbatim: false,
        prediction: None,
        annotations: Vec::new(),
    };
    let p = build(&motion(&path, &solved, kin.as_ref(), d, mode), &m, d, &options).expect("builds");
    render(&p, d.name, builtin_template(d.name).expect("template")).expect("renders")
}

/// The head and the tail of a program, its size and its hash: small, yet any change shows.
fn digest(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let hash = Sha256::digest(text.as_bytes()).iter().map(|b| format!("{b:02x}")).collect::<String>();
    let head = lines.iter().take(40).copied().collect::<Vec<_>>().join("\n");
    let tail = lines.iter().skip(lines.len().saturating_sub(8).max(40)).copied().collect::<Vec<_>>().join("\n");
    format!("lines: {}\nsha256: {hash}\n--- head ---\n{head}\n--- tail ---\n{tail}\n", lines.len())
}

const EXAMPLES: [&str; 2] = ["examples/cl/hypar-5axis.cl", "examples/cl/bicubic-5axis.cl"];
const REAL: [&str; 2] = [
    "../shared/data/cl/userFour__MECH491-postprocessor__APT_code.txt",
    "../shared/data/cl/userFour__MECH491-postprocessor__APT_Project2.txt",
];

#[test]
fn every_built_in_machine_in_every_mode_on_the_examples() {
    for machine_name in ["mikron-ucp710", "maho600e"] {
        for (mode, label) in
            [(Mode::G1, "g1"), (Mode::InverseTime, "inverse-time"), (Mode::Tcp, "tcp"), (Mode::Bspline, "bspline")]
        {
            // BSPLINE exists in the Siemens dialect only (the Mikron's).
            if mode == Mode::Bspline && machine(machine_name).dialect != "siemens-840d" {
                continue;
            }
            for example in EXAMPLES {
                let stem = example.rsplit('/').next().unwrap_or(example).trim_end_matches(".cl");
                let text = program(example, machine_name, mode, None);
                insta::assert_snapshot!(format!("{stem}__{machine_name}__{label}"), digest(&text));
            }
        }
    }
}

#[test]
fn real_five_axis_files_on_the_built_ins() {
    for machine_name in ["mikron-ucp710", "maho600e"] {
        for file in REAL {
            let stem = file.rsplit("__").next().unwrap_or(file).trim_end_matches(".txt");
            let text = program(file, machine_name, Mode::G1, None);
            insta::assert_snapshot!(format!("real_{stem}__{machine_name}"), digest(&text));
        }
    }
}

#[test]
fn every_dialect_writes_the_example() {
    for d in ["siemens-840d", "fanuc", "heidenhain", "linuxcnc"] {
        let text = program(EXAMPLES[0], "mikron-ucp710", Mode::G1, Some(d));
        let blank = text.lines().position(|l| l.trim().is_empty());
        assert_eq!(blank, None, "{d}: blank line (0-based index) in the program");
        insta::assert_snapshot!(format!("dialect_{d}"), digest(&text));
    }
}

/// A program read back: the axis values after each G0/G1 block, with the G93 state and F.
struct Block {
    joints: Vec<f64>,
    feed_move: bool,
    inverse_time: bool,
    f: Option<f64>,
}

fn read_back(text: &str, machine: &Machine) -> Vec<Block> {
    let mut values: Vec<Option<f64>> = vec![None; machine.axes.len()];
    let mut inverse_time = false;
    let mut out = Vec::new();
    for line in text.lines() {
        let code = line.split(['(', ';']).next().unwrap_or("");
        // A retract in machine coordinates is not a position of the program's frame.
        if code.split_whitespace().any(|t| t == "G53") {
            continue;
        }
        let mut motion = None;
        let mut f = None;
        for token in code.split_whitespace() {
            let (letter, number) = token.split_at(1);
            let Ok(v) = number.parse::<f64>() else { continue };
            match letter {
                "G" if v == 0.0 || v == 1.0 => motion = Some(v == 1.0),
                "G" if v == 93.0 => inverse_time = true,
                "G" if v == 94.0 => inverse_time = false,
                "F" => f = Some(v),
                l => {
                    if let Some(i) = machine.axis_index(l) {
                        values[i] = Some(if machine.axes[i].kind == AxisKind::Rotary { v.to_radians() } else { v });
                    }
                }
            }
        }
        if let Some(feed_move) = motion {
            let joints = values.iter().map(|v| v.unwrap_or(0.0)).collect();
            out.push(Block { joints, feed_move, inverse_time, f });
        }
    }
    out
}

/// The CL points with the feed they are reached at.
fn cl_points(path: &ToolPath) -> Vec<(Point3<f64>, Option<f64>)> {
    path.items
        .iter()
        .filter_map(|i| match &i.kind {
            ItemKind::Move(m) => Some((m.to, if let Motion::Feed(f) = m.motion { Some(f.value) } else { None })),
            _ => None,
        })
        .collect()
}

/// The independent check: the emitted program, read back through the forward kinematics, passes
/// through every CL point in order (within the rounding of the written decimals), and its other
/// points (linearization) lie between them.
#[test]
fn the_program_read_back_passes_through_every_cl_point() {
    for machine_name in ["mikron-ucp710", "maho600e"] {
        let m = machine(machine_name);
        let kin = solver_for(&m);
        let src = source(EXAMPLES[0]);
        let path = read(&src);
        let text = program(EXAMPLES[0], machine_name, Mode::G1, Some("linuxcnc"));
        let blocks = read_back(&text, &m);
        let targets = cl_points(&path);
        // The written values are in the work offset's frame: back to the kinematics'.
        let frame = postpro_motion::work_frame(kin.as_ref(), Mode::G1);
        let mut next = 0;
        for b in &blocks {
            let tip = kin.forward(&frame.unapply(&Joints::from_slice(&b.joints))).tip;
            if next < targets.len() && (tip - targets[next].0).norm() < 0.01 {
                next += 1;
            }
        }
        assert_eq!(next, targets.len(), "{machine_name}: only {next} of {} CL points found in order", targets.len());
    }
}

/// Inverse time: G93 is active on every feed block, and F × Δt = 1 with Δt the part-space length
/// of the block (from the forward kinematics of the written axis values) over the CL feed.
#[test]
fn inverse_time_f_times_delta_t_is_one() {
    for machine_name in ["mikron-ucp710", "maho600e"] {
        let m = machine(machine_name);
        let kin = solver_for(&m);
        let path = read(&source(EXAMPLES[0]));
        let targets = cl_points(&path);
        let text = program(EXAMPLES[0], machine_name, Mode::InverseTime, Some("linuxcnc"));
        assert!(text.contains("G94"), "G94 restored after the program");
        let blocks = read_back(&text, &m);
        let frame = postpro_motion::work_frame(kin.as_ref(), Mode::InverseTime);
        let mut next = 0;
        let mut previous: Option<Point3<f64>> = None;
        let mut checked = 0;
        let mut clamped = 0;
        for b in &blocks {
            let tip = kin.forward(&frame.unapply(&Joints::from_slice(&b.joints))).tip;
            // The CL move this block belongs to: the next CL point not yet reached.
            let feed = targets.get(next).and_then(|t| t.1);
            if b.feed_move {
                assert!(b.inverse_time, "{machine_name}: a feed block outside G93");
                let f = b.f.unwrap_or_else(|| panic!("{machine_name}: a G93 block without F"));
                let (Some(prev), Some(feed)) = (previous, feed) else {
                    panic!("{machine_name}: a feed block without a feed")
                };
                let length = (tip - prev).norm();
                if length > 0.01 {
                    let dt = length / feed;
                    // The written decimals (1 µm, 1e-4°) make the length read back uncertain by
                    // about 3 µm: the tolerance grows for short blocks.
                    let tolerance = 2e-3 + 3e-3 / length;
                    if f >= 99_999.0 {
                        // Limited to the controller's maximum F (noted in the program): slower.
                        assert!(f * dt < 1.0 + tolerance);
                        clamped += 1;
                    } else {
                        let product = f * dt;
                        assert!(
                            (product - 1.0).abs() < tolerance,
                            "{machine_name}: F {f} × Δt {dt} = {product} ({length} mm)"
                        );
                        checked += 1;
                    }
                }
            }
            if next < targets.len() && (tip - targets[next].0).norm() < 0.01 {
                next += 1;
            }
            previous = Some(tip);
        }
        assert_eq!(text.matches("F limited to 99999").count(), clamped, "{machine_name}: every clamped block is noted");
        assert!(checked > 1000, "{machine_name}: only {checked} blocks checked");
    }
}

#[test]
fn the_manta_is_larger_than_both_built_ins() {
    let path = read(&source("examples/cl/manta-5axis.cl"));
    for machine_name in ["mikron-ucp710", "maho600e"] {
        let m = machine(machine_name);
        let err = solve(solver_for(&m).as_ref(), &path, &m.policy).expect_err("600 mm part");
        assert!(err.to_string().contains("no solution within the travel"), "{err}");
    }
}

#[test]
fn unsupported_modes_are_errors() {
    let src = source(EXAMPLES[0]);
    let path = read(&src);
    let m = machine("mikron");
    let kin = solver_for(&m);
    let solved = solve(kin.as_ref(), &path, &m.policy).expect("solves");
    let options = Options {
        units: postpro_machine::model::ProgramUnits::Mm,
        program_name: "T".into(),
        source_name: "t".into(),
        block_numbers: false,
        tcp_orientation: Default::default(),
        insert_verbatim: false,
        prediction: None,
        annotations: Vec::new(),
    };
    for (d, mode, message) in [
        ("linuxcnc", Mode::Tcp, "the linuxcnc dialect has no tcp mode"),
        ("heidenhain", Mode::InverseTime, "the heidenhain dialect has no inverse-time mode"),
        ("fanuc", Mode::Bspline, "the fanuc dialect has no bspline mode"),
    ] {
        let d = dialect(d).expect("dialect");
        let err = build(&motion(&path, &solved, kin.as_ref(), d, mode), &m, d, &options).expect_err(message);
        assert_eq!(err.to_string(), message);
    }
}

/// Writing block by block (the CLI's way, with skeletons for the motion blocks) gives exactly
/// the program the whole-context rendering gives, in every dialect and mode.
#[test]
fn streaming_equals_the_whole_rendering() {
    let src = source(EXAMPLES[0]);
    let path = read(&src);
    for machine_name in ["mikron-ucp710", "maho600e"] {
        let m = machine(machine_name);
        let kin = solver_for(&m);
        let solved = solve(kin.as_ref(), &path, &m.policy).expect("solves");
        for d in postpro_emit::DIALECTS {
            for mode in [Mode::G1, Mode::InverseTime, Mode::Tcp, Mode::Bspline] {
                for block_numbers in [false, true] {
                    let options = Options {
                        units: postpro_machine::model::ProgramUnits::Mm,
                        program_name: "TEST".into(),
                        source_name: "t.cl".into(),
                        block_numbers,
                        tcp_orientation: Default::default(),
                        insert_verbatim: false,
                        prediction: None,
                        annotations: Vec::new(),
                    };
                    let template = builtin_template(d.name).expect("template");
                    let program_motion = motion(&path, &solved, kin.as_ref(), d, mode);
                    let Ok(program) = build(&program_motion, &m, d, &options) else { continue };
                    let whole = render(&program, d.name, template).expect("renders");
                    let mut streamed = Vec::new();
                    postpro_emit::write_program(&program_motion, &m, d, &options, d.name, template, &mut streamed)
                        .expect("writes");
                    let streamed = String::from_utf8(streamed).expect("UTF-8");
                    let first = whole.lines().zip(streamed.lines()).find(|(a, b)| a != b);
                    assert!(whole == streamed, "{} {:?} {block_numbers}: {first:?}", d.name, mode);
                }
            }
        }
    }
}

/// BSPLINE: every spline written, rebuilt from the program's control points and `PL` values and
/// evaluated densely through the forward kinematics, keeps the tool tip within the tolerance of
/// the programmed CL segments (plus the rounding of the written control points).
#[test]
fn bspline_stays_within_tolerance_of_the_cl_points() {
    use postpro_emit::bspline::Spline;
    for example in EXAMPLES {
        let m = machine("mikron-ucp710");
        let kin = solver_for(&m);
        let path = read(&source(example));
        let cl: Vec<Point3<f64>> = cl_points(&path).into_iter().map(|(p, _)| p).collect();
        let text = program(example, "mikron-ucp710", Mode::Bspline, None);
        let mut values: Vec<f64> = vec![0.0; m.axes.len()];
        let mut spline: Option<(Vec<Joints>, Vec<f64>)> = None;
        let mut splines = Vec::new();
        for line in text.lines() {
            let code = line.split(';').next().unwrap_or("").trim();
            if code.starts_with("BSPLINE") {
                spline = Some((vec![Joints::from_slice(&values)], Vec::new()));
                continue;
            }
            let mut pl = None;
            for token in code.split_whitespace() {
                if let Some(v) = token.strip_prefix("PL=") {
                    pl = v.parse::<f64>().ok();
                    continue;
                }
                let (letter, number) = token.split_at(1);
                if let (Some(i), Ok(v)) = (m.axis_index(letter), number.parse::<f64>()) {
                    values[i] = if m.axes[i].kind == AxisKind::Rotary { v.to_radians() } else { v };
                }
            }
            match (&mut spline, pl) {
                (Some((control, pls)), Some(pl)) => {
                    control.push(Joints::from_slice(&values));
                    pls.push(pl);
                }
                (Some(_), None) if code == "G1" => splines.extend(spline.take()),
                _ => {}
            }
        }
        assert!(splines.len() > 10, "{example}: {} splines", splines.len());
        for (control, pls) in splines {
            let spline = Spline::from_written(control, &pls);
            let total = spline.domain().1;
            let polyline = |p: &Point3<f64>| {
                cl.windows(2)
                    .map(|w| {
                        let ab = w[1] - w[0];
                        let t = ((p - w[0]).dot(&ab) / ab.norm_squared().max(1e-12)).clamp(0.0, 1.0);
                        (p - (w[0] + ab * t)).norm()
                    })
                    .fold(f64::INFINITY, f64::min)
            };
            for k in 0..=200 {
                let u = total * f64::from(k) / 200.0;
                let tip = kin.forward(&spline.at(u)).tip;
                let off = polyline(&tip);
                assert!(off < m.policy.linearization_tolerance + 0.005, "{example}: {off} mm off at u = {u}/{total}");
            }
        }
    }
}

/// A user template: undefined names are errors (strict), and a line longer than the dialect
/// accepts is an error, never a truncated block.
#[test]
fn user_templates_are_strict_and_lines_are_bounded() {
    let src = source(EXAMPLES[0]);
    let path = read(&src);
    let m = machine("mikron");
    let kin = solver_for(&m);
    let solved = solve(kin.as_ref(), &path, &m.policy).expect("solves");
    let d = dialect("fanuc").expect("dialect");
    let options = Options {
        units: postpro_machine::model::ProgramUnits::Mm,
        program_name: "T".into(),
        source_name: "t".into(),
        block_numbers: false,
        tcp_orientation: Default::default(),
        insert_verbatim: false,
        prediction: None,
        annotations: Vec::new(),
    };
    let program = motion(&path, &solved, kin.as_ref(), d, Mode::G1);
    let write = |template: &str| {
        let mut out = Vec::new();
        postpro_emit::write_program(&program, &m, d, &options, "user.j2", template, &mut out).map(|()| out)
    };
    let err = write("{{ header.no_such_field }}").expect_err("strict");
    assert!(err.to_string().starts_with("template user.j2: "), "{err}");
    let long = "{% macro program_start() %}%\n{% endmacro %}{% macro program_end() %}%\n{% endmacro %}\
                {% macro block(b) %}{% for i in range(300) %}X{% endfor %}{% endmacro %}\
                {{ program_start() }}{% for b in blocks %}{{ block(b) }}\n{% endfor %}{{ program_end() }}";
    let err = write(long).expect_err("too long");
    assert!(err.to_string().starts_with("a line is longer than the 256 characters the fanuc dialect accepts"), "{err}");
    let ok = write("{{ header.name }} {{ blocks|length }}\n").expect("a whole-program template");
    assert!(String::from_utf8(ok).expect("UTF-8").starts_with("T "));
}

/// A feed beyond the machine's (or the controller's) range is written at the limit, with a note on
/// the block.
#[test]
fn a_feed_out_of_range_is_limited_and_noted() {
    let src = postpro_cl::Source::new("fast.cl", "FEDRAT/MMPM,150000\nGOTO/0,0,0\nGOTO/10,0,0\nGOTO/20,0,0\n");
    let path = read(&src);
    let m = machine("maho");
    let kin = solver_for(&m);
    let solved = solve(kin.as_ref(), &path, &m.policy).expect("solves");
    let d = dialect("fanuc").expect("dialect");
    let options = Options {
        units: postpro_machine::model::ProgramUnits::Mm,
        program_name: "T".into(),
        source_name: "fast.cl".into(),
        block_numbers: false,
        tcp_orientation: Default::default(),
        insert_verbatim: false,
        prediction: None,
        annotations: Vec::new(),
    };
    let text = render(
        &build(&motion(&path, &solved, kin.as_ref(), d, Mode::G1), &m, d, &options).expect("builds"),
        d.name,
        builtin_template(d.name).expect("template"),
    )
    .expect("renders");
    // The machine's feed_max (10 m/min) is below the controller's largest F: it wins.
    let note = "F10000.000 (feed 150000 mm/min limited to 10000 mm/min [the machine's range 1…10000 mm/min])";
    assert!(text.contains(note), "{text}");
    assert_eq!(text.matches("F10000").count(), 1, "the F word once, modal: {text}");
}

/// The program of a solved tool path in mode G1 for dialect `d`, in mm, without prediction.
fn g1_program(
    path: &ToolPath,
    solved: &postpro_kin::Solved,
    m: &Machine,
    d: &postpro_emit::Dialect,
    source: &str,
) -> String {
    let kin = solver_for(m);
    let options = Options {
        units: postpro_machine::model::ProgramUnits::Mm,
        program_name: "T".into(),
        source_name: source.into(),
        block_numbers: false,
        tcp_orientation: Default::default(),
        insert_verbatim: false,
        prediction: None,
        annotations: Vec::new(),
    };
    let p = build(&motion(path, solved, kin.as_ref(), d, Mode::G1), m, d, &options).expect("builds");
    render(&p, d.name, builtin_template(d.name).expect("template")).expect("renders")
}

/// A stop's operator message is a comment of the dialect: parentheses in the CL text
/// (`STOP/(INSTALL TEST STRIP)`, CATIA) do not nest a comment, which LinuxCNC refuses.
#[test]
fn a_stop_message_stays_one_comment() {
    let src = postpro_cl::Source::new("stop.cl", "FEDRAT/MMPM,500\nGOTO/0,0,0\nSTOP/(TURN THE PART)\nGOTO/10,0,0\n");
    let path = read(&src);
    let m = machine("example-3axis-vmc");
    let solved = solve(solver_for(&m).as_ref(), &path, &m.policy).expect("solves");
    for (name, stop) in [
        ("linuxcnc", "M0 ([TURN THE PART])"),
        ("fanuc", "M0 ([TURN THE PART])"),
        ("siemens-840d", "M0 ; (TURN THE PART)"),
    ] {
        let text = g1_program(&path, &solved, &m, dialect(name).expect("dialect"), "stop.cl");
        assert!(text.lines().any(|l| l == stop), "{name}: {text}");
    }
}
