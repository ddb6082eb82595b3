//! Vertex positions stored with one padding vertex after the last, so that the buffer can be
//! handed to Embree without a copy: Embree reads every vertex, the last one included, with a
//! 16-byte load, 4 bytes past a 12-byte `Vec3` (rtcSetSharedGeometryBuffer(3): "the last
//! buffer element must be readable using 16-byte SSE load instructions").

use glam::Vec3;
use std::ops::Deref;

/// Vertex positions; derefs to the real vertices (without the padding).
#[derive(Clone, Debug, PartialEq)]
pub struct VertexBuffer {
    /// The vertices, then one padding vertex (always present).
    data: Vec<Vec3>,
}

impl VertexBuffer {
    /// The vertices followed by the padding vertex, for sharing with native code.
    pub fn padded(&self) -> &[Vec3] {
        &self.data
    }
}

impl Default for VertexBuffer {
    fn default() -> Self {
        VertexBuffer::from(Vec::new())
    }
}

impl From<Vec<Vec3>> for VertexBuffer {
    fn from(mut data: Vec<Vec3>) -> Self {
        data.push(Vec3::ZERO);
        VertexBuffer { data }
    }
}

impl Deref for VertexBuffer {
    type Target = [Vec3];
    fn deref(&self) -> &[Vec3] {
        &self.data[..self.data.len() - 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derefs_to_the_vertices_and_keeps_a_padding_vertex() {
        let v = VertexBuffer::from(vec![Vec3::X, Vec3::Y]);
        assert_eq!(&*v, &[Vec3::X, Vec3::Y]);
        assert_eq!(v.len(), 2);
        assert_eq!(v.padded().len(), 3);
        assert!(VertexBuffer::default().is_empty());
        assert_eq!(VertexBuffer::default().padded().len(), 1);
    }
}
