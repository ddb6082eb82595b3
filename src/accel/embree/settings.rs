//! [`EmbreeSettings`]: how an Embree scene is built and queried.
//!
//! | field | type | default | meaning |
//! |---|---|---|---|
//! | `quality` | [`BuildQuality`] | `Medium` | BVH build quality (`High` ≈ 5× slower build, for long renders) |
//! | `packet_width` | [`PacketWidth`] | `Auto` | width of the packets used by the batch queries, but for a batch's tail, which takes the narrowest that holds it (`Auto`: widest native) |

use std::fmt;
use std::str::FromStr;

use super::sys;

/// BVH build quality (`RTC_BUILD_QUALITY_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BuildQuality {
    /// Fastest build, slower traversal (dynamic scenes).
    Low,
    /// Embree's default: a good build for most renders.
    #[default]
    Medium,
    /// Spatial splits: ~5× slower to build, faster traversal on long renders.
    High,
}

impl BuildQuality {
    pub(super) fn raw(self) -> sys::RTCBuildQuality {
        match self {
            BuildQuality::Low => sys::RTCBuildQuality::RTC_BUILD_QUALITY_LOW,
            BuildQuality::Medium => sys::RTCBuildQuality::RTC_BUILD_QUALITY_MEDIUM,
            BuildQuality::High => sys::RTCBuildQuality::RTC_BUILD_QUALITY_HIGH,
        }
    }
}

impl fmt::Display for BuildQuality {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BuildQuality::Low => "low",
            BuildQuality::Medium => "medium",
            BuildQuality::High => "high",
        })
    }
}

impl FromStr for BuildQuality {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "low" => Ok(BuildQuality::Low),
            "medium" => Ok(BuildQuality::Medium),
            "high" => Ok(BuildQuality::High),
            _ => Err(format!("unknown Embree build quality {s:?} (expected low, medium or high)")),
        }
    }
}

/// The packet width used by `intersect_batch` / `occluded_batch` (a batch's tail goes in the
/// narrowest of 4, 8 and 16 lanes that holds it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PacketWidth {
    /// The widest width the device supports natively (16 with AVX-512, 8 with AVX2, else 4).
    #[default]
    Auto,
    W4,
    W8,
    W16,
}

impl PacketWidth {
    /// The width in lanes, given the device's native widths (widest last).
    pub(super) fn lanes(self, natives: &[usize]) -> usize {
        match self {
            PacketWidth::Auto => natives.last().copied().unwrap_or(4),
            PacketWidth::W4 => 4,
            PacketWidth::W8 => 8,
            PacketWidth::W16 => 16,
        }
    }
}

/// Settings of the Embree backend; see the module docs for the table of defaults.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EmbreeSettings {
    pub quality: BuildQuality,
    pub packet_width: PacketWidth,
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::accel::Accelerator;
    use crate::accel::embree::Embree;
    use crate::accel::embree::scene::test_quad;
    use crate::geometry::Ray;

    #[test]
    fn quality_parses_and_all_qualities_build() {
        let (p, i) = test_quad();
        for q in ["low", "Medium", "HIGH"] {
            let quality: BuildQuality = q.parse().unwrap();
            let e = Embree::with_settings(&p, &i, EmbreeSettings { quality, ..Default::default() }).unwrap();
            assert!(e.occluded(&Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z)));
            assert!(e.describe().contains(&format!("{quality} quality")), "{}", e.describe());
        }
        assert!("ultra".parse::<BuildQuality>().is_err());
    }

    #[test]
    fn packet_widths() {
        assert_eq!(PacketWidth::Auto.lanes(&[4, 8, 16]), 16);
        assert_eq!(PacketWidth::Auto.lanes(&[]), 4);
        assert_eq!(PacketWidth::W8.lanes(&[4]), 8);
    }
}
