//! Image sizes: width and height in pixels, bounded so that a frame of every
//! AOV fits in memory; parsed from `WxH` on the command line and from
//! `(w, h)` in scene files.

use std::fmt;

use serde::de::{self, Deserialize, Deserializer};

/// An image size `(width, height)`, each in `1..=16384`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Size(pub u32, pub u32);

/// Largest image side blobtrace accepts.
pub const MAX_SIDE: u32 = 16384;

/// Most pixels an image may have: a frame of every AOV takes 32 bytes a
/// pixel, so this caps one at 2 GiB.
pub const MAX_PIXELS: u64 = 1 << 26;

impl Size {
    /// Parses `WxH` (as on the command line).
    pub fn parse(s: &str) -> Result<Self, String> {
        let (w, h) =
            s.split_once(['x', 'X']).ok_or_else(|| format!("expected WIDTHxHEIGHT such as 640x480, got {s:?}"))?;
        let side = |v: &str| v.trim().parse::<u32>().map_err(|_| format!("{v:?} is not a whole number in {s:?}"));
        Self::checked(side(w)?, side(h)?)
    }

    /// The size `w × h` if each side lies in `1..=MAX_SIDE` and it has at
    /// most [`MAX_PIXELS`] pixels.
    pub fn checked(w: u32, h: u32) -> Result<Self, String> {
        if (1..=MAX_SIDE).contains(&w) && (1..=MAX_SIDE).contains(&h) && u64::from(w) * u64::from(h) <= MAX_PIXELS {
            Ok(Size(w, h))
        } else {
            Err(format!("image size {w}x{h} is out of range (each side 1..={MAX_SIDE}, at most {MAX_PIXELS} pixels)"))
        }
    }
}

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.0, self.1)
    }
}

impl serde::Serialize for Size {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (self.0, self.1).serialize(s)
    }
}

impl<'de> Deserialize<'de> for Size {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (w, h) = <(u32, u32)>::deserialize(d)?;
        Size::checked(w, h).map_err(de::Error::custom)
    }
}
