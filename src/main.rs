//! The `sparsemor` command: reduce big FE models from disk (see `sparsemor --help`).

mod cli;

use std::alloc::{GlobalAlloc, Layout, System};

/// The system allocator, with blocks of [`HUGE`] bytes and more advised to the kernel for
/// transparent huge pages (`madvise(MADV_HUGEPAGE)`; Linux's default THP mode is `madvise`).
/// A large block comes from a fresh mapping, so every 4 KiB page of it costs a page fault
/// on first touch; the responses, bases and projections of a 10⁵–10⁶-DoF body are such
/// blocks, allocated anew per frequency and per step, and huge pages fault 512 times fewer
/// pages for them (the times are in docs/performance.md). Library users get about the same
/// from the environment, `GLIBC_TUNABLES=glibc.malloc.hugetlb=1`.
struct HugePages;

/// Blocks from this size up are advised (two huge pages: at least one lies inside).
const HUGE: usize = 4 << 20;

// SAFETY: every call is forwarded to `System` with its arguments unchanged; the advice
// changes how the kernel backs the pages, not their contents or ownership.
unsafe impl GlobalAlloc for HugePages {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        advise(unsafe { System.alloc(layout) }, layout.size())
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        advise(unsafe { System.alloc_zeroed(layout) }, layout.size())
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        advise(unsafe { System.realloc(ptr, layout, new_size) }, new_size)
    }
}

#[global_allocator]
static ALLOCATOR: HugePages = HugePages;

/// Advises the 2 MiB-aligned interior of the block at `p` of `size` bytes for huge pages
/// when it is at least [`HUGE`]; returns `p`.
fn advise(p: *mut u8, size: usize) -> *mut u8 {
    #[cfg(target_os = "linux")]
    if size >= HUGE && !p.is_null() {
        const PAGE: usize = 2 << 20;
        let start = (p as usize).next_multiple_of(PAGE);
        let end = (p as usize + size) / PAGE * PAGE;
        if end > start {
            // SAFETY: [start, end) lies inside the block just allocated; MADV_HUGEPAGE
            // keeps its contents. The result is advice only: an error (a kernel without
            // THP) leaves the block as it is.
            let _ = unsafe {
                rustix::mm::madvise(
                    start as *mut std::ffi::c_void,
                    end - start,
                    rustix::mm::Advice::LinuxHugepage,
                )
            };
        }
    }
    p
}

fn main() {
    let cluster = match cluster() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let rank = cluster.as_ref().map_or(0, |c| c.rank());
    let result = cli::run(cluster.clone());
    // finalizes MPI (the last reference)
    drop(cluster);
    match result {
        Ok(done) => std::process::exit(done.exit_code()),
        Err(e) => {
            if rank == 0 {
                eprintln!("error: {e}");
            } else {
                eprintln!("error (rank {rank}): {e}");
            }
            std::process::exit(1);
        }
    }
}

/// The ranks of the MPI job this process was started in by `mpirun` (cargo feature `mpi`),
/// or `None`. A panic on any rank then ends every rank (`MPI_Abort`), after its message.
#[cfg(feature = "mpi")]
fn cluster() -> sparsemor::Result<Option<std::sync::Arc<dyn sparsemor::engine::Cluster>>> {
    use sparsemor::engine::mpi;
    let launched = ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
        .iter()
        .any(|v| std::env::var_os(v).is_some());
    if !launched {
        return Ok(None);
    }
    let world = mpi::Mpi::init()?;
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        hook(info);
        mpi::abort(101);
    }));
    Ok(Some(std::sync::Arc::new(world)))
}

#[cfg(not(feature = "mpi"))]
fn cluster() -> sparsemor::Result<Option<std::sync::Arc<dyn sparsemor::engine::Cluster>>> {
    Ok(None)
}
