//! `EXT_meshopt_compression` and `KHR_meshopt_compression`: buffer views stored compressed by
//! meshoptimizer's codecs (what `gltfpack -c` writes). A compressed view names, in its
//! extension, the bytes that encode it (mode ATTRIBUTES: the vertex codec, TRIANGLES: the
//! index codec, INDICES: the index-sequence codec; a filter that undoes the octahedral,
//! quaternion, exponential or colour packing of attributes); the view itself lies in a
//! *fallback* buffer that holds no data of its own (its `uri` absent, the extension marking it
//! `fallback`). The loader gives such a buffer zeroed bytes of its byteLength (counted in the
//! memory budget like any buffer) and decodes every compressed view into its place, so that
//! accessors then read it as they read any view. If the fallback buffer does hold data (a file
//! made for loaders without the extension), the decoded bytes replace it, as the extension asks.
//!
//! Decoded by `meshoptimizer-rs`, a pure-Rust port of meshoptimizer's decoders, writing into
//! the view's own bytes (no allocation): a malformed stream is an error naming the view.

use meshoptimizer_rs::codec;

/// The extensions read here.
pub const EXTENSIONS: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// The meshopt extension object of a buffer or view, and its name.
fn extension(value: impl Fn(&str) -> Option<serde_json::Value>) -> Option<(&'static str, serde_json::Value)> {
    EXTENSIONS.iter().find_map(|&name| value(name).map(|v| (name, v)))
}

/// Whether `buffer` is a meshopt fallback buffer: its data is what the compressed views that
/// lie in it decode to, not anything the file stores.
pub fn is_fallback(buffer: &gltf::Buffer) -> bool {
    extension(|n| buffer.extension_value(n).cloned())
        .is_some_and(|(_, e)| e.get("fallback").and_then(|f| f.as_bool()) == Some(true))
}

/// Decodes every compressed view of `doc` into `buffers` (indexed as the document's). An error
/// is (where, what), `where` a JSON path such as `bufferViews[3].extensions.EXT_meshopt_compression`.
pub fn decode_views(doc: &gltf::Document, buffers: &mut [Vec<u8>]) -> Result<(), (String, String)> {
    let mut workspace = meshoptimizer_rs::Workspace::default();
    for view in doc.views() {
        let Some((name, ext)) = extension(|n| view.extension_value(n).cloned()) else { continue };
        let at = format!("bufferViews[{}].extensions.{name}", view.index());
        let fail = |what: String| (at.clone(), what);
        let field = |key: &str| ext.get(key).and_then(|v| v.as_u64()).and_then(|v| usize::try_from(v).ok());
        let need = |key: &str| field(key).ok_or_else(|| fail(format!("{key} is missing or not a whole number")));
        let (source_buffer, count, stride) = (need("buffer")?, need("count")?, need("byteStride")?);
        let (offset, length) = (field("byteOffset").unwrap_or(0), need("byteLength")?);
        let mode = ext.get("mode").and_then(|m| m.as_str()).unwrap_or("");
        let filter = ext.get("filter").and_then(|m| m.as_str()).unwrap_or("NONE");

        // Where the encoded bytes are, and where the decoded ones go: the whole view, which
        // must be exactly count × byteStride bytes.
        let source = buffers
            .get(source_buffer)
            .and_then(|b| b.get(offset..offset.checked_add(length)?))
            .ok_or_else(|| {
                fail(format!("its bytes ({offset} + {length} of buffers[{source_buffer}]) are out of range"))
            })?
            .to_vec(); // a copy: the source may lie in the buffer the view is decoded into
        let decoded = count.checked_mul(stride).filter(|&n| n == view.length()).ok_or_else(|| {
            fail(format!("count {count} × byteStride {stride} is not the view's byteLength {}", view.length()))
        })?;
        if view.stride().is_some_and(|s| s != stride) {
            return Err(fail(format!("byteStride {stride} is not the view's {}", view.stride().unwrap_or(0))));
        }
        let target = buffers
            .get_mut(view.buffer().index())
            .and_then(|b| b.get_mut(view.offset()..view.offset().checked_add(decoded)?))
            .ok_or_else(|| fail(format!("the view lies outside buffers[{}]", view.buffer().index())))?;

        let known = ["NONE", "OCTAHEDRAL", "QUATERNION", "EXPONENTIAL"];
        if !(known.contains(&filter) || filter == "COLOR" && name == "KHR_meshopt_compression") {
            return Err(fail(format!("filter {filter:?} is not one of {}", known.join(", "))));
        }
        if mode != "ATTRIBUTES" && filter != "NONE" {
            return Err(fail(format!("mode {mode} takes no filter (it has {filter:?})")));
        }
        let ws = &mut workspace;
        let decoding = match mode {
            "ATTRIBUTES" => {
                codec::decode_vertex_buffer_into(target, count, stride, &source, ws).and_then(|()| match filter {
                    "OCTAHEDRAL" => codec::decode_filter_oct(target, count, stride, ws),
                    "QUATERNION" => codec::decode_filter_quat(target, count, stride, ws),
                    "EXPONENTIAL" => codec::decode_filter_exp(target, count, stride, ws),
                    "COLOR" => codec::decode_filter_color(target, count, stride, ws),
                    _ => Ok(()),
                })
            }
            "TRIANGLES" => codec::decode_index_buffer_into(target, count, stride, &source, ws),
            "INDICES" => codec::decode_index_sequence_into(target, count, stride, &source, ws),
            other => return Err(fail(format!("mode {other:?} is not one of ATTRIBUTES, TRIANGLES, INDICES"))),
        };
        decoding.map_err(|e| fail(format!("the compressed {mode} data cannot be decoded ({e:?})")))?;
    }
    Ok(())
}
