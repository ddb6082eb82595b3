//! Geometric primitives shared by every backend and integrator: rays, bounding boxes,
//! triangles and shading frames.

mod aabb;
mod frame;
mod ray;
mod triangle;
mod vertex_buffer;

pub use aabb::Aabb;
pub use frame::Frame;
pub use ray::{OffsetPoint, Ray, offset_epsilon, offset_origin};
pub use triangle::{TriangleHit, intersect_triangle};
pub use vertex_buffer::VertexBuffer;
