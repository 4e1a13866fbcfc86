//! The index that names a node of the BlobTree arena, shared by the nodes
//! and the blend indices that list them.

/// Index of a node in [`super::Model`]'s arena.
pub type NodeId = u32;
