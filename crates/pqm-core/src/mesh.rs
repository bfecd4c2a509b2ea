//! Half-edge mesh (work in progress in the lead's tree).
/// Vertex handle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct VertexId(pub u32);
/// Face handle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FaceId(pub u32);
/// Half-edge handle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct HalfedgeId(pub u32);
/// Half-edge mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {}
