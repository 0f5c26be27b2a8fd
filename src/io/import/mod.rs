//! Reading models written by FE codes (docs/design.md §4, "Importers"): one entry, [`read`],
//! that tells the format of each file from its content (the rules: [`read`]) and hands the set
//! to the reader of that format.
//!
//! | what | files | reader |
//! |---|---|---|
//! | ANSYS binary full file | `Jobname.full` (+ optional node table) | [`ansys::read_full`] |
//! | ANSYS APDL Math export | K, M (`*EXPORT,…,MMF` or `HBMAT`, [`harwell_boeing`]), the DoF mapping vector, a node table | [`ansys::read_apdl_math`] |
//! | Abaqus `*MATRIX OUTPUT` | `*_STIF*.mtx`, `*_MASS*.mtx` (+ the `.inp` deck) | [`abaqus::read`] |
//! | Nastran OUTPUT4 (OP4), ASCII or binary | one or more `.op4` files holding `KAA`/`MAA` (or `KGG`, `KLL`, `KHH` / `MGG`, `MLL`, `MHH`) (+ a DoF map) | [`nastran`], on [`crate::io::op4::read_op4`] |
//! | node coordinate table | rows `node x y z`, any separator, decimal point or comma | [`read_node_table`] |
//!
//! Layout: `types` holds the vocabulary every reader shares ([`Dof`], [`Imported`],
//! [`NodeTable`], ...); each reader has its file and its own content sniffing (`looks_like`);
//! `dispatch` asks the sniffers and calls the readers. The readers import `types` and the
//! text toolkit (`io::text`), never the dispatcher; this file only declares and re-exports.
//!
//! # What comes back
//! [`Imported`]: full-storage M and K in the order of the DoF map, the DoF map itself (node
//! number and direction per DoF, written `17:x`), node coordinates when every node carries the
//! same DoFs, the producer and the units as the files record them (nothing is guessed), and the
//! constrained DoFs that were removed. [`Imported::into_model`] validates it as a
//! [`crate::model::Model`].

pub mod abaqus;
pub mod ansys;
mod dispatch;
pub mod harwell_boeing;
pub mod nastran;
mod node_table;
mod types;

pub use dispatch::read;
pub use node_table::read_node_table;
pub use types::{Direction, Dof, Format, Imported, NodeTable};
