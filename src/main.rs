//! The `sparsemor` command: reduce big FE models from disk (see `sparsemor --help`).

mod cli;

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
