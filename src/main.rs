//! The `sparsemor` command: reduce big FE models from disk (see `sparsemor --help`).

mod cli;

fn main() {
    return_large_blocks_to_the_system();
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

/// Fixes glibc's mmap threshold at 1 MiB: every allocation from 1 MiB up is its own mapping,
/// returned to the system when freed. By default the threshold rises to the largest block
/// freed so far (up to 32 MiB), after which the N-sized vectors and supernode buffers of a
/// sweep come from the heap and leave it fragmented. On the 10⁶-DoF bar (`sweep --threads 1`,
/// two frequencies) the peak RSS fell from 4.98 to 4.82 GB and the run took 54 s instead of
/// 60 s (docs/design.md §8). A library leaves the allocator to its host program; the same
/// setting is `MALLOC_MMAP_THRESHOLD_=1048576` in the environment.
fn return_large_blocks_to_the_system() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets an allocator parameter; it runs before any other thread
    // exists, and an unsupported parameter is reported by its return value, ignored here.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 20);
    }
}

/// The ranks of the MPI job this process was started in by `mpirun` (cargo feature `mpi`),
/// or `None`. A panic on any rank then ends every rank (`MPI_Abort`), after its message.
#[cfg(feature = "mpi")]
fn cluster() -> sparsemor::Result<Option<std::sync::Arc<dyn sparsemor::distributed::Cluster>>> {
    use sparsemor::distributed::mpi;
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
fn cluster() -> sparsemor::Result<Option<std::sync::Arc<dyn sparsemor::distributed::Cluster>>> {
    Ok(None)
}
