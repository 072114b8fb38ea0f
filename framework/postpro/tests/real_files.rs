//! Every real CL file (`../shared/data/cl`, and the inputs of the peers in
//! `../shared/data/peers/*/[*/[*/]]input/`) as a shop would post it: `postpro --machine NAME
//! FILE` on a built-in machine that fits it, with default options. The LinuxCNC program of each
//! runs in LinuxCNC's `rs274` with a tool table holding its tools, and the tool tip it drives
//! (the machine's forward kinematics on the axis values rs274 reports, with each tool's length)
//! reaches every CL point, in order, with the CL tool axis. Files that cannot be milled get a
//! clear error, pinned; no program prints a number with float noise.
//!
//! rs274 is found as the harness finds it (`tests::rs274`): without it the back-simulation is
//! skipped with a line on standard error, except under CI.

mod programs;

use std::path::Path;

use postpro_cl::{LengthUnit, ReadOptions};
use programs::{
    cl_points, data_dir, header_tools, machine, on_two_threads, our_float_noise, out_dir, post, postpro, program_units,
    reached_in_order, rs274_tools, stderr, tips, tolerances,
};
use tests::rs274::Rs274;

/// A real file posted on a built-in machine: the file (relative to `../shared/data`), the
/// machine, and the options beyond the defaults.
struct Case {
    file: &'static str,
    machine: &'static str,
    args: &'static [&'static str],
}

const VMC: &str = "example-3axis-vmc";

/// The files that post, each on a machine that fits it.
///
/// - 3-axis files (tool along +Z throughout): the 3-axis example VMC (LinuxCNC, 762 × 406 ×
///   508 mm), whose travels hold each of them.
/// - NX CLSFs made for the Haas UMC-750 (`userFour__MECH491-postprocessor`, inch): the built-in
///   `haas-umc750` (B −35…120° carrying C), the machine they were programmed for.
/// - SOLIDWORKS CAM 3+2 set-ups (`aamorim1913__AptPostProcessor`, tool along ±X, +Y, 0.29°
///   tilts): `maho600e`, a B/C trunnion like the DMU50-type table clsplit assumes; B ±90° holds
///   the side set-ups.
/// - CATIA's peening program (tool along −X and tilted about it) and Creo's simultaneous
///   5-axis `finition.ncl`: `mikron-ucp710`, an A/C trunnion (A −120…30°) like the B-about-X
///   table of the peer's post. `finition.ncl` says `UNITS / INCHES` over millimetre data (a
///   6 mm cutter at 7958 rpm; `docs/cl-reader.md`): `--cl-units mm`, as its README says.
const POSTED: &[Case] = &[
    Case { file: "cl/HumMan__CLSFProcessor__cutcom.clsf", machine: VMC, args: &[] },
    Case { file: "cl/HumMan__CLSFProcessor__nurbs.clsf", machine: VMC, args: &[] },
    Case { file: "cl/MichaHofft__CreoPost__bohren_1.ncl.8", machine: VMC, args: &[] },
    Case { file: "cl/MichaHofft__CreoPost__schruppen_1.ncl.1", machine: VMC, args: &[] },
    Case { file: "cl/aamorim1913__AptPostProcessor__Teste-Metrologia.apt", machine: "maho600e", args: &[] },
    Case { file: "cl/aamorim1913__AptPostProcessor__manufacture3-top.apt", machine: VMC, args: &[] },
    Case { file: "cl/aamorim1913__AptPostProcessor__shimemcunha.apt", machine: "maho600e", args: &[] },
    Case {
        file: "cl/liubaishuo-github__peening-post-processor__peening.aptsource",
        machine: "mikron-ucp710",
        args: &[],
    },
    Case { file: "cl/samueljmorris__kuka-fdm__1001.apt", machine: VMC, args: &[] },
    Case { file: "cl/steptools__STEPNode__Plane_1.cldata", machine: VMC, args: &[] },
    Case { file: "cl/steptools__STEPNode__coremill.cls", machine: VMC, args: &[] },
    Case { file: "cl/userFour__MECH491-postprocessor__APT_Project2.txt", machine: "haas-umc750", args: &[] },
    Case { file: "cl/userFour__MECH491-postprocessor__APT_code.txt", machine: "haas-umc750", args: &[] },
    Case {
        file: "peers/4r19415__5-axis-Rotation-tool-center-point-RTCP-/input/finition.ncl",
        machine: "mikron-ucp710",
        args: &["--cl-units", "mm"],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2021/Teste-Metrologia/input/Teste-Metrologia.apt",
        machine: "maho600e",
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2021/basemach/input/basemach.apt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2022/Dem-target1/input/Dem-target1.apt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2022/Dem-target2/input/Dem-target2.apt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2022/Interface-glue/input/Interface-glue.apt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2022/SupPetriLED/input/SupPetriLED.apt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2022/Top-light-cover/input/Top-light-cover.apt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2022/shimemcunha/input/shimemcunha.apt",
        machine: "maho600e",
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-2023/Teflon-gasket/input/Teflon-gasket.apt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-tools/boss/input/boss.apt",
        machine: "maho600e",
        args: &[],
    },
    Case {
        file: "peers/aamorim1913__AptPostProcessor/parts-tools/wall-holes/input/wall-holes.apt",
        machine: "maho600e",
        args: &[],
    },
    Case { file: "peers/karlo-c277__CATIAV5-Post-Processor-/dwelltest/input/dwelltest.txt", machine: VMC, args: &[] },
    Case {
        file: "peers/liubaishuo-github__peening-post-processor/input/peening.aptsource",
        machine: "mikron-ucp710",
        args: &[],
    },
    Case {
        file: "peers/userFour__MECH491-postprocessor/SimpleMillPlane/input/APT_SimpleMillPlane.txt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/userFour__MECH491-postprocessor/SimpleMillPlane_ZIG/input/APT_SimpleMillPlane_ZIG.txt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/userFour__MECH491-postprocessor/Variable_Axis/input/APT_Variable_Axis.txt",
        machine: "haas-umc750",
        args: &[],
    },
    Case {
        file: "peers/userFour__MECH491-postprocessor/Zig_Zag_Smoothed/input/APT_Zig_Zag_Smoothed.txt",
        machine: VMC,
        args: &[],
    },
    Case {
        file: "peers/userFour__MECH491-postprocessor/Zig_Zag_Smoothed_61c3654/input/APT_Zig_Zag_Smoothed.txt",
        machine: VMC,
        args: &[],
    },
];

/// The files no built-in machine mills, each with the machine it is tried on and why: their
/// errors are pinned (`snapshots/real_files__refused@….snap`).
///
/// - CATIA lathe programs (`TURRET`, `TOOLNO/…,TURN`): turning, not milling.
/// - An APT part program (source language): no CL data.
/// - SOLIDWORKS CAM files with a set-up from below (tool along −Z: the part turned over by hand
///   between set-ups, which clsplit writes as `nan`): no 5-axis machine tilts 180°.
/// - HumMan's `ust_a2.cls`: its MSYS has X and Y swapped (Z points down), so its tool axes all
///   point below the horizontal in the frame the program is written in (k from −1 to 0): the
///   head-head machine it was made for (`tool_dir (0,0,-1)`) is not one of ours, and no
///   built-in tilts past 120°.
const REFUSED: &[(&str, &str)] = &[
    ("cl/karlo-c277__CATIAV5-Post-Processor-__DEMO3.txt", VMC),
    ("cl/karlo-c277__CATIAV5-Post-Processor-__DEMO5.txt", VMC),
    ("peers/karlo-c277__CATIAV5-Post-Processor-/DEMO1/input/DEMO1.txt", VMC),
    ("cl/smooker__aptos-apt360__multax.apt", VMC),
    ("cl/aamorim1913__AptPostProcessor__Interface-glue.clt", "maho600e"),
    ("peers/aamorim1913__AptPostProcessor/parts-2021/Sacrifice-Board/input/Sacrifice-Board.apt", "maho600e"),
    ("cl/HumMan__CLSFProcessor__ust_a2.cls", "mikron-ucp710"),
];

/// The real CL files: the corpus and the peers' inputs (the hold-out files are the reader's).
fn real_files() -> Vec<String> {
    tests::real_cl_files().into_iter().map(|(name, _)| name).filter(|n| !n.starts_with("peers/holdout/")).collect()
}

#[test]
fn every_real_file_is_a_case() {
    let mut cases: Vec<&str> = POSTED.iter().map(|c| c.file).chain(REFUSED.iter().map(|r| r.0)).collect();
    cases.sort_unstable();
    let files = real_files();
    assert_eq!(
        cases,
        files.iter().map(String::as_str).collect::<Vec<_>>(),
        "add each new real file to POSTED or REFUSED"
    );
}

/// The read options a case's arguments give (for its CL points).
fn read_options(args: &[&str]) -> ReadOptions {
    let cl_units = args.windows(2).find(|w| w[0] == "--cl-units").map(|w| match w[1] {
        "inch" => LengthUnit::Inch,
        _ => LengthUnit::Mm,
    });
    ReadOptions { cl_units, ..ReadOptions::default() }
}

/// No number of a program written for a real file (header, comments, tool data, blocks) nor of
/// what `postpro` says is printed with float noise (`6.095999999999999`); numbers the CL file
/// holds as written (a PPRINT passed on as a comment) are the CAM system's. Each as
/// `program line: number` (`stderr line: number`).
fn float_noise_of(file: &str, posted: &programs::Posted) -> Vec<String> {
    let cl = std::fs::read(data_dir().join(file)).expect("the CL file");
    let cl = String::from_utf8_lossy(&cl);
    let program = our_float_noise(&posted.text, &cl).into_iter().map(|n| format!("program {n}"));
    program.chain(our_float_noise(&posted.stderr, &cl).into_iter().map(|n| format!("stderr {n}"))).collect()
}

/// Every file that posts: on its machine with default options, its LinuxCNC program prints no
/// float noise, runs in rs274 with a tool table of its tools, and the tips it drives reach every
/// CL point in order.
#[test]
fn every_real_file_posts_and_its_linuxcnc_program_reaches_the_cl_points_in_rs274() {
    let rs274 = Rs274::for_test();
    let dir = out_dir("real_files");
    let outcomes = on_two_threads(POSTED, |case| {
        let stem = case.file.replace('/', "__");
        let out = dir.join(format!("{stem}.ngc"));
        let mut args = vec!["--machine", case.machine, "--dialect", "linuxcnc"];
        args.extend_from_slice(case.args);
        post(case.file, &args, &out)
            .and_then(|posted| {
                let noise = float_noise_of(case.file, &posted);
                if !noise.is_empty() {
                    return Err(format!("numbers printed with float noise: {}", noise.join(", ")));
                }
                let Some(rs274) = &rs274 else { return Ok(format!("{}: posted", case.file)) };
                let units = program_units(&posted.text);
                let tools = header_tools(&posted.text);
                let run = rs274.run(&posted.path, &rs274_tools(&tools, units)).map_err(|e| e.to_string())?;
                let m = machine(case.machine);
                let lengths: Vec<(u32, f64)> =
                    tools.iter().filter_map(|t| t.length.map(|l| (t.number, l * units.to_mm()))).collect();
                let tips = tips(&run, &m, postpro_motion::Mode::G1, &lengths);
                let points = cl_points(&data_dir().join(case.file), &read_options(case.args));
                let (tolerance, angle) = tolerances(&m, units == tests::nc::Units::Inch);
                let (distance, off) = reached_in_order(&points, &tips, tolerance, angle)?;
                Ok(format!(
                    "{}: {} motions in rs274, {} CL points reached within {distance:.4} mm and {off:.4}°",
                    case.file,
                    run.motions.len(),
                    points.len()
                ))
            })
            .map_err(|e| format!("{} on {}: {e} ({})", case.file, case.machine, out.display()))
    });
    let report: Vec<&String> = outcomes.iter().filter_map(|o| o.as_ref().ok()).collect();
    let failures: Vec<&String> = outcomes.iter().filter_map(|o| o.as_ref().err()).collect();
    eprintln!("{}", report.iter().map(|r| r.as_str()).collect::<Vec<_>>().join("\n"));
    let failures: Vec<&str> = failures.iter().map(|f| f.as_str()).collect();
    assert!(failures.is_empty(), "{} file(s) failed:\n{}", failures.len(), failures.join("\n\n"));
}

/// The files no built-in machine mills get a clear error, which names the file, line and column
/// and says why; nothing is written.
#[test]
fn files_that_cannot_be_milled_get_a_clear_error() {
    let dir = out_dir("refused");
    let mut posted = Vec::new();
    for (file, machine) in REFUSED {
        let out = dir.join("refused.ngc");
        let o = postpro(&["--machine", machine, file, "-o", out.to_str().expect("a UTF-8 path")], &data_dir());
        if o.status.code() != Some(1) || out.exists() {
            posted.push(format!("{file} on {machine}: exit {:?}, {}", o.status.code(), stderr(&o)));
            let _ = std::fs::remove_file(&out);
            continue;
        }
        let name = Path::new(file).file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
        insta::assert_snapshot!(format!("refused@{name}"), stderr(&o), &format!("postpro --machine {machine} {file}"));
    }
    assert!(posted.is_empty(), "files that cannot be milled were posted:\n{}", posted.join("\n"));
}
