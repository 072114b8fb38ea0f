//! B-spline throughput (CL points per second) on one run of feed moves of 10 k, 100 k and 1 M
//! points: a smooth 5-axis finishing path in NX CLSF (a spiral winding in and out over a saddle,
//! a point every 0.5 mm, the tool tilted 10–40° and swinging, every 500th segment 8 mm long so
//! that the fit refines there), read, solved on the Mikron UCP 710 and fitted within its
//! tolerance (`fit`), then evaluated as the prediction does (`evaluate`: values and the first
//! three derivatives at four parameters per segment, in order).
//! `cargo bench -p postpro-kin --bench bspline` prints Kelem/s and Melem/s (elements are points).

use std::fmt::Write;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use postpro_cl::{Source, read};
use postpro_kin::bspline::{Run, fit_indexed};
use postpro_kin::{Joints, Pose, choose, solver_for, targets};
use postpro_machine::Registry;

/// The NX CLSF text of the spiral: a rapid to its start, then `points` feed moves.
fn spiral_cl(points: usize) -> String {
    let mut text = String::from("TOOL PATH/VARIABLE_CONTOUR,TOOL,BALL_D10\nTLDATA/MILL,10.0,5.0,75.0,0.0,0.0\n");
    let mut theta = 0.0_f64;
    for k in 0..points {
        // The radius swings between 20 and 100 mm, slowly enough to stay a fine spiral.
        let r = 60.0 - 40.0 * (theta / 400.0).cos();
        let (x, y) = (r * theta.cos(), r * theta.sin());
        let tilt = (25.0 + 15.0 * (k as f64 * 0.0021).sin()).to_radians();
        let azimuth = 0.8 * (k as f64 * 0.0017).sin() + 0.2 * theta.sin();
        let (i, j, l) = (tilt.sin() * azimuth.cos(), tilt.sin() * azimuth.sin(), tilt.cos());
        if k == 0 {
            text.push_str("RAPID\n");
        }
        let _ = writeln!(text, "GOTO/{x:.4},{y:.4},{:.4},{i:.7},{j:.7},{l:.7}", (y * y - x * x) / 800.0);
        if k == 0 {
            text.push_str("FEDRAT/MMPM,2000.0\n");
        }
        let step = if k % 500 == 499 { 8.0 } else { 0.5 };
        theta += step / r;
    }
    text
}

fn bench(c: &mut Criterion) {
    let registry = Registry::builtin().expect("built-in machines");
    let machine = &registry.find("mikron-ucp710").expect("the Mikron is built in").machine;
    let kin = solver_for(machine);
    let policy = &machine.policy;
    let mut group = c.benchmark_group("bspline");
    group.sample_size(10);
    for points in [10_000, 100_000, 1_000_000] {
        let path = read(&Source::new("spiral.cl", spiral_cl(points)));
        let solved = choose(kin.as_ref(), &targets(&path, policy.linearization_tolerance), policy, None)
            .unwrap_or_else(|e| panic!("the benchmark path does not solve: {e}"));
        let joints: Vec<Joints> = solved.steps.iter().map(|s| s.joints).collect();
        let poses: Vec<Pose> = solved.steps.iter().map(|s| s.pose).collect();
        let run = Run { joints: &joints, poses: &poses };
        let fit = || fit_indexed(kin.as_ref(), &run, policy.linearization_tolerance, policy.singular_cone);
        let fitted = fit().unwrap_or_else(|| panic!("the {points}-point run does not fit"));
        eprintln!(
            "{points} points: {} interpolated ({} midpoints)",
            fitted.poses.len(),
            fitted.poses.len() - joints.len()
        );
        group.throughput(Throughput::Elements(points as u64));
        group.bench_function(BenchmarkId::new("fit", points), |b| b.iter(|| fit().map(|f| f.poses.len())));
        group.bench_function(BenchmarkId::new("evaluate", points), |b| {
            b.iter(|| {
                let mut cursor = fitted.spline.cursor();
                let mut sum = 0.0;
                for w in fitted.params.windows(2) {
                    for k in 0..4 {
                        let u = w[0] + (w[1] - w[0]) * f64::from(k) / 4.0;
                        sum += cursor.at(u)[0] + cursor.derivatives(u)[3][0];
                    }
                }
                sum
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
