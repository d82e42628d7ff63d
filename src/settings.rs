//! What a render is asked to do beyond the scene: the seed, the sampler, the packet width
//! and whether to skip work that cannot change the image. None of them but the seed and
//! the sampler changes a bit of the image.

use crate::error::{Error, Result};
use crate::sampling::SamplerKind;
use std::fmt;
use std::str::FromStr;

/// Rays traced together: one (the scalar reference tracer), or a SIMD packet of 4 (2x2
/// pixels), 8 (4x2 pixels) or 16 (4x4 pixels). The image is the same bits at every
/// width; only the time changes.
///
/// The default is [`PacketWidth::widest`]: the widest that pays on the instruction set
/// the binary was compiled for.
///
/// ```
/// use raytracer::PacketWidth;
///
/// assert_eq!(PacketWidth::try_from(4)?, PacketWidth::Four);
/// assert_eq!("8".parse::<PacketWidth>()?.rays(), 8);
/// assert!(PacketWidth::try_from(3).is_err());
/// # Ok::<(), raytracer::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PacketWidth {
    /// One ray at a time: the scalar reference tracer.
    Scalar,
    /// Packets of 4 rays (2x2 pixels).
    Four,
    /// Packets of 8 rays (4x2 pixels).
    Eight,
    /// Packets of 16 rays (4x4 pixels).
    Sixteen,
}

impl PacketWidth {
    /// Every width, narrowest first.
    pub const ALL: [PacketWidth; 4] = [
        PacketWidth::Scalar,
        PacketWidth::Four,
        PacketWidth::Eight,
        PacketWidth::Sixteen,
    ];

    /// The widest packet that pays on the binary's instruction set: 16 with AVX-512, 8
    /// with AVX2, else 4 (wider packets then run as halves).
    pub const fn widest() -> PacketWidth {
        if crate::lanes::AVX512 {
            PacketWidth::Sixteen
        } else if crate::lanes::AVX2 {
            PacketWidth::Eight
        } else {
            PacketWidth::Four
        }
    }

    /// Rays a packet holds: 1, 4, 8 or 16.
    pub const fn rays(self) -> u32 {
        match self {
            PacketWidth::Scalar => 1,
            PacketWidth::Four => 4,
            PacketWidth::Eight => 8,
            PacketWidth::Sixteen => 16,
        }
    }
}

impl Default for PacketWidth {
    fn default() -> Self {
        PacketWidth::widest()
    }
}

/// The width of `rays` rays, or [`Error::PacketWidth`] if it is not 1, 4, 8 or 16.
impl TryFrom<u32> for PacketWidth {
    type Error = Error;

    fn try_from(rays: u32) -> Result<Self> {
        match rays {
            1 => Ok(PacketWidth::Scalar),
            4 => Ok(PacketWidth::Four),
            8 => Ok(PacketWidth::Eight),
            16 => Ok(PacketWidth::Sixteen),
            _ => Err(Error::PacketWidth(rays.to_string())),
        }
    }
}

/// Parses `1`, `4`, `8` or `16`.
impl FromStr for PacketWidth {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        s.parse::<u32>()
            .ok()
            .and_then(|n| PacketWidth::try_from(n).ok())
            .ok_or_else(|| Error::PacketWidth(s.to_string()))
    }
}

/// Writes the number of rays (`1`, `4` or `8`).
impl fmt::Display for PacketWidth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.rays())
    }
}

/// How to render: the random numbers (seed and sampler), the packet width and whether to
/// skip work that cannot change the image.
///
/// The default is the fastest configuration with the lowest error at equal time: seed 0,
/// the Sobol sampler, the widest packets, specialisation on.
/// [`RenderSettings::original_sampling`] gives the original program's random numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    /// Seed of the random numbers; a different seed changes the noise only.
    pub seed: u32,
    /// Rays per packet. The image is the same bits at every width.
    pub packet_width: PacketWidth,
    /// Skip what the scene does not need (shadow rays of light samples that add nothing,
    /// packets that miss the scene); the image is the same bits.
    pub specialize: bool,
    /// How pixel jitter, light samples and bounces are spread.
    pub sampler: SamplerKind,
}

impl RenderSettings {
    /// The defaults with seed `seed`.
    pub fn new(seed: u32) -> Self {
        Self {
            seed,
            packet_width: PacketWidth::default(),
            specialize: true,
            sampler: SamplerKind::default(),
        }
    }

    /// The original program's sampling: independent random numbers (seed `seed`), one ray
    /// at a time.
    pub fn original_sampling(seed: u32) -> Self {
        Self {
            packet_width: PacketWidth::Scalar,
            sampler: SamplerKind::Independent,
            ..Self::new(seed)
        }
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self::new(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packet_widths_round_trip_and_reject_the_rest() {
        for w in PacketWidth::ALL {
            assert_eq!(PacketWidth::try_from(w.rays()).unwrap(), w);
            assert_eq!(w.to_string().parse::<PacketWidth>().unwrap(), w);
        }
        for bad in [0, 2, 3, 5, 12, 32, u32::MAX] {
            assert!(PacketWidth::try_from(bad).is_err(), "{bad}");
        }
        for bad in ["", "x", "-1", " 4", "4.0", "08x"] {
            assert!(bad.parse::<PacketWidth>().is_err(), "{bad:?}");
        }
    }

    #[test]
    fn the_default_width_is_the_widest_compiled_in() {
        let expected = if cfg!(target_feature = "avx512f") {
            16
        } else if cfg!(target_feature = "avx2") {
            8
        } else {
            4
        };
        assert_eq!(PacketWidth::default().rays(), expected);
        assert_eq!(RenderSettings::default().packet_width.rays(), expected);
        assert_eq!(RenderSettings::default().sampler, SamplerKind::Sobol);
    }
}
