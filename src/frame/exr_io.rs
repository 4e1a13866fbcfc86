//! Multi-channel float EXR files for frames.

use std::collections::BTreeMap;
use std::io::Cursor;

use exr::prelude::*;

use super::Frame;

/// Encodes all channels of a frame as 32-bit float EXR bytes. Colour is
/// premultiplied by coverage, as EXR expects (a miss is RGBA 0, 0, 0, 0; the
/// background colour appears in the PNG only), so a compositor lays the
/// render over anything.
pub fn exr_bytes(frame: &Frame) -> std::result::Result<Vec<u8>, String> {
    let premultiplied = |k: usize| frame.color.iter().zip(&frame.alpha).map(|(c, a)| c[k] * a).collect();
    let mut channels: Vec<(String, Vec<f32>)> = vec![
        ("R".into(), premultiplied(0)),
        ("G".into(), premultiplied(1)),
        ("B".into(), premultiplied(2)),
        ("A".into(), frame.alpha.clone()),
        ("Z".into(), frame.depth.clone()),
        ("N.X".into(), frame.normal.iter().map(|n| n.x).collect()),
        ("N.Y".into(), frame.normal.iter().map(|n| n.y).collect()),
        ("N.Z".into(), frame.normal.iter().map(|n| n.z).collect()),
    ];
    channels.extend(frame.extra.iter().cloned());
    channels_exr_bytes(frame.width, frame.height, channels)
}

/// Encodes named row-major float planes of `width × height` as EXR bytes.
pub fn channels_exr_bytes(
    width: u32,
    height: u32,
    channels: Vec<(String, Vec<f32>)>,
) -> std::result::Result<Vec<u8>, String> {
    let list =
        channels.into_iter().map(|(name, v)| AnyChannel::new(name.as_str(), FlatSamples::F32(v))).collect::<Vec<_>>();
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(list)),
    );
    let mut buf = Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut buf).map_err(|e| e.to_string())?;
    Ok(buf.into_inner())
}

/// The float channels of an EXR file by name, with its size.
#[derive(Clone, Debug)]
pub struct ExrChannels {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Channel samples, row-major, by channel name.
    pub channels: BTreeMap<String, Vec<f32>>,
}

/// Reads every channel of the first layer of an EXR file as `f32`.
pub fn read_exr_channels(path: &std::path::Path) -> std::result::Result<ExrChannels, String> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let layer = image.layer_data;
    let channels =
        layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect();
    Ok(ExrChannels { width: layer.size.0, height: layer.size.1, channels })
}
