//! # maamplan
//!
//! Collision-free, singularity-aware motion planning for multi-axis additive
//! manufacturing. This crate answers one question millions of times: *with
//! the print head at this pose, does it touch the platform or anything
//! already printed (or come closer to it than a safety margin)?* — exactly
//! (triangle-level), for batches of poses.
//! [`plan`] builds machine motion on top of it, and [`generate`] makes the
//! waypoints from a mesh (planar slicing with raster fills, iso-planar
//! paths on a curved layer). [`check`] asks it of every waypoint's pose
//! (or a written plan's) without planning, [`simulate`] of every line of
//! any program, and [`report`] turns the answers into documents.
//!
//! ```
//! use maamplan::{collide::{cpu::CpuBackend, Backend}, default_job, scene::{Scene, SceneConfig}};
//!
//! let job = default_job::job();
//! let scene = Scene::build(&job.toolpath, &job.head, &job.platform, &SceneConfig::default()).unwrap();
//! let verdicts = CpuBackend::new(&scene).evaluate(&scene.waypoint_queries).unwrap();
//! assert_eq!(verdicts.len(), job.toolpath.waypoint_count());
//! assert!(verdicts.iter().any(|&c| c), "the embedded default has colliding waypoints");
//! ```
#![warn(missing_docs)]

pub mod check;
pub mod collide;
pub mod default_job;
pub mod errors;
pub mod generate;
pub mod geometry;
pub mod io;
pub mod job;
pub mod kinematics;
pub mod plan;
pub mod program_toolpath;
pub mod prove;
pub mod report;
pub mod scene;
pub mod simulate;
pub mod toolpath;
