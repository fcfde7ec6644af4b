//! Proofs that poses and whole moves keep the safety margin: what the
//! machine does between two G-code lines ([`bounds`]), how much of a move
//! one pose's clearance covers ([`levels`]), and the [`Prover`] that turns
//! the collision evaluator's boolean answers into verdicts on moves. The
//! planner, `simulate` and `check` all prove through it.

pub mod bounds;
pub mod levels;
pub mod prover;

pub use bounds::{
    displacement_bound, pieces_bound, sweep, tip_deviation_bound, tip_subdivision,
    tip_subdivision_where, Sweep,
};
pub use prover::{Answering, MoveSpec, Prover, Ticker};
