//! Which backend answers a run's queries: the choice the command line
//! (`--backend auto|gpu|cpu|parry`) and the Python binding offer, and the
//! GPU opened on another thread while the caller loads its scene.

use super::cpu::CpuBackend;
use super::gpu::{GpuBackend, GpuContext, GpuOptions};
use super::parry::ParryBackend;
use super::{Backend, CollideError};
use crate::scene::Scene;

/// The backends a run can choose (`--backend`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendKind {
    /// A hardware GPU when present, the CPU otherwise.
    Auto,
    /// wgpu compute shaders on the best adapter (software ones included).
    Gpu,
    /// Exact BVH + distance-grid evaluator on all CPU cores.
    Cpu,
    /// The same semantics from parry3d's primitives (the reference).
    Parry,
}

impl BackendKind {
    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Auto => "auto",
            BackendKind::Gpu => "gpu",
            BackendKind::Cpu => "cpu",
            BackendKind::Parry => "parry",
        }
    }

    /// Build the backend over `scene`; `announce` says on stderr what `auto` chose.
    pub fn build<'a>(
        self,
        scene: &'a Scene,
        announce: bool,
    ) -> Result<Box<dyn Backend + Send + 'a>, CollideError> {
        self.build_with(Opening::none(), scene, announce, GpuOptions::default())
    }

    /// Start opening the GPU this backend needs (none for cpu and parry) on
    /// another thread, so that it opens while the caller loads the scene:
    /// a driver's start takes a few hundred milliseconds.
    pub fn open(self) -> Opening {
        let hardware_only = match self {
            BackendKind::Auto => true,
            BackendKind::Gpu => false,
            BackendKind::Cpu | BackendKind::Parry => return Opening(None),
        };
        Opening(Some(std::thread::spawn(move || {
            GpuContext::open(hardware_only)
        })))
    }

    /// [`Self::build`] with the GPU `opening` ([`Self::open`], or
    /// [`Opening::none`]), the gpu backend tuned by `gpu` (`bench`'s
    /// tuning flags).
    pub fn build_with<'a>(
        self,
        mut opening: Opening,
        scene: &'a Scene,
        announce: bool,
        gpu: GpuOptions,
    ) -> Result<Box<dyn Backend + Send + 'a>, CollideError> {
        let mut context = || -> Result<Option<GpuContext>, CollideError> {
            match opening.0.take() {
                Some(thread) => thread.join().expect("opening the GPU panicked"),
                None => GpuContext::open(self == BackendKind::Auto),
            }
        };
        Ok(match self {
            BackendKind::Auto => match context() {
                Ok(Some(ctx)) => {
                    let name = format!("{} ({})", ctx.summary.name, ctx.summary.backend);
                    let b = GpuBackend::new(ctx, scene, gpu)?;
                    if announce {
                        eprintln!("backend auto: gpu on {name}");
                    }
                    Box::new(b)
                }
                Ok(None) => {
                    if announce {
                        eprintln!(
                            "backend auto: no hardware GPU, using cpu ({} threads)",
                            rayon::current_num_threads()
                        );
                    }
                    Box::new(CpuBackend::new(scene))
                }
                Err(e) => {
                    eprintln!("backend auto: {e}; using cpu");
                    Box::new(CpuBackend::new(scene))
                }
            },
            BackendKind::Gpu => {
                let ctx = context()?.ok_or(CollideError::NoGpu)?;
                Box::new(GpuBackend::new(ctx, scene, gpu)?)
            }
            BackendKind::Cpu => Box::new(CpuBackend::new(scene)),
            BackendKind::Parry => Box::new(ParryBackend::new(scene)?),
        })
    }
}

/// A GPU context being opened on another thread ([`BackendKind::open`]),
/// or none: then [`BackendKind::build_with`] opens the GPU it needs itself.
pub struct Opening(Option<std::thread::JoinHandle<Result<Option<GpuContext>, CollideError>>>);

impl Opening {
    /// Nothing opened ahead (a caller with no loading to overlap).
    pub fn none() -> Self {
        Opening(None)
    }
}

impl Drop for Opening {
    /// A run that ends before it builds its backend (an input error)
    /// waits for the driver to finish opening: leaving the process while
    /// another thread is inside the driver's start crashes it.
    fn drop(&mut self) {
        if let Some(thread) = self.0.take() {
            let _ = thread.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    /// A run that fails while the GPU is still being opened (an input
    /// error found while the driver loads) returns only once the opening
    /// thread is done: the caller then reports the error (the command
    /// line exits 2) with no other thread inside the driver, whose start
    /// crashes a process that leaves under it. Every command holds its
    /// [`Opening`] as a local, so every `?` between `open` and
    /// `build_with` passes through this drop.
    #[test]
    fn an_input_error_waits_for_the_gpu_being_opened() {
        let opened = Arc::new(AtomicBool::new(false));
        let flag = opened.clone();
        let run = || -> Result<(), String> {
            let _opening = Opening(Some(std::thread::spawn(move || {
                std::thread::sleep(std::time::Duration::from_millis(300));
                flag.store(true, Ordering::SeqCst);
                Ok(None)
            })));
            Err("bad input".into())
        };
        assert_eq!(run().unwrap_err(), "bad input");
        assert!(
            opened.load(Ordering::SeqCst),
            "returned before the GPU opened"
        );
    }
}
