//! Geometric primitives shared by every backend and integrator: rays, bounding boxes,
//! triangles, analytic spheres and shading frames.

mod aabb;
mod frame;
mod ray;
mod sphere;
mod triangle;
mod vertex_buffer;

pub use aabb::Aabb;
pub use frame::Frame;
pub use ray::{OFFSET_SCALE, OffsetPoint, Ray, offset_epsilon, offset_origin};
pub use sphere::{Sphere, octahedral_decode, octahedral_encode};
pub use triangle::{TriangleHit, intersect_triangle};
pub use vertex_buffer::VertexBuffer;
