//! Checking poses without planning (`maamplan check`): the head at every
//! waypoint as the machine poses it — the pose [`crate::plan`] starts
//! from — or at a written plan's rows, with the printing moves between
//! them split as `plan` writes them; one verdict each, counted per layer.

use crate::collide::CollideError;
use crate::io::plan_csv::PlanRow;
use crate::job::LoadedJob;
use crate::kinematics::{Axes, Machine};
use crate::plan::layer_reading::NearestLayer;
use crate::plan::{input_axes, runs, PlanOptions};
use crate::prove::Prover;
use crate::scene::cutoff;

/// What can go wrong checking a written plan.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// The plan has a row count other than the toolpath's waypoint count.
    #[error(
        "{rows} rows but the toolpath has {waypoints} waypoints: check the plan of this toolpath"
    )]
    RowCount {
        /// Rows of the plan.
        rows: usize,
        /// Waypoints of the toolpath.
        waypoints: usize,
    },
    /// A collision backend failed.
    #[error(transparent)]
    Collide(#[from] CollideError),
}

/// What was checked, per waypoint.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdicts {
    /// Does its pose come within the margin (`None`: not posed, a row the
    /// plan skips)?
    pub poses: Vec<Option<bool>>,
    /// Does a printing move into it come within the margin (`None`: no
    /// move into it checked)?
    pub moves: Vec<Option<bool>>,
}

impl Verdicts {
    /// Printing moves checked.
    pub fn moves_checked(&self) -> usize {
        self.moves.iter().filter(|m| m.is_some()).count()
    }

    /// The waypoints whose pose collides, in order.
    pub fn colliding_waypoints(&self) -> Vec<usize> {
        colliding(&self.poses)
    }

    /// The waypoints a colliding printing move goes into, in order.
    pub fn colliding_moves_into(&self) -> Vec<usize> {
        colliding(&self.moves)
    }

    /// Per layer of `job`, its waypoints and the colliding poses and
    /// moves among them.
    pub fn per_layer(&self, job: &LoadedJob) -> Vec<LayerCount> {
        let mut counts = vec![LayerCount::default(); job.toolpath.layers.len()];
        for (i, (pose, into)) in self.poses.iter().zip(&self.moves).enumerate() {
            let count = &mut counts[job.scene.waypoint_layers[i] as usize];
            count.waypoints += 1;
            count.colliding += (*pose == Some(true)) as usize;
            count.colliding_moves += (*into == Some(true)) as usize;
        }
        counts
    }
}

fn colliding(verdicts: &[Option<bool>]) -> Vec<usize> {
    verdicts
        .iter()
        .enumerate()
        .filter(|(_, v)| **v == Some(true))
        .map(|(i, _)| i)
        .collect()
}

/// One layer's counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LayerCount {
    /// Waypoints.
    pub waypoints: usize,
    /// Colliding poses.
    pub colliding: usize,
    /// Colliding printing moves into its waypoints.
    pub colliding_moves: usize,
}

impl LayerCount {
    /// The sum of `counts`.
    pub fn total<'a>(counts: impl IntoIterator<Item = &'a LayerCount>) -> LayerCount {
        counts
            .into_iter()
            .fold(LayerCount::default(), |sum, c| LayerCount {
                waypoints: sum.waypoints + c.waypoints,
                colliding: sum.colliding + c.colliding,
                colliding_moves: sum.colliding_moves + c.colliding_moves,
            })
    }
}

/// Every waypoint of `job` posed as `machine` poses it (direct IK, C
/// unwound per continuous run), each checked by `prover` against the
/// material printed before it; no moves.
pub fn input_poses(
    job: &LoadedJob,
    machine: &Machine,
    prover: &Prover,
) -> Result<Verdicts, CollideError> {
    let toolpath = &job.toolpath;
    let axes = input_axes(
        machine,
        &toolpath.positions(),
        &toolpath.directions(),
        &runs(toolpath, PlanOptions::default().jump),
    );
    let axes: Vec<Option<Axes>> = axes.into_iter().map(Some).collect();
    Ok(Verdicts {
        poses: poses(&axes, prover)?,
        moves: vec![None; toolpath.waypoint_count()],
    })
}

/// The poses of a written plan's `rows` (one per waypoint of `job`) and
/// the printing moves between consecutive visited rows, split for the tip
/// tolerance exactly as `plan` writes them.
pub fn written_plan(
    job: &LoadedJob,
    machine: &Machine,
    prover: &Prover,
    rows: &[PlanRow],
) -> Result<Verdicts, CheckError> {
    let n = job.toolpath.waypoint_count();
    if rows.len() != n {
        return Err(CheckError::RowCount {
            rows: rows.len(),
            waypoints: n,
        });
    }
    let axes: Vec<Option<Axes>> = rows.iter().map(row_axes).collect();
    let poses = poses(&axes, prover)?;
    let moves = plan_moves(job, machine, prover, rows, &axes)?;
    Ok(Verdicts { poses, moves })
}

/// A row's machine axes (`None`: the plan skips it).
fn row_axes(row: &PlanRow) -> Option<Axes> {
    row.axes.map(|v| Axes {
        xyz: [v[0], v[1], v[2]],
        tilt: v[3].to_radians(),
        c: v[4].to_radians(),
    })
}

/// Each pose (`None`: none there) checked against the material printed
/// before its waypoint.
fn poses(axes: &[Option<Axes>], prover: &Prover) -> Result<Vec<Option<bool>>, CollideError> {
    let items: Vec<(usize, Axes)> = axes
        .iter()
        .enumerate()
        .filter_map(|(g, a)| a.map(|a| (g, a)))
        .collect();
    let pose_hits = prover.poses_at(
        &items
            .iter()
            .map(|(g, a)| (*a, cutoff(*g)))
            .collect::<Vec<_>>(),
        prover.margin,
    )?;
    let mut poses = vec![None; axes.len()];
    for ((g, _), h) in items.iter().zip(pose_hits) {
        poses[*g] = Some(h);
    }
    Ok(poses)
}

/// Per row, whether a printing move into it (none after a travel or a
/// skipped row) collides.
fn plan_moves(
    job: &LoadedJob,
    machine: &Machine,
    prover: &Prover,
    rows: &[PlanRow],
    axes: &[Option<Axes>],
) -> Result<Vec<Option<bool>>, CollideError> {
    let reader = NearestLayer::of(&job.toolpath);
    let mut specs = Vec::new();
    let mut owner = Vec::new();
    for g in 1..axes.len() {
        let (Some(a), Some(b)) = (axes[g - 1], axes[g]) else {
            continue;
        };
        if rows[g].travel_before {
            continue;
        }
        let layer = job.scene.waypoint_layers[g] as usize;
        for mv in reader.bead_moves(machine, &a, &b, machine.tip_tolerance, layer, g as u32) {
            specs.push(mv);
            owner.push(g);
        }
    }
    let hits = prover.moves(&specs)?;
    let mut moves = vec![None; axes.len()];
    for (&g, h) in owner.iter().zip(hits) {
        let e = moves[g].get_or_insert(false);
        *e |= h;
    }
    Ok(moves)
}
