//! Reading glTF 2.0 back: the JSON document (parsed and validated by the `gltf` crate) and the
//! bytes of each of its buffers, from a GLB's binary chunk, a `data:` URI (base64) or a file
//! beside a `.gltf`.
//!
//! The `gltf` crate's own importer also decodes images, and its `import` feature pulls an
//! image-codec stack into the build; the project reads only geometry and animation, so it
//! resolves buffers here and builds `gltf` without default features.

use std::path::Path;

use gltf::buffer::Source;

/// A glTF document with its buffers' bytes, `buffers[i]` for `document.buffers().nth(i)`.
#[derive(Debug)]
pub struct Loaded {
    /// The validated JSON document.
    pub document: gltf::Document,
    /// Each buffer's bytes, at least its declared `byteLength` long.
    pub buffers: Vec<Vec<u8>>,
}

/// Reads a `.glb` or `.gltf` file; relative buffer URIs resolve against its folder.
pub fn read_file(path: &Path) -> Result<Loaded, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    read_slice(&bytes, path.parent())
}

/// Reads a GLB or glTF JSON held in memory. Buffers in files need `base` (the folder their
/// URIs are relative to); without it only the GLB chunk and `data:` URIs resolve.
pub fn read_slice(bytes: &[u8], base: Option<&Path>) -> Result<Loaded, String> {
    let gltf::Gltf { document, mut blob } =
        gltf::Gltf::from_slice(bytes).map_err(|e| e.to_string())?;
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let data = match buffer.source() {
            Source::Bin => blob.take().ok_or_else(|| {
                "buffer 0 refers to a GLB binary chunk that is missing".to_string()
            })?,
            Source::Uri(uri) => read_uri(uri, base)?,
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {} holds {} bytes, {} declared",
                buffer.index(),
                data.len(),
                buffer.length()
            ));
        }
        buffers.push(data);
    }
    Ok(Loaded { document, buffers })
}

/// The bytes a buffer URI names: a base64 `data:` URI or a percent-encoded relative path.
fn read_uri(uri: &str, base: Option<&Path>) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, payload) = rest
            .split_once(";base64,")
            .ok_or_else(|| "a data: URI that is not base64".to_string())?;
        return decode_base64(payload);
    }
    if uri.contains("://") {
        return Err(format!(
            "buffer URI `{uri}`: only relative files and data: URIs are read"
        ));
    }
    let base =
        base.ok_or_else(|| format!("buffer file `{uri}` without a folder to read it from"))?;
    let path = base.join(percent_decode(uri)?);
    std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Standard base64 (RFC 4648 §4) with optional `=` padding.
fn decode_base64(text: &str) -> Result<Vec<u8>, String> {
    let value = |c: u8| -> Result<u32, String> {
        Ok(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return Err(format!("base64: unexpected byte {c:#04x}")),
        }
        .into())
    };
    let digits = text.trim_end_matches('=').as_bytes();
    if digits.len() % 4 == 1 {
        return Err("base64: truncated".into());
    }
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        let mut bits = 0u32;
        for &c in chunk {
            bits = (bits << 6) | value(c)?;
        }
        bits <<= 6 * (4 - chunk.len() as u32);
        let bytes = bits.to_be_bytes();
        out.extend_from_slice(&bytes[1..chunk.len()]);
    }
    Ok(out)
}

/// `%XX` escapes of a URI path decoded (glTF URIs are RFC 3986).
fn percent_decode(uri: &str) -> Result<String, String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("buffer URI `{uri}`: a bad % escape"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("buffer URI `{uri}`: not UTF-8"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Base64 of every padding length against RFC 4648's test vectors.
    #[test]
    fn base64_matches_the_rfc_vectors() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(decode_base64(coded).unwrap(), plain.as_bytes(), "{coded}");
        }
        assert!(decode_base64("Zm9v!").is_err());
        assert!(decode_base64("Zm9vY").is_err());
    }

    #[test]
    fn percent_escapes_decode() {
        assert_eq!(percent_decode("my%20mesh.bin").unwrap(), "my mesh.bin");
        assert!(percent_decode("bad%2").is_err());
    }

    /// A glTF JSON whose one buffer is a data: URI reads back with its bytes; a buffer shorter
    /// than declared is an error.
    #[test]
    fn data_uri_buffers_resolve() {
        let json = |length: usize| {
            format!(
                r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{length},"uri":"data:application/octet-stream;base64,AAECAw=="}}]}}"#
            )
        };
        let loaded = read_slice(json(4).as_bytes(), None).unwrap();
        assert_eq!(loaded.buffers, vec![vec![0u8, 1, 2, 3]]);
        assert!(read_slice(json(8).as_bytes(), None).is_err());
        let file = json(4).replace("data:application/octet-stream;base64,AAECAw==", "x.bin");
        assert!(
            read_slice(file.as_bytes(), None)
                .unwrap_err()
                .contains("x.bin")
        );
    }
}
