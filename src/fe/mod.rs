//! Built-in FE generator: a free-free 3-D linear-elastic box (bar, [`BoxSpec`]), the
//! embedded default model of sparsemor, and an L-shaped bracket ([`bracket`]), both meshed
//! with 8-node trilinear hexahedra (`hex8`).

mod bar;
pub mod bracket;
mod hex8;

pub use bar::{
    assemble, bar_model, paper_io_dofs, paper_scene, BoxSpec, FeBody, MAX_ASSEMBLY_BYTES,
    PAPER_BAND_HZ, PAPER_RAYLEIGH_ALPHA, PAPER_RAYLEIGH_BETA,
};
