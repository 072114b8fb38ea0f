//! The policy's first pass: every solution of every target, and the dynamic programme (or the
//! greedy choice) over the regular ones, keeping only the branch graph and a summary of each
//! singular run.

use nalgebra::Point3;
use postpro_machine::model::PathChoice;

use super::{
    Choice, Node, ON_POLE, Rules, Run, Swing, Target, best_state, passes_pole, pole_distance, run_move, swing_weight,
};
use crate::bits::Bits;
use crate::policy::{Policy, SolveError};
use crate::pose::{Joints, Pose};
use crate::solver::{Kinematics, Solutions};

/// The first pass of the policy (see [`super::choose`]): push every target in path order, then
/// [`BranchGraph::finish`]. Holds the last layer of the dynamic programme and, per regular target,
/// two bits: the state each of its two states came from.
pub struct BranchGraph<'a> {
    kin: &'a dyn Kinematics,
    rules: Rules<'a>,
    sols: Solutions,
    probe: Solutions,
    /// The states of the last regular target (the start before the first).
    layer: [Node; 2],
    /// Per regular target, the predecessor of each state (bit `2k + s`).
    preds: Bits,
    regular: Bits,
    /// Per regular target, whether the move into it passes the pole.
    pole_passages: Bits,
    /// Regular targets so far.
    regulars: usize,
    /// Targets so far.
    index: usize,
    /// The previous regular target: its index, pose and pole distance.
    previous_regular: Option<(usize, Pose, f64)>,
    /// The previous target: its tip and pole distance (for the weights of a singular run).
    previous: Option<(Point3<f64>, f64)>,
    /// A rapid among the targets since the previous regular one (this one included).
    rapid_since: bool,
    /// The singular run being read.
    run: Option<OpenRun>,
    runs: Vec<Run>,
}

/// A singular run not yet closed by a regular target.
struct OpenRun {
    start: usize,
    free: u8,
    points: usize,
    has_rapid: bool,
    /// The last move into `start.max(1)..` that is a rapid (target index).
    last_rapid: Option<usize>,
    on_pole: bool,
    /// Sums of the weights of the moves so far as if no move / some move were on the pole.
    inverse_eps: f64,
    on_pole_length: f64,
}

impl OpenRun {
    /// Adds the move into target `index` (tip `tip`, pole distance `pole`) from the previous
    /// target, rapid or not.
    fn add_move(
        &mut self,
        index: usize,
        rapid: bool,
        previous: Option<(Point3<f64>, f64)>,
        tip: Point3<f64>,
        pole: f64,
    ) {
        let Some((eps, length)) = run_move(self.start, index, previous, tip, pole) else { return };
        if rapid {
            self.last_rapid = Some(index);
        }
        if eps < ON_POLE {
            self.on_pole = true;
        }
        self.inverse_eps += swing_weight(eps, 0.0, false);
        self.on_pole_length += swing_weight(eps, length, true);
    }

    fn close(self, after: Option<[f64; 2]>) -> Run {
        let swing = match self.last_rapid {
            Some(m) => Swing::AtRapid(m),
            None => Swing::Weighted {
                on_pole: self.on_pole,
                total: if self.on_pole { self.on_pole_length } else { self.inverse_eps },
            },
        };
        Run { points: self.points, free: self.free, after, has_rapid: self.has_rapid, swing }
    }
}

impl<'a> BranchGraph<'a> {
    /// A graph for `kin` under `policy`, the machine at `start` before the first target (its
    /// home position when `None`). The tool length does not matter: the rotary axes, which the
    /// choice is about, do not depend on it.
    pub fn new(kin: &'a dyn Kinematics, policy: &'a Policy, start: Option<&Joints>) -> BranchGraph<'a> {
        let rules = Rules::new(kin.machine(), policy);
        let start = start.copied().unwrap_or(rules.home);
        BranchGraph {
            kin,
            rules,
            sols: Solutions::new(),
            probe: Solutions::new(),
            layer: [Node { jumps: 0, cost: 0.0, pred: 0, joints: start, branch: u8::MAX }, Node::EMPTY],
            preds: Bits::default(),
            regular: Bits::default(),
            pole_passages: Bits::default(),
            regulars: 0,
            index: 0,
            previous_regular: None,
            previous: None,
            rapid_since: false,
            run: None,
            runs: Vec::new(),
        }
    }

    /// The next target. An error when it cannot be reached at all, or only beyond the travels.
    pub fn push(&mut self, t: &Target) -> Result<(), SolveError> {
        let i = self.index;
        self.index += 1;
        self.kin.inverse(&t.pose, &mut self.sols);
        if self.sols.is_empty() {
            return Err(self.rules.unreachable(t));
        }
        let pole = pole_distance(&self.sols);
        self.rapid_since |= t.rapid;
        let previous = self.previous.replace((t.pose.tip, pole));
        if let Some(free) = self.rules.free_axis(&self.sols) {
            self.regular.push(false);
            let run = self.run.get_or_insert(OpenRun {
                start: i,
                free: free as u8,
                points: 0,
                has_rapid: false,
                last_rapid: None,
                on_pole: false,
                inverse_eps: 0.0,
                on_pole_length: 0.0,
            });
            run.points += 1;
            run.has_rapid |= t.rapid;
            run.add_move(i, t.rapid, previous, t.pose.tip, pole);
            return Ok(());
        }
        self.regular.push(true);
        if let Some(run) = self.run.as_mut() {
            run.add_move(i, t.rapid, previous, t.pose.tip, pole);
        }
        // Consecutive feed points: here a branch change away from the pole, or a turn beyond the
        // nearest one, is a discontinuity.
        let previous_target = self.previous_regular.filter(|&(p, _, _)| p + 1 == i && !self.rapid_since);
        let pole_passage = previous_target.is_some_and(|(_, pose, p_pole)| {
            passes_pole(self.kin, (&pose, p_pole), (&t.pose, pole), self.rules.policy.pole_passage, &mut self.probe)
        });
        self.pole_passages.push(pole_passage);
        let rules = &self.rules;
        let mut layer = [Node::EMPTY; 2];
        let mut reasons: [Option<(usize, f64)>; 4] = [None; 4];
        for (s, cand) in self.sols.iter().enumerate() {
            if let Err(reason) = rules.linear_ok(&cand.joints) {
                reasons[2 * s] = Some(reason);
                continue;
            }
            for (p, node) in self.layer.iter().enumerate().filter(|(_, n)| n.is_live()) {
                match rules.unwound(&cand.joints, &node.joints) {
                    Ok(mut j) => {
                        let switch = node.branch != u8::MAX && node.branch != cand.branch;
                        let jump = rules.jump(
                            (&node.joints, node.branch),
                            (&j, cand.branch),
                            previous_target.is_some(),
                            pole_passage,
                        );
                        // The travel before unwinding: the whole turns taken off at a rapid are
                        // the policy's, and must not make the other branch look cheaper.
                        let cost = node.cost
                            + rules.travel_cost(&node.joints, &j)
                            + if switch { super::SWITCH_COST } else { 0.0 }
                            + if rules.preferred(&j) { 0.0 } else { super::OFF_PREFERENCE_COST };
                        if self.rapid_since {
                            rules.unwinding.apply(&mut j);
                        }
                        let next = Node {
                            jumps: node.jumps + u32::from(jump.is_some()),
                            cost,
                            pred: p as u8,
                            joints: j,
                            branch: cand.branch,
                        };
                        if next.better_than(&layer[s]) {
                            layer[s] = next;
                        }
                    }
                    Err(reason) => reasons[2 * s + p] = Some(reason),
                }
            }
        }
        if !layer.iter().any(Node::is_live) {
            let reasons: Vec<(usize, f64)> = reasons.into_iter().flatten().collect();
            return Err(rules.out_of_travel(t, &reasons));
        }
        if rules.policy.choice == PathChoice::Greedy {
            // Keep only the best: the next point is chosen from it alone.
            let best = best_state(&layer);
            layer[1 - best] = Node::EMPTY;
        }
        if let Some(run) = self.run.take() {
            let free = usize::from(run.free);
            let value = |n: &Node| if n.is_live() { n.joints[free] } else { f64::NAN };
            self.runs.push(run.close(Some([value(&layer[0]), value(&layer[1])])));
        }
        self.preds.push(layer[0].pred == 1);
        self.preds.push(layer[1].pred == 1);
        self.layer = layer;
        self.regulars += 1;
        self.previous_regular = Some((i, t.pose, pole));
        self.rapid_since = false;
        Ok(())
    }

    /// The choice: back from the best last state, the state of every regular target.
    pub fn finish(mut self) -> Choice {
        if let Some(run) = self.run.take() {
            self.runs.push(run.close(None));
        }
        let mut states = Bits::default();
        for _ in 0..self.regulars {
            states.push(false);
        }
        if self.regulars > 0 {
            let mut s = best_state(&self.layer);
            for k in (0..self.regulars).rev() {
                states.set(k, s == 1);
                s = usize::from(self.preds.get(2 * k + s));
            }
        }
        Choice { regular: self.regular, states, pole_passages: self.pole_passages, runs: self.runs }
    }
}
