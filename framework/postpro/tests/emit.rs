//! The main job, `postpro --machine NAME FILE.cl [-o OUT]`: where the program goes, what it
//! starts with, and the error cases (unknown machine, unreachable pose, unwritable output),
//! which never leave a partial program nor clobber an existing one.

mod common;

use std::ops::Deref;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn postpro(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postpro")).args(args).current_dir(dir).output().expect("postpro runs")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8(bytes.to_vec()).expect("UTF-8")
}

/// A scratch folder, removed when the test passes (kept to look into when it fails).
struct Scratch(PathBuf);

impl Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A scratch folder with a copy of a CL file of the repository.
fn scratch(name: &str, cl: &str) -> Scratch {
    let dir = std::env::temp_dir().join(format!("postpro-emit-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    std::fs::copy(repo().join(cl), dir.join(Path::new(cl).file_name().expect("file name"))).expect("copy");
    Scratch(dir)
}

fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .expect("list")
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .filter(|n| n.contains(".tmp"))
        .collect()
}

#[test]
fn the_program_goes_next_to_the_cl_file_with_the_dialect_extension() {
    let dir = scratch("default", "examples/cl/hypar-5axis.cl");
    let o = postpro(&["--machine", "mikron", "hypar-5axis.cl"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let program = std::fs::read_to_string(dir.join("hypar-5axis.mpf")).expect("hypar-5axis.mpf written");
    assert!(program.starts_with("; HYPAR-5AXIS: hypar-5axis.cl on mikron-ucp710, mode tcp\n"), "{}", &program[..200]);
    assert!(program.ends_with("M30\n"));
    assert!(
        text(&o.stderr).lines().any(|l| l.starts_with("wrote hypar-5axis.mpf for mikron-ucp710 ")),
        "{}",
        text(&o.stderr)
    );
    // TCP mode writes none of the points the linearization added, and says so where it counts them.
    let unwritten = "added by linearization (not written: TCP keeps the tip on the path)";
    assert!(text(&o.stderr).contains(unwritten), "{}", text(&o.stderr));
    assert!(program.contains("\n; the points added by linearization are not written: TCP keeps the tip on the path"));
    let o = postpro(&["-m", "maho", "hypar-5axis.cl", "--mode", "inverse-time"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(!text(&o.stderr).contains("not written"), "{}", text(&o.stderr));
    assert!(std::fs::read_to_string(dir.join("hypar-5axis.nc")).expect("fanuc program").contains("G93"));
    assert!(leftovers(&dir).is_empty());
}

#[test]
fn dash_writes_to_standard_output() {
    let dir = scratch("stdout", "examples/cl/hypar-5axis.cl");
    let o = postpro(&["-m", "mikron", "hypar-5axis.cl", "--dialect", "linuxcnc", "-o", "-", "--block-numbers"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    assert!(out.starts_with("%\n"), "{}", &out[..100]);
    assert!(out.contains("\nN10 "), "block numbers");
    assert!(!dir.join("hypar-5axis.ngc").exists());
}

#[test]
fn an_unknown_machine_suggests_the_nearest_names() {
    let dir = scratch("unknown", "examples/cl/hypar-5axis.cl");
    let o = postpro(&["-m", "mikorn", "hypar-5axis.cl"], &dir);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("mikron"), "{}", text(&o.stderr));
}

#[test]
fn an_unreachable_pose_names_the_line_and_keeps_the_old_program() {
    let dir = scratch("unreachable", "tests/kin/unreachable.cl");
    std::fs::write(dir.join("unreachable.mpf"), "old program\n").expect("an existing program");
    let o = postpro(&["-m", "mikron", "unreachable.cl"], &dir);
    assert_eq!(o.status.code(), Some(1));
    let err = text(&o.stderr);
    assert!(err.contains("[unreachable.cl:6:1]") && err.contains("no solution within the travel"), "{err}");
    assert_eq!(std::fs::read_to_string(dir.join("unreachable.mpf")).expect("kept"), "old program\n");
    assert!(leftovers(&dir).is_empty());
}

#[test]
fn an_unwritable_output_is_an_error_without_a_partial_file() {
    let dir = scratch("unwritable", "examples/cl/hypar-5axis.cl");
    let o = postpro(&["-m", "mikron", "hypar-5axis.cl", "-o", "missing-folder/out.mpf"], &dir);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("cannot write missing-folder/out.mpf"), "{}", text(&o.stderr));
    assert!(leftovers(&dir).is_empty());
    let o = postpro(&["-m", "fanuc-has-no-such-machine", "hypar-5axis.cl", "--dialect", "nonsense"], &dir);
    assert_eq!(o.status.code(), Some(2));
    let o = postpro(&["-m", "mikron", "hypar-5axis.cl", "--dialect", "linuxcnc", "--mode", "tcp"], &dir);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stderr).contains("the linuxcnc dialect has no tcp mode"), "{}", text(&o.stderr));
    assert!(!dir.join("hypar-5axis.ngc").exists());
}

#[test]
fn the_output_never_overwrites_the_cl_file() {
    let dir = scratch("same", "examples/cl/hypar-5axis.cl");
    std::fs::rename(dir.join("hypar-5axis.cl"), dir.join("part.nc")).expect("rename");
    let o = postpro(&["-m", "maho", "part.nc"], &dir);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(std::fs::read_to_string(dir.join("part.nc")).expect("kept").starts_with("$$ GENERATOR"));
}

/// A device or a named pipe as the output (`-o /dev/null`, a FIFO a shop's tooling reads) is
/// written in place: renaming a file over it, as a regular output is replaced, would turn the
/// device or the pipe into a regular file (as root, `/dev/null` itself).
#[test]
fn a_named_pipe_as_the_output_is_written_through_and_stays_a_pipe() {
    use std::os::unix::fs::FileTypeExt;
    let dir = scratch("fifo", "examples/cl/hypar-5axis.cl");
    let fifo = dir.join("program.pipe");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo runs");
    assert!(made.success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).expect("the pipe reads"))
    };
    let o = postpro(&["-m", "maho", "hypar-5axis.cl", "--no-predict", "-o", "program.pipe"], &dir);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    // Checked before waiting for the reader, which waits for ever on a pipe renamed away.
    assert!(std::fs::metadata(&fifo).expect("still there").file_type().is_fifo(), "still a named pipe");
    let read = reader.join().expect("the reader ends");
    assert!(read.starts_with("%\n") && read.trim_end().ends_with('%'), "the whole program through the pipe");
    assert!(leftovers(&dir).is_empty());
}

/// Where nothing in the program waits for the end of the prediction, the prediction pass writes
/// it as it goes and the slowdowns' comments are put in their places afterwards: two passes over
/// the CL file instead of three. The program, the messages and the exit code are those of the
/// three passes byte for byte, in every dialect and mode, B-spline runs with their comments
/// inside, Heidenhain's numbered lines and `N` words (moved up after each comment; a verbatim
/// insert's own `N` word after the block's stays) included, rotary brakes too (locked where the
/// tool axes say a set-up stands); the cases whose program depends on the whole pass take the
/// third: brakes where the steps prove the tool axes' guess wrong, 3+2 set-ups in working planes
/// (predicted again on their blocks first), `N` words on Heidenhain's numbered lines.
#[test]
fn the_program_the_prediction_pass_writes_is_the_one_a_pass_of_its_own_writes() {
    let dir = scratch("two-passes", "examples/cl/hypar-5axis.cl");
    for other in ["bicubic-5axis.cl", "hypar-3plus2.cl", "manta-5axis.cl"] {
        std::fs::copy(repo().join("examples/cl").join(other), dir.join(other)).expect("copy");
    }
    let hypar = std::fs::read_to_string(dir.join("hypar-5axis.cl")).expect("the example");
    let insert = hypar.replacen("FEDRAT/MMPM,2000.0000\n", "FEDRAT/MMPM,2000.0000\nINSERT/N5 M1\n", 1);
    assert_ne!(insert, hypar, "the insert goes in");
    std::fs::write(dir.join("insert.cl"), insert).expect("write");
    std::fs::write(dir.join("wiggle.cl"), common::two_set_ups(true)).expect("write");
    std::fs::write(dir.join("still.cl"), common::two_set_ups(false)).expect("write");
    // The file, the machine, the options, and the passes: as it goes, and with `--three-passes`.
    type Case<'a> = (&'a str, &'a str, &'a [&'a str], (usize, usize));
    let cases: &[Case<'_>] = &[
        ("hypar-5axis.cl", "mikron", &["--mode", "g1"], (2, 3)),
        ("hypar-5axis.cl", "mikron", &["--mode", "tcp", "--tcp-orientation", "vectors"], (2, 3)),
        ("hypar-5axis.cl", "mikron", &["--mode", "bspline"], (2, 3)),
        ("bicubic-5axis.cl", "mikron", &["--mode", "inverse-time"], (2, 3)),
        ("bicubic-5axis.cl", "maho600e", &[], (2, 3)),
        ("hypar-5axis.cl", "mikron", &["--dialect", "linuxcnc"], (2, 3)),
        ("manta-5axis.cl", "nutating", &[], (2, 3)),
        ("hypar-5axis.cl", "mikron", &["--block-numbers"], (2, 3)),
        ("hypar-5axis.cl", "mikron", &["--block-numbers", "--mode", "bspline"], (2, 3)),
        ("bicubic-5axis.cl", "maho600e", &["--block-numbers"], (2, 3)),
        ("insert.cl", "mikron", &["--block-numbers", "--insert", "verbatim"], (2, 3)),
        ("insert.cl", "mikron", &["--block-numbers"], (2, 3)),
        ("hypar-5axis.cl", "mikron", &["--block-numbers", "--dialect", "heidenhain"], (3, 3)),
        ("hypar-5axis.cl", "mikron", &["--dialect", "heidenhain"], (2, 3)),
        (
            "hypar-5axis.cl",
            "mikron",
            &["--dialect", "heidenhain", "--mode", "tcp", "--tcp-orientation", "vectors"],
            (2, 3),
        ),
        // Rotary brakes: locked where the tool axes say, as the steps then prove.
        ("hypar-5axis.cl", "haas-umc750", &[], (2, 3)),
        ("bicubic-5axis.cl", "haas-umc750", &["--mode", "inverse-time"], (2, 3)),
        ("still.cl", "haas-umc750", &["--plane-mode", "joints"], (2, 3)),
        // The tool axes' guess proved wrong by the steps: the program written by a pass of its own.
        ("wiggle.cl", "haas-umc750", &["--plane-mode", "joints"], (3, 3)),
        // Working planes where the tool axes say set-ups stand, as the steps then prove; a pass
        // of their own predicts again on the blocks in the planes where the prediction pass was
        // not in them (--three-passes: four passes).
        ("hypar-3plus2.cl", "haas-umc750", &[], (2, 4)),
        ("hypar-3plus2.cl", "mikron", &[], (2, 4)),
        ("hypar-3plus2.cl", "maho600e", &["--mode", "inverse-time"], (2, 4)),
        // Without a prediction, the same: the pass that surveys the steps writes the program.
        ("hypar-5axis.cl", "mikron", &["--no-predict"], (2, 3)),
        ("hypar-3plus2.cl", "haas-umc750", &["--no-predict"], (2, 3)),
        ("wiggle.cl", "mikron", &["--no-predict"], (4, 3)),
        ("still.cl", "mikron", &[], (2, 4)),
        // Predicted in working planes the steps do not stand in as guessed: predicted again
        // without the guess, in the planes again, then written: five passes.
        ("wiggle.cl", "haas-umc750", &[], (5, 4)),
        ("wiggle.cl", "mikron", &[], (5, 4)),
    ];
    // What a run says, but for the name of its output and the times.
    let said = |o: &Output, out: &str| -> String {
        text(&o.stderr).lines().filter(|l| !l.starts_with("timing:")).collect::<Vec<_>>().join("\n").replace(out, "OUT")
    };
    let mut commented = 0;
    for &(file, machine, args, passes) in cases {
        let case = format!("{file} on {machine} {}", args.join(" "));
        let run = |out: &str, extra: &[&str]| {
            let mut all = vec!["--machine", machine, file, "-o", out, "--timing"];
            all.extend_from_slice(args);
            all.extend_from_slice(extra);
            postpro(&all, &dir)
        };
        let (two, three) = (run("two.nc", &[]), run("three.nc", &["--three-passes"]));
        assert!(two.status.success() && three.status.success(), "{case}: {}", text(&two.stderr));
        let (passes, passes_alone) = passes;
        let timing = text(&two.stderr).lines().find(|l| l.starts_with("timing:")).unwrap_or_default().to_string();
        assert!(timing.contains(&format!("; {passes} passes")), "{case}: {timing}");
        assert!(text(&three.stderr).contains(&format!("; {passes_alone} passes")), "{case}");
        let program = |name: &str| std::fs::read(dir.join(name)).expect("the program");
        assert!(program("two.nc") == program("three.nc"), "{case}: the programs differ");
        assert_eq!(said(&two, "two.nc"), said(&three, "three.nc"), "{case}");
        // Where the header names slowdowns, their comments are put in the body.
        let written = text(&program("two.nc"));
        if passes == 2 && written.contains("worst slowdown #") {
            commented += 1;
            assert!(written.contains("slowdown #1:"), "{case}: the slowdowns' comments are put in");
        }
    }
    assert!(commented >= 15, "{commented} cases with comments put in");
    let left: Vec<String> = std::fs::read_dir(&*dir)
        .expect("list")
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "scratch files left: {left:?}");
}

#[test]
fn moves_linearization_cannot_bring_within_tolerance_are_a_warning_that_strict_refuses() {
    let dir = scratch("unsettled", "framework/postpro/tests/jobs/two_tools_tilted.cl");
    // Its first moves: a plunge, then two tilting feed moves.
    let cl = std::fs::read_to_string(dir.join("two_tools_tilted.cl")).expect("read");
    let head: Vec<&str> = cl.lines().take(11).collect();
    std::fs::write(dir.join("tilting.cl"), format!("{}\nFINI\n", head.join("\n"))).expect("write");
    // A tolerance no 4096 points a move reach: each tilting feed move stays over it.
    let run = |extra: &[&str]| {
        let mut args = vec!["--machine", "maho600e", "tilting.cl", "--tolerance", "1e-9"];
        args.extend_from_slice(extra);
        postpro(&args, &dir)
    };
    let said = "2 feed move(s), the first here, stray up to ";
    let out = run(&["--mode", "g1", "-o", "g1.h"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    let warning = stderr.lines().find(|l| l.contains(said)).unwrap_or_else(|| panic!("{stderr}"));
    assert!(warning.starts_with("warning: tilting.cl:10:1: "), "{warning}");
    assert!(warning.contains("over the linearization tolerance of 0.000000001 mm"), "{warning}");
    assert!(dir.join("g1.h").exists());

    let out = run(&["--mode", "g1", "-o", "strict.h", "--strict"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    let stderr = text(&out.stderr);
    assert!(stderr.contains(&format!("error: tilting.cl:10:1: {said}")), "{stderr}");
    assert!(stderr.contains("--strict makes them errors"), "{stderr}");
    assert!(!dir.join("strict.h").exists());
    assert_eq!(leftovers(&dir), Vec::<String>::new());

    // With the tolerance reached, and in TCP mode (the controller keeps the tip on the path),
    // nothing is said.
    let out = postpro(&["--machine", "maho600e", "tilting.cl", "--mode", "g1", "-o", "-"], &dir);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!text(&out.stderr).contains("stray up to"), "{}", text(&out.stderr));
    let out = run(&["--mode", "tcp", "-o", "-", "--strict"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!text(&out.stderr).contains("stray up to"), "{}", text(&out.stderr));

    // `solve` says it in its summary.
    let out = postpro(&["solve", "--machine", "maho600e", "tilting.cl", "--tolerance", "1e-9"], &dir);
    let summary = text(&out.stdout);
    let line = summary.lines().find(|l| l.starts_with("off path    ")).unwrap_or_else(|| panic!("{summary}"));
    assert!(line.starts_with("off path    2 feed move(s) stray up to "), "{line}");
    assert!(line.ends_with("(first at tilting.cl:10:1)"), "{line}");
    let out = postpro(&["solve", "--machine", "maho600e", "tilting.cl"], &dir);
    assert!(!text(&out.stdout).contains("off path"), "{}", text(&out.stdout));
}
