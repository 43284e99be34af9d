//! Decoding multi-layer EXR bytes into plain layers: shared by the runtime loader and the
//! offline readers, which wrap the failure in their own error types (naming the file).

/// One layer: `width × height` pixels, row 0 first, each channel a flat row-major array.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrLayer {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub channels: Vec<(String, Vec<f32>)>,
}

/// Why bytes did not decode: the field (`layer.channel`) when one is to blame, and a message.
#[derive(Clone, Debug)]
pub struct DecodeError {
    pub field: Option<String>,
    pub message: String,
}

/// Decodes every layer (largest resolution level, flat samples as f32).
pub fn decode_layers(bytes: &[u8]) -> Result<Vec<ExrLayer>, DecodeError> {
    use exr::prelude::{ReadChannels, ReadLayers, read};
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .non_parallel()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| DecodeError { field: None, message: e.to_string() })?;
    let mut out = Vec::new();
    for layer in image.layer_data {
        let name = layer.attributes.layer_name.as_ref().map(|n| n.to_string()).unwrap_or_default();
        let (width, height) = (layer.size.0, layer.size.1);
        let mut channels = Vec::new();
        for ch in layer.channel_data.list {
            let v: Vec<f32> = ch.sample_data.values_as_f32().collect();
            if v.len() != width * height {
                return Err(DecodeError {
                    field: Some(format!("{name}.{}", ch.name)),
                    message: "wrong sample count".into(),
                });
            }
            channels.push((ch.name.to_string(), v));
        }
        out.push(ExrLayer { name, width, height, channels });
    }
    Ok(out)
}
